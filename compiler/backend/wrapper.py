"""Bus wrappers around the core: one register file, two bus front-ends.

``pendulum_regs`` holds the register file, the step sequencer (free run at a divided
clock rate, lockstep bursts of N steps for HiLDE, single steps, soft reset), the U
latch that only reaches the core at a step start, the LO/HI snapshots and two ×4
quadrature decoders (``pendulum_qdec``). The bus front-ends only translate their
protocol into one-cycle read and write strobes on word addresses:

* ``pendulum_raptor``: the RAPTOR 2000 module's synchronous local bus
  (``addr``, ``wdata``, ``wr``, ``rd``, ``rdata``, ``ack`` one cycle after a strobe);
* ``pendulum_axil``: an AXI4-Lite slave (OKAY responses, byte strobes ignored).

The register map (:func:`register_map`) is the single source of the offsets: the
read multiplexer, the Verilog offset constants, ``report.json`` and
``docs/register_map.md`` all come from it. As in :mod:`.emit`, Python prepares every
string and the templates only loop and print.
"""

from __future__ import annotations

from .arith import extend
from .emit import GENERATOR, _env
from .viewmodel import ENCODER_PORTS, STATE_PORTS

BUSES = ("raptor", "axi-lite")

FRONT_ENDS = {"raptor": ("pendulum_raptor", "pendulum_raptor.v.j2"),
              "axi-lite": ("pendulum_axil", "pendulum_axil.v.j2")}
REGS_MODULE = "pendulum_regs"
QDEC_MODULE = "pendulum_qdec"

MAGIC = 0x50454E44            # "PEND"
VERSION = 0x0001_0000         # register-map version, major.minor in 16.16
ADDR_WIDTH = 8                # byte-address bits of both buses: 64 words of 32 bits
WORD_BITS = ADDR_WIDTH - 2

UNITS = {"u": "V", "x": "m", "dx": "m/s", "theta": "rad", "dtheta": "rad/s"}
MEANING = {"x": "cart position", "dx": "cart velocity", "theta": "pendulum angle",
           "dtheta": "pendulum angular velocity"}

# CONTROL bits (the template spells the same positions)
CONTROL_BITS = (("RUN", "rw, free run: one model step every STEP_DIV clock cycles while set"),
                ("LOCKSTEP", "pulse, start a burst of N_STEPS steps (HiLDE lockstep), ignored while "
                             "STATUS.BUSY is set or RUN is written 1 in the same word"),
                ("STEP", "pulse, start a burst of one step, same rules as LOCKSTEP, which wins if both are set"),
                ("SOFT_RESET", "pulse, core back to its initial state, step count, encoder counts and overflow "
                               "flags zeroed, RUN cleared, a burst aborted, U, STEP_DIV and N_STEPS kept"))
STATUS_BITS = (("RUNNING", "CONTROL.RUN"),
               ("BUSY", "a lockstep or single-step burst is in progress, cleared once the new state of its "
                        "last step is on the outputs"),
               ("OVERFLOW", "copy of OVERFLOW.STICKY"))


def _fmt(p: dict) -> str:
    sign = "signed" if p["signed"] else "unsigned"
    return f"{sign} {p['width']}-bit, {p['frac']} fraction bits"


def _bits(fields) -> str:
    return "; ".join(f"bit {i} {name}: {text}" for i, (name, text) in enumerate(fields))


def _check_ports(ports: dict) -> None:
    missing = [p for p in ("u",) + STATE_PORTS if p not in ports]
    if missing:
        raise ValueError(f"port formats missing for {', '.join(missing)}")
    for p in ("u",) + STATE_PORTS:
        w = ports[p].get("width")
        if not isinstance(w, int) or w < 1:
            raise ValueError(f"port {p}: width must be a positive int, got {w!r}")
    if ports["u"]["width"] > 32:
        raise ValueError(f"port u is {ports['u']['width']} bits; the U register holds at most 32")
    for p in STATE_PORTS:
        if ports[p]["width"] > 64:
            raise ValueError(f"port {p} is {ports[p]['width']} bits; LO/HI register pairs hold at most 64")


