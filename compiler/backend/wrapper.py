"""Bus wrappers around the core: one register file, two bus front-ends.

``<plant>_regs`` holds the register file, the step sequencer (free run at a divided
clock rate, lockstep bursts of N steps for HiLDE, single steps, soft reset), the input
latch that only reaches the core at a step start, the LO/HI snapshots and one ×4
quadrature decoder (``<plant>_qdec``) per encoder. The wrappers hold what the plant has: a
plant without a quadrature encoder (only sampled converters, or no sensor) gets neither the
``ENC`` register nor the decoder module (:func:`has_encoders`). The bus front-ends only translate
their protocol into one-cycle read and write strobes on word addresses:

* ``<plant>_raptor``: the RAPTOR 2000 module's synchronous local bus
  (``addr``, ``wdata``, ``wr``, ``rd``, ``rdata``, ``ack`` one cycle after a strobe);
* ``<plant>_axil``: an AXI4-Lite slave (OKAY responses, byte strobes ignored).

``<plant>`` is the core's name without its ``_core`` suffix (:func:`module_names`:
``pendulum_core`` gives ``pendulum_regs``, ...). Everything plant-specific (the input, the
reported states, the encoders, their descriptions and register names) comes from the
plant interface the core was built from (:class:`pendc.model.interface.PlantInterface`).

The register map (:func:`register_map`) is the single source of the offsets: the
read multiplexer, the Verilog offset constants, ``report.json`` and
``docs/register_map.md`` all come from it. Its layout (:data:`COMMON_REGISTERS` at the same
offsets on every plant, then the plant's registers in a fixed order) is documented in
``docs/register_map.md`` and checked by ``tests/test_register_layout.py``. As in
:mod:`.emit`, Python prepares every string and the templates only loop and print.
"""

from __future__ import annotations

from . import verilog_text as vtext
from .arith import bits, extend
from .emit import GENERATOR, _env

BUSES = ("raptor", "axi-lite")

# bus -> (module suffix, template)
FRONT_ENDS = {"raptor": ("raptor", "bus_raptor.v.j2"), "axi-lite": ("axil", "bus_axi_lite.v.j2")}
REGS_TEMPLATE = "register_file.v.j2"
QDEC_TEMPLATE = "quadrature_decoder.v.j2"
COUNT_BITS = 32               # an encoder count register

MAGIC = 0x50454E44            # "PEND"
VERSION = 0x0001_0000         # register-map version, major.minor in 16.16
ADDR_WIDTH = 8                # byte-address bits of both buses: 64 words of 32 bits
WORD_BITS = ADDR_WIDTH - 2

STATUS_BITS = (("RUNNING", "CONTROL.RUN"),
               ("BUSY", "a lockstep or single-step burst is in progress, cleared once the new state of its "
                        "last step is on the outputs"),
               ("OVERFLOW", "copy of OVERFLOW.STICKY"))
_PREFIXES = (("", 1.0), ("m", 1e-3), ("\u00b5", 1e-6), ("n", 1e-9))   # SI prefixes (µ: micro)


# The registers at the same byte offset on every plant (0x00, 0x04, ...): everything before the
# plant's own registers. The input's word (``U`` for the default model) is named by the plant;
# None stands for it here.
COMMON_REGISTERS = ("ID", "VERSION", "BUILD_ID", "CONFIG", "CONTROL", "STATUS", "STEP_DIV", "N_STEPS",
                    "STEPS_LEFT", None, "OVERFLOW")


def control_bits(input_register: str) -> tuple:
    """The CONTROL register's bits (the template spells the same positions)."""
    return (("RUN", "rw, free run: one model step every STEP_DIV clock cycles while set"),
            ("LOCKSTEP", "pulse, start a burst of N_STEPS steps (HiLDE lockstep), ignored while "
                         "STATUS.BUSY is set or RUN is written 1 in the same word"),
            ("STEP", "pulse, start a burst of one step, same rules as LOCKSTEP, which wins if both are set"),
            ("SOFT_RESET", "pulse, core back to its initial state, step count, encoder counts and overflow "
                           f"flags zeroed, RUN cleared, a burst aborted, {input_register}, STEP_DIV and N_STEPS kept"))


def module_names(core: str) -> dict:
    """The wrapper modules of core ``core``: ``regs``, ``qdec`` and one per bus, named by the
    core's name without a trailing ``_core`` (``pendulum_core`` -> ``pendulum_regs``, ...)."""
    prefix = core[:-len("_core")] if core.endswith("_core") and core != "_core" else core
    names = {"regs": f"{prefix}_regs", "qdec": f"{prefix}_qdec"}
    names.update({bus: f"{prefix}_{suffix}" for bus, (suffix, _) in FRONT_ENDS.items()})
    return names


def _fmt(p: dict) -> str:
    sign = "signed" if p["signed"] else "unsigned"
    return f"{sign} {p['width']}-bit, {p['frac']} fraction bits"


def _bits(fields) -> str:
    return "; ".join(f"bit {i} {name}: {text}" for i, (name, text) in enumerate(fields))


def _amount(value: float, unit: str) -> str:
    """``value`` ``unit`` with an SI prefix that keeps the number readable: 2.5e-6 m -> "2.5 µm"."""
    for prefix, scale in _PREFIXES:
        if abs(value) / scale >= 0.1:
            return f"{value / scale:.3g} {prefix}{unit}"
    return f"{value:.3g} {unit}"


def _default_interface():
    """The default model's plant interface (for callers that give port formats only)."""
    from ..model.modelfile import load_model
    return load_model().interface


def _channels(interface) -> list:
    """Every encoder line of the plant, in sensor order (A then B)."""
    return [c for sensor in interface.sensors for c in sensor.channels]


def _check_ports(ports: dict, interface) -> None:
    inp = interface.input.name
    names = (inp,) + interface.outputs
    missing = [p for p in names if p not in ports]
    if missing:
        raise ValueError(f"port formats missing for {', '.join(missing)}")
    for p in names:
        w = ports[p].get("width")
        if not isinstance(w, int) or w < 1:
            raise ValueError(f"port {p}: width must be a positive int, got {w!r}")
    if ports[inp]["width"] > 32:
        raise ValueError(f"port {inp} is {ports[inp]['width']} bits; its register holds at most 32")
    for p in interface.outputs:
        if ports[p]["width"] > 64:
            raise ValueError(f"port {p} is {ports[p]['width']} bits; LO/HI register pairs hold at most 64")
    if len(_channels(interface)) > 32:
        raise ValueError(f"{len(_channels(interface))} encoder lines do not fit the 32-bit ENC register")
    for sensor in _converters(interface):
        code_bits(sensor, ports)


def has_encoders(interface) -> bool:
    """True if the plant has a quadrature encoder: only then do the wrappers hold the ``ENC``
    register (its lines) and the x4 decoder module ``<plant>_qdec``."""
    return any(not s.is_adc for s in interface.sensors)


def _converters(interface) -> list:
    """The plant's sampled converters (ADC sensors), in sensor order."""
    return [s for s in interface.sensors if s.is_adc]


def code_bits(sensor, ports: dict) -> tuple:
    """``(hi, lo)``: the bits of converter ``sensor``'s code port that hold its code (the port
    holds the integer code in its Q-format, whose fraction bits are zero); ValueError when the
    port is missing or its format cannot hold every code."""
    f = ports.get(sensor.code_port)
    if f is None:
        raise ValueError(f"port formats missing for {sensor.code_port}")
    lo, hi = f["frac"], f["frac"] + sensor.bits - 1
    if lo < 0 or hi >= f["width"] - (1 if f["signed"] else 0):
        raise ValueError(f"port {sensor.code_port} ({f['width']} bits, {f['frac']} fraction bits) cannot hold "
                         f"a {sensor.bits}-bit code")
    return hi, lo