def status_words(status_nodes) -> list:
    """``(register name, low bit, high bit)`` of the debug build's OVERFLOW_STATUS words."""
    n = len(status_nodes)
    return [(f"OVERFLOW_STATUS_{k}", 32 * k, min(n, 32 * k + 32) - 1) for k in range((n + 31) // 32)]


def register_map(ports: dict, status_nodes=()) -> list[dict]:
    """The wrappers' registers: name, byte offset, access, implemented bits, description.

    Offsets do not depend on ``ports`` (only widths and descriptions do), so host
    software sees one map for every model. A debug build (``status_nodes``: the core's
    ``overflow_status`` bit order) appends the OVERFLOW_STATUS_k words after the map, one
    sticky bit per node.
    """
    _check_ports(ports)
    u = ports["u"]
    regs = [
        ("ID", "ro", 32, f"magic word 0x{MAGIC:08X} (ASCII \"PEND\")"),
        ("VERSION", "ro", 32, f"register-map version 0x{VERSION:08X} (major in bits 31..16, minor in 15..0)"),
        ("BUILD_ID", "ro", 32, "32-bit hash of the generated core files (report.json \"build_id\")"),
        ("CONFIG", "ro", 24, "bits 7..0 ii (clock cycles per model step, minimum STEP_DIV); bits 15..8 width "
                             "of u; bits 23..16 fraction bits of u (two's complement)"),
        ("CONTROL", "rw", len(CONTROL_BITS), _bits(CONTROL_BITS) + "; pulse bits self-clear and read 0, "
                                                     "writing 0 to RUN stops the free run"),
        ("STATUS", "ro", len(STATUS_BITS), _bits(STATUS_BITS)),
        ("STEP_DIV", "rw", 32, "clock cycles per model step in free run; writes below ii are clamped to "
                               "ii (reset value ii)"),
        ("N_STEPS", "rw", 32, "steps of a lockstep burst started by CONTROL.LOCKSTEP (0: no burst)"),
        ("STEPS_LEFT", "ro", 32, "steps of the current burst not yet started"),
        ("U", "rw", u["width"], f"input voltage u ({UNITS['u']}), {_fmt(u)}, "
                                f"{'sign' if u['signed'] else 'zero'}-extended to 32 bits; latched into the "
                                "core only when a step starts"),
        ("OVERFLOW", "w1c", 2, "bit 0 STICKY: w1c, set when the core's flag rises; bit 1 CORE: ro, the core's own "
                               "flag, some node left its Q-format range since the last (soft) reset"),
        ("ENC", "ro", len(ENCODER_PORTS), "current encoder lines: " +
         "; ".join(f"bit {i} {p.upper()}" for i, p in enumerate(ENCODER_PORTS))),
        ("ENC_X_COUNT", "ro", 32, "cart encoder, signed 32-bit x4 quadrature count since the last (soft) "
                                  "reset (2.5 um per count, up when A leads)"),
        ("ENC_THETA_COUNT", "ro", 32, "pendulum encoder, signed 32-bit x4 quadrature count since the last "
                                      "(soft) reset (0.314 mrad per count, up when A leads)"),
        ("STEP_COUNT_LO", "ro", 32, "bits 31..0 of the 64-bit count of steps started since the last (soft) "
                                    "reset; reading it latches STEP_COUNT_HI"),
        ("STEP_COUNT_HI", "ro", 32, "bits 63..32 of the step count as latched by the last STEP_COUNT_LO read"),
    ]
    for p in STATE_PORTS:
        f = ports[p]
        what = f"{MEANING[p]} {p} ({UNITS[p]}), {_fmt(f)}"
        ext = "sign" if f["signed"] else "zero"
        regs.append((f"{p.upper()}_LO", "ro", min(32, f["width"]),
                     f"bits 31..0 of the {ext}-extended {what}; reading it latches {p.upper()}_HI"))
        regs.append((f"{p.upper()}_HI", "ro", max(0, f["width"] - 32),
                     f"bits 63..32 of the {ext}-extended {p} as latched by the last {p.upper()}_LO read"))
    for name, lo, hi in status_words(status_nodes):
        bits = "; ".join(f"bit {i - lo} {status_nodes[i]}" for i in range(lo, hi + 1))
        regs.append((name, "ro", hi - lo + 1, f"debug build: sticky overflow bits of nodes {lo}..{hi} of the "
                                              f"core's overflow_status, set at the end of the step in which the "
                                              f"node left its Q-format range, cleared by a (soft) reset: {bits}"))
    if len(regs) > 1 << WORD_BITS:
        raise ValueError(f"{len(regs)} registers do not fit the {1 << WORD_BITS} words of the address space "
                         f"({len(status_nodes)} overflow status bits)")
    return [{"name": n, "offset": 4 * i, "access": a, "width": w, "description": d}
            for i, (n, a, w, d) in enumerate(regs)]


def _word(offset: int) -> str:
    return f"{WORD_BITS}'d{offset // 4}"


def _hex32(value: int) -> str:
    return f"32'h{value & 0xFFFFFFFF:08x}"


def _core_ports(view) -> dict:
    return {name: (direction, width, signed) for direction, name, width, signed in view.ports}


def _check_view(view, ports: dict) -> dict:
    core = _core_ports(view)
    for p in ("u",) + STATE_PORTS:
        if p not in core:
            raise ValueError(f"core {view.module} has no port {p}")
        if core[p][1] != ports[p]["width"]:
            raise ValueError(f"port {p}: core has {core[p][1]} bits, port formats say {ports[p]['width']}")
    return core


def _regs_context(view, ports: dict, ident: int, registers: list, header: str, status_nodes=()) -> dict:
    core = _check_view(view, ports)
    u = ports["u"]
    uw = u["width"]
    states, reads, snaps = [], [], []
    for p in STATE_PORTS:
        f = ports[p]
        states.append({"name": f"st_{p}", "signed": "signed " if f["signed"] else "",
                       "range": f"[{f['width'] - 1}:0]" if f["width"] > 1 else "",
                       "ext": f"st_{p}_ext", "ext_rhs": extend(f"st_{p}", f["width"], f["signed"], 64)})
    config = (view.ii & 0xFF) | ((uw & 0xFF) << 8) | ((u["frac"] & 0xFF) << 16)
    values = {
        "ID": _hex32(MAGIC), "VERSION": _hex32(VERSION), "BUILD_ID": _hex32(ident), "CONFIG": _hex32(config),
        "CONTROL": "{31'd0, run}",
        "STATUS": "{29'd0, ovf_sticky, busy, run}",
        "STEP_DIV": "step_div", "N_STEPS": "n_steps", "STEPS_LEFT": "steps_left",
        "U": "u_ext",
        "OVERFLOW": "{30'd0, core_overflow, ovf_sticky}",
        "ENC": "{28'd0, " + ", ".join(reversed(ENCODER_PORTS)) + "}",
        "ENC_X_COUNT": "enc_x_count", "ENC_THETA_COUNT": "enc_theta_count",
        "STEP_COUNT_LO": "step_count[31:0]", "STEP_COUNT_HI": "step_count_hi",
    }
    for name, lo, hi in status_words(status_nodes):
        w = hi - lo + 1
        values[name] = f"core_status[{hi}:{lo}]" if w == 32 else f"{{{32 - w}'d0, core_status[{hi}:{lo}]}}"
    pairs = {"STEP_COUNT": "step_count"}
    for p in STATE_PORTS:
        values[f"{p.upper()}_LO"] = f"st_{p}_ext[31:0]"
        values[f"{p.upper()}_HI"] = f"st_{p}_hi"
        pairs[p.upper()] = f"st_{p}_ext"
    for r in registers:
        name = r["name"]
        entry = {"addr": f"A_{name}", "value": values[name], "snap": "", "snap_value": ""}
        if name.endswith("_LO") and name[:-3] in pairs:
            hi = values[name[:-3] + "_HI"]
            entry.update(snap=hi, snap_value=f"{pairs[name[:-3]]}[63:32]")
            snaps.append(hi)
        reads.append(entry)
    conns = [".clk(clk)", ".rst(core_rst)", ".step(core_step)", ".ready(core_ready)", ".u(core_u)"]
    conns += [f".{p}(st_{p})" for p in STATE_PORTS]
    conns += [f".{p}({p})" for p in ENCODER_PORTS if p in core]
    if status_nodes:
        from .emit import status_nodes as core_status_nodes
        if list(status_nodes) != core_status_nodes(view):
            raise ValueError(f"the overflow status nodes are not those of core {view.module}'s debug build")
        conns.append(".overflow_status(core_status)")
    conns.append(".overflow(core_overflow)")
    return {
        "header": header, "module": REGS_MODULE, "core": view.module, "qdec": QDEC_MODULE, "ii": view.ii,
        "word_msb": WORD_BITS - 1, "ii_lit": f"32'd{view.ii}",
        "params": [{"name": f"A_{r['name']}", "value": _word(r["offset"])} for r in registers],
        "u_signed": "signed " if u["signed"] else "", "u_range": f"[{uw - 1}:0]" if uw > 1 else "",
        "u_wdata": f"wdata[{uw - 1}:0]" if uw > 1 else "wdata[0]", "u_zero": f"{uw}'d0",
        "u_ext": extend("u_reg", uw, u["signed"], 32),
        "states": states, "reads": reads, "snaps": snaps,
        "core_conns": [{"text": c, "sep": "," if i < len(conns) - 1 else ""} for i, c in enumerate(conns)],
        "enc_ties": [p for p in ENCODER_PORTS if p not in core],
        "encoders": list(ENCODER_PORTS),
        "status_msb": len(status_nodes) - 1,
    }


def render_wrapper(view, ports: dict, build_id: int, bus: str, status_nodes=()) -> tuple[dict, dict]:
    """The wrapper's files for ``bus`` as ``{filename: text}`` and ``{"module", "registers"}``;
    ``status_nodes`` (a debug build's :func:`pendc.backend.emit.status_nodes`): the core's
    ``overflow_status`` is readable as OVERFLOW_STATUS_k words on both buses."""
    if bus not in FRONT_ENDS:
        raise ValueError(f"unknown bus {bus!r}; choose one of {', '.join(BUSES)}")
    status_nodes = list(status_nodes)
    registers = register_map(ports, status_nodes)
    top, template = FRONT_ENDS[bus]
    header = f"Generated by {GENERATOR} (build 0x{build_id & 0xFFFFFFFF:08x}); do not edit."
    env = _env()
    regs = _regs_context(view, ports, build_id, registers, header, status_nodes)
    common = {"header": header, "regs": REGS_MODULE, "addr_msb": ADDR_WIDTH - 1, "word_msb": WORD_BITS - 1,
              "word_zero": f"{WORD_BITS}'d0", "core": view.module, "encoders": list(ENCODER_PORTS)}
    files = {
        f"{REGS_MODULE}.v": env.get_template("pendulum_regs.v.j2").render(**regs),
        f"{QDEC_MODULE}.v": env.get_template("pendulum_qdec.v.j2").render(header=header, module=QDEC_MODULE),
        f"{top}.v": env.get_template(template).render(module=top, **common),
    }
    return files, {"module": top, "registers": registers}


def markdown_table(registers: list) -> str:
    """The register map as a Markdown table (``docs/register_map.md``)."""
    rows = ["| offset | name | access | bits | description |", "|---|---|---|---|---|"]
    for r in registers:
        rows.append(f"| 0x{r['offset']:02X} | `{r['name']}` | {r['access']} | {r['width']} | {r['description']} |")
    return "\n".join(rows) + "\n"