def status_words(status_nodes) -> list:
    """``(register name, low bit, high bit)`` of the debug build's OVERFLOW_STATUS words."""
    n = len(status_nodes)
    return [(f"OVERFLOW_STATUS_{k}", 32 * k, min(n, 32 * k + 32) - 1) for k in range((n + 31) // 32)]


def register_map(ports: dict, status_nodes=(), interface=None) -> list[dict]:
    """The wrappers' registers: name, byte offset, access, implemented bits, description.

    ``interface``: the plant interface (default: the default model's), whose
    :meth:`~pendc.model.interface.PlantInterface.register_names` name the input's word, each
    reported state's LO/HI pair, each encoder's count and each converter's code.

    Layout: :data:`COMMON_REGISTERS` at offsets 0x00..0x28 on every plant; then the plant's
    registers, one word after another: ``ENC`` (the encoder lines; only a plant with an
    encoder has it), one word per sensor in the plant file's order (an encoder's count, a
    converter's code), ``STEP_COUNT_LO``/``_HI``, each reported state's LO/HI pair. So the
    offsets depend on the plant's sensors and reported states, not on ``ports`` (only widths
    and descriptions do): host software sees one map for every build of a plant. A debug build
    (``status_nodes``: the core's ``overflow_status`` bit order) appends the
    OVERFLOW_STATUS_k words after the map, one sticky bit per node.
    """
    interface = interface or _default_interface()
    _check_ports(ports, interface)
    names = interface.register_names()
    inp = interface.input
    u = ports[inp.name]
    (u_reg,) = names[inp.name]
    channels = _channels(interface)
    regs = [
        ("ID", "ro", 32, f"magic word 0x{MAGIC:08X} (ASCII \"PEND\")"),
        ("VERSION", "ro", 32, f"register-map version 0x{VERSION:08X} (major in bits 31..16, minor in 15..0)"),
        ("BUILD_ID", "ro", 32, "32-bit hash of the generated core files (report.json \"build_id\")"),
        ("CONFIG", "ro", 24, "bits 7..0 ii (clock cycles per model step, minimum STEP_DIV); bits 15..8 width "
                             f"of {inp.name}; bits 23..16 fraction bits of {inp.name} (two's complement)"),
        ("CONTROL", "rw", len(control_bits(u_reg)), _bits(control_bits(u_reg)) + "; pulse bits self-clear and read 0, "
                                                           "writing 0 to RUN stops the free run"),
        ("STATUS", "ro", len(STATUS_BITS), _bits(STATUS_BITS)),
        ("STEP_DIV", "rw", 32, "clock cycles per model step in free run; writes below ii are clamped to "
                               "ii (reset value ii)"),
        ("N_STEPS", "rw", 32, "steps of a lockstep burst started by CONTROL.LOCKSTEP (0: no burst)"),
        ("STEPS_LEFT", "ro", 32, "steps of the current burst not yet started"),
        (u_reg, "rw", u["width"], f"{inp.meaning}, port {inp.name}: {_fmt(u)}, "
                                  f"{'sign' if u['signed'] else 'zero'}-extended to 32 bits; latched into the "
                                  "core only when a step starts"),
        ("OVERFLOW", "w1c", 2, "bit 0 STICKY: w1c, set when the core's flag rises; bit 1 CORE: ro, the core's own "
                               "flag, some node left its Q-format range since the last (soft) reset"),
    ]
    if has_encoders(interface):
        regs.append(("ENC", "ro", len(channels), "current encoder lines: " +
                     "; ".join(f"bit {i} {p.upper()}" for i, p in enumerate(channels))))
    for sensor in interface.sensors:
        unit = interface.state(sensor.state).unit
        if sensor.is_adc:
            regs.append((names[sensor.name][0], "ro", sensor.bits,
                         f"{sensor.body} converter ({sensor.state}), unsigned {sensor.bits}-bit code of the state "
                         f"after the last step: floor((value - lo) * 2^{sensor.bits} / (hi - lo)) clamped to "
                         f"0..{sensor.codes - 1}, range [{sensor.lo:g}, {sensor.hi:g}] {unit} "
                         f"({_amount(sensor.resolution, unit)} per code)"))
            continue
        regs.append((names[sensor.name][0], "ro", COUNT_BITS,
                     f"{sensor.body} encoder ({sensor.state}), signed {COUNT_BITS}-bit x4 quadrature count since "
                     f"the last (soft) reset ({_amount(sensor.resolution, unit)} per count, up when A leads)"))
    regs += [
        ("STEP_COUNT_LO", "ro", 32, "bits 31..0 of the 64-bit count of steps started since the last (soft) "
                                    "reset; reading it latches STEP_COUNT_HI"),
        ("STEP_COUNT_HI", "ro", 32, "bits 63..32 of the step count as latched by the last STEP_COUNT_LO read"),
    ]
    for p in interface.outputs:
        f = ports[p]
        state = interface.state(p)
        lo, hi = names[p]
        what = f"{state.label} {p} ({state.unit}), {_fmt(f)}"
        ext = "sign" if f["signed"] else "zero"
        regs.append((lo, "ro", min(32, f["width"]), f"bits 31..0 of the {ext}-extended {what}; reading it latches {hi}"))
        regs.append((hi, "ro", max(0, f["width"] - 32),
                     f"bits 63..32 of the {ext}-extended {p} as latched by the last {lo} read"))
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


def _check_view(view, ports: dict, interface) -> dict:
    core = _core_ports(view)
    for p in (interface.input.name,) + interface.outputs:
        if p not in core:
            raise ValueError(f"core {view.module} has no port {p}")
        if core[p][1] != ports[p]["width"]:
            raise ValueError(f"port {p}: core has {core[p][1]} bits, port formats say {ports[p]['width']}")
    return core


def _view_interface(view):
    interface = getattr(view, "interface", None)
    if interface is None:
        raise ValueError(f"core {view.module} carries no plant interface (build it from a lowered plant model)")
    return interface


def _decl(width: int, signed: bool) -> tuple:
    return ("signed " if signed else ""), (f"[{width - 1}:0]" if width > 1 else "")


def _regs_context(view, ports: dict, ident: int, registers: list, header: str, status_nodes=()) -> dict:
    interface = _view_interface(view)
    core = _check_view(view, ports, interface)
    modules = module_names(view.module)
    names = interface.register_names()
    inp = interface.input.name
    u = ports[inp]
    uw = u["width"]
    (u_reg,) = names[inp]
    channels = _channels(interface)
    states, reads, snaps = [], [], []
    for p in interface.outputs:
        f = ports[p]
        sign, rng = _decl(f["width"], f["signed"])
        states.append({"name": f"st_{p}", "signed": sign, "range": rng,
                       "ext": f"st_{p}_ext", "ext_rhs": extend(f"st_{p}", f["width"], f["signed"], 64)})
    config = (view.ii & 0xFF) | ((uw & 0xFF) << 8) | ((u["frac"] & 0xFF) << 16)
    pad = 32 - len(channels)
    values = {
        "ID": _hex32(MAGIC), "VERSION": _hex32(VERSION), "BUILD_ID": _hex32(ident), "CONFIG": _hex32(config),
        "CONTROL": "{31'd0, run}",
        "STATUS": "{29'd0, ovf_sticky, busy, run}",
        "STEP_DIV": "step_div", "N_STEPS": "n_steps", "STEPS_LEFT": "steps_left",
        u_reg: "input_ext",
        "OVERFLOW": "{30'd0, core_overflow, ovf_sticky}",
        "STEP_COUNT_LO": "step_count[31:0]", "STEP_COUNT_HI": "step_count_hi",
    }
    if channels:
        values["ENC"] = "{" + (f"{pad}'d0, " if pad else "") + ", ".join(reversed(channels)) + "}"
    decoders, codes = [], []
    for sensor in _converters(interface):
        f = ports[sensor.code_port]
        hi, lo = code_bits(sensor, ports)
        sign, rng = _decl(f["width"], f["signed"])
        wire = sensor.code_port
        pad = 32 - sensor.bits
        values[names[sensor.name][0]] = ("{" + (f"{pad}'d0, " if pad else "") + bits(wire, f["width"], hi, lo) + "}")
        # the port's bits around the code (its sign extension and zero fraction bits) are not read
        rest = ([(f["width"] - 1, hi + 1)] if hi + 1 < f["width"] else []) + ([(lo - 1, 0)] if lo > 0 else [])
        unused = [bits(wire, f["width"], a, b) for a, b in rest]
        codes.append({"name": wire, "signed": sign, "range": rng, "port": sensor.code_port,
                      "unused": ("{" + ", ".join(unused) + "}") if len(unused) > 1 else "".join(unused),
                      "unused_range": _decl(sum(a - b + 1 for a, b in rest), False)[1]})
    for sensor in interface.sensors:
        if sensor.is_adc:
            continue
        count = f"{sensor.name}_count"
        values[names[sensor.name][0]] = count
        a, b = sensor.channels
        decoders.append({"count": count, "lines": vtext.wrap(f"{modules['qdec']} u_qdec_{sensor.state} ",
                                                             f"(.clk(clk), .clr(clear), .a({a}), .b({b}), .count({count}));")})
    for name, lo, hi in status_words(status_nodes):
        w = hi - lo + 1
        values[name] = f"core_status[{hi}:{lo}]" if w == 32 else f"{{{32 - w}'d0, core_status[{hi}:{lo}]}}"
    snapshot = {"STEP_COUNT_LO": ("step_count_hi", "step_count[63:32]")}
    for p in interface.outputs:
        lo, hi = names[p]
        values[lo], values[hi] = f"st_{p}_ext[31:0]", f"st_{p}_hi"
        snapshot[lo] = (f"st_{p}_hi", f"st_{p}_ext[63:32]")
    for r in registers:
        name = r["name"]
        entry = {"addr": f"A_{name}", "value": values[name], "snap": "", "snap_value": ""}
        if name in snapshot:
            entry.update(snap=snapshot[name][0], snap_value=snapshot[name][1])
            snaps.append(snapshot[name][0])
        reads.append(entry)
    conns = [".clk(clk)", ".rst(core_rst)", ".step(core_step)", ".ready(core_ready)", f".{inp}(core_input)"]
    conns += [f".{p}(st_{p})" for p in interface.outputs]
    conns += [f".{p}({p})" for p in channels if p in core]
    conns += [f".{c['port']}({c['name']})" for c in codes if c["port"] in core]
    if status_nodes:
        from .emit import status_nodes as core_status_nodes
        if list(status_nodes) != core_status_nodes(view):
            raise ValueError(f"the overflow status nodes are not those of core {view.module}'s debug build")
        conns.append(".overflow_status(core_status)")
    conns.append(".overflow(core_overflow)")
    u_sign, u_range = _decl(uw, u["signed"])
    return {
        "header": header, "module": modules["regs"], "core": view.module, "qdec": modules["qdec"], "ii": view.ii,
        "word_msb": WORD_BITS - 1, "ii_lit": f"32'd{view.ii}",
        "params": [{"name": f"A_{r['name']}", "value": _word(r["offset"])} for r in registers],
        "input_addr": f"A_{u_reg}", "input_name": inp,
        "u_signed": u_sign, "u_range": u_range,
        "u_wdata": f"wdata[{uw - 1}:0]" if uw > 1 else "wdata[0]", "u_zero": f"{uw}'d0",
        "u_ext": extend("input_reg", uw, u["signed"], 32),
        "states": states, "reads": reads, "snaps": snaps,
        "core_conns": [{"text": c, "sep": "," if i < len(conns) - 1 else ""} for i, c in enumerate(conns)],
        "enc_ties": [p for p in channels if p not in core],
        "encoders": channels, "decoders": decoders, "codes": codes,
        "status_msb": len(status_nodes) - 1,
    }


def render_wrapper(view, ports: dict, build_id: int, bus: str, status_nodes=()) -> tuple[dict, dict]:
    """The wrapper's files for ``bus`` as ``{filename: text}`` and ``{"module", "registers"}``;
    ``view``: the core's view-model, whose plant interface lays out the registers;
    ``status_nodes`` (a debug build's :func:`pendc.backend.emit.status_nodes`): the core's
    ``overflow_status`` is readable as OVERFLOW_STATUS_k words on both buses."""
    if bus not in FRONT_ENDS:
        raise ValueError(f"unknown bus {bus!r}; choose one of {', '.join(BUSES)}")
    interface = _view_interface(view)
    status_nodes = list(status_nodes)
    registers = register_map(ports, status_nodes, interface)
    modules = module_names(view.module)
    top, template = modules[bus], FRONT_ENDS[bus][1]
    header = f"Generated by {GENERATOR} (build 0x{build_id & 0xFFFFFFFF:08x}); do not edit."
    env = _env()
    regs = _regs_context(view, ports, build_id, registers, header, status_nodes)
    common = {"header": header, "regs": modules["regs"], "addr_msb": ADDR_WIDTH - 1, "word_msb": WORD_BITS - 1,
              "word_zero": f"{WORD_BITS}'d0", "core": view.module, "encoders": _channels(interface)}
    files = {f"{modules['regs']}.v": env.get_template(REGS_TEMPLATE).render(**regs)}
    if has_encoders(interface):     # the decoder module only where the register file instantiates it
        files[f"{modules['qdec']}.v"] = env.get_template(QDEC_TEMPLATE).render(header=header, module=modules["qdec"])
    files[f"{top}.v"] = env.get_template(template).render(module=top, **common)
    return files, {"module": top, "registers": registers}


def markdown_table(registers: list) -> str:
    """The register map as a Markdown table (``docs/register_map.md``)."""
    rows = ["| offset | name | access | bits | description |", "|---|---|---|---|---|"]
    for r in registers:
        rows.append(f"| 0x{r['offset']:02X} | `{r['name']}` | {r['access']} | {r['width']} | {r['description']} |")
    return "\n".join(rows) + "\n"
