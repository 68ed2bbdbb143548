"""From a typed IR graph to the flat view-model the Verilog templates print.

Timing of one model step (``ii`` clock cycles, from a :class:`pendc.passes.schedule.Schedule`;
without one, the combinational schedule: ``ii = 1 + number of table stages``): a step
request is accepted when ``ready`` is high (cycle 0); every table is a synchronous ROM
whose address is read at the end of its address cycle; nodes run in their scheduled
cycle (pipeline registers and shared multipliers: :mod:`.timing`); in the last cycle
the state registers and FSMs update. ``u`` must be held from the accepting cycle to the last.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..ir import fsm as fsm_sem
from ..ir import lut as lut_sem
from ..ir.graph import Graph
from ..ir.nodes import Kind
from ..ir.qformat import Overflow, QFormat, Rounding
from ..passes.resources import slope_bits
from ..passes.schedule import Schedule, schedule_graph
from .arith import (Netlist, aligned, bits, extend, literal, operand_width, requantize, signed_width, ulit,
                    wrap_signed)
from .timing import Datapath

STATE_PORTS = ("x", "dx", "theta", "dtheta")
# names the core template declares itself (templates/pendulum_core.v.j2), besides the ports
TEMPLATE_NAMES = ("clk", "rst", "step", "ready", "overflow", "phase", "last", "overflow_hit", "overflow_r",
                  "overflow_status", "overflow_status_r")
ENCODER_PORTS = ("enc_x_a", "enc_x_b", "enc_theta_a", "enc_theta_b")


@dataclass
class Rom:
    name: str          # module name
    inst: str
    addr_width: int
    data_width: int
    words: list        # hex strings, index = address
    addr: str          # address wire in the core
    q: str             # registered data wire in the core
    en: str            # read enable: the cycle the address is valid in (the word then holds until the next step)


@dataclass
class CoreView:
    module: str
    ii: int
    phase_width: int
    ports: list                       # (direction, name, width, signed)
    net: Netlist
    registers: list = field(default_factory=list)   # (name, width, signed, reset literal, next)
    fsms: list = field(default_factory=list)        # dict(name, state_width, reset, input, rules, ...)
    roms: list = field(default_factory=list)
    lut_regs: list = field(default_factory=list)    # (name, width, source, enable) registered beside a ROM
    outputs: list = field(default_factory=list)     # (port, wire)
    dp: Datapath | None = None                      # pipeline registers, shared units, overflow gating


def sig(name: str) -> str:
    return f"n_{name}"


def table_stages(graph: Graph) -> dict:
    """Stage of every LUT: 1 + the largest stage of the LUTs feeding its address."""
    stage: dict = {}
    for n in graph.nodes:
        upstream = [stage[i] for i in n.inputs if i in stage]
        if n.kind is Kind.LUT:
            stage[n.name] = 1 + max(upstream, default=0)
        elif upstream and n.kind not in (Kind.REGISTER, Kind.FSM):
            stage[n.name] = max(upstream)
    return {n.name: stage[n.name] for n in graph.of_kind(Kind.LUT)}


def build_view(graph: Graph, module: str = "pendulum_core", schedule: Schedule | None = None) -> CoreView:
    """The view-model of the core for ``schedule`` (default: combinational between table reads)."""
    schedule = schedule or schedule_graph(graph)
    ii = schedule.ii
    net = Netlist()
    for name in TEMPLATE_NAMES + ("u",) + STATE_PORTS + ENCODER_PORTS:
        net.claim(name)
    for n in graph.nodes:       # node values first: every helper name is allocated around them
        net.claim(sig(n.name))
    view = CoreView(module=module, ii=ii, phase_width=max(1, (ii - 1).bit_length()), ports=[], net=net)
    view.dp = Datapath(schedule, net, {n.name: n.kind for n in graph.nodes}, view.phase_width)
    u = graph["u"].qformat
    view.ports = [("input", "u", u.width, True)]
    for port in STATE_PORTS:
        f = graph.output(port).qformat
        view.ports.append(("output", port, f.width, True))
    for port in ENCODER_PORTS:
        if any(p == port for p, _ in graph.outputs):
            view.ports.append(("output", port, 1, False))
    for n in graph.nodes:
        _emit_node(view, graph, n)
    view.dp.finish()
    view.outputs = [(p, sig(node)) for p, node in graph.outputs]
    return view


def _use_cycle(view: CoreView, n) -> int:
    """The cycle a node reads its inputs in."""
    if n.kind in (Kind.REGISTER, Kind.FSM):
        return view.ii - 1
    if n.kind is Kind.LUT:
        return view.dp.schedule.lut_addr[n.name]
    return view.dp.schedule.stage.get(n.name, 0)


def _emit_node(view: CoreView, graph: Graph, n) -> None:
    net = view.net
    out: QFormat = n.qformat
    name = sig(n.name)
    ins = [graph[i] for i in n.inputs]
    a = [view.dp.ref(i, _use_cycle(view, n), sig(i)) for i in n.inputs]
    f = [i.qformat for i in ins]
    k = n.kind
    if k is Kind.CONST:
        net.wire(name, out.width, literal(out.from_float(n.param("value")), out.width), own=True)
    elif k is Kind.INPUT:
        net.wire(name, out.width, n.param("port"), own=True)
    elif k is Kind.REGISTER:
        view.registers.append((name, out.width, literal(out.from_float(n.param("reset")), out.width), a[0]))
    elif k is Kind.FSM:
        _emit_fsm(view, n, a[0], f[0])
    elif k in (Kind.GAIN, Kind.MUL):
        if k is Kind.GAIN:
            c = QFormat.parse(n.param("cfmt"))
            second = (None, c.width, c.from_float(n.param("value")), True)
            frac = f[0].frac + c.frac
        else:
            second = (a[1], f[1].width, None, f[1].signed)
            frac = f[0].frac + f[1].frac
        x, width = view.dp.product(name, n.name, (a[0], f[0].width, None, f[0].signed), second)
        requantize(net, name, x, width, frac, out, n.rounding, n.overflow, n.name, result=name)
    elif k in (Kind.ADD, Kind.SUB, Kind.COMPARE):
        frac = max(q.frac for q in f)
        width = max(operand_width(q) - q.frac for q in f) + frac + 1     # signed integer bits + carry
        ea, eb = (net.wire(f"{name}_{t}", width, aligned(s, q, frac, width)) for t, s, q in zip("ab", a, f))
        if k is Kind.COMPARE:
            ops = {"lt": "<", "le": "<=", "gt": ">", "ge": ">=", "eq": "==", "ne": "!="}
            net.wire(name, 1, f"$signed({ea}) {ops[n.param('op')]} $signed({eb})", signed=False, own=True)
        else:
            x = net.wire(f"{name}_x", width, f"{ea} {'+' if k is Kind.ADD else '-'} {eb}")
            requantize(net, name, x, width, frac, out, n.rounding, n.overflow, n.name, result=name)
    elif k is Kind.NEG:
        width = f[0].width + 1
        x = net.wire(f"{name}_x", width, f"{ulit(0, width)} - {extend(a[0], f[0].width, f[0].signed, width)}")
        requantize(net, name, x, width, f[0].frac, out, n.rounding, n.overflow, n.name, result=name)
    elif k is Kind.CAST:
        requantize(net, name, a[0], f[0].width, f[0].frac, out, n.rounding, n.overflow, n.name,
                   signed=f[0].signed, result=name)
    elif k is Kind.SLICE:
        hi, lo = n.param("hi"), n.param("lo")
        hi, lo = (f[0].width - 1, f[0].width - 1) if hi == lo == -1 else (hi, lo)
        net.wire(name, out.width, bits(a[0], f[0].width, hi, lo), signed=False, own=True)
    elif k is Kind.MUX:
        sel, sel_w = a[0], f[0].width
        last = len(a) - 2
        choices = []
        for j, (s, q) in enumerate(zip(a[1:], f[1:])):
            before = len(net.overflow)
            choices.append(requantize(net, f"{name}_in{j}", s, q.width, q.frac, out, n.rounding, n.overflow, n.name,
                                      signed=q.signed))
            # only the selected input can overflow the mux (as in the interpreter); a select
            # beyond the data inputs selects the last one (pendc.ir.nodes)
            picked = (f"({sel} >= {ulit(j, sel_w)})" if j == last and last < (1 << sel_w) - 1
                      else f"({sel} == {ulit(j, sel_w)})")
            for k in range(before, len(net.overflow)):
                ovf, node = net.overflow[k]
                gated = net.wire(f"{ovf}_sel", 1, f"{ovf} & {picked}", signed=False)
                net.overflow[k] = (gated, node)
        rhs = choices[-1]
        for j in range(len(choices) - 2, -1, -1):
            rhs = f"({sel} == {ulit(j, sel_w)}) ? {choices[j]} : {rhs}"
        net.wire(name, out.width, rhs, own=True)
    elif k is Kind.LUT:
        _emit_lut(view, n, a[0], f[0])
    else:
        raise ValueError(f"no Verilog for node kind {k}")


def _emit_fsm(view: CoreView, n, inp: str, fin: QFormat) -> None:
    states = n.param("states")
    sw = max(1, (len(states) - 1).bit_length())
    ow = n.qformat.width
    state = view.net.fresh(f"{sig(n.name)}_state")
    ops = dict(lt="<", le="<=", gt=">", ge=">=")
    rules = []
    for src, op, threshold, dst in n.param("transitions"):
        t = fsm_sem.threshold_int(threshold, fin)
        fixed = fsm_sem.constant_outcome(op, t, fin)     # a threshold beyond the input's range
        if fixed is False:
            continue                                      # never fires
        cond = "1'b1" if fixed else f"{_wide(inp, fin)} {ops[op]} $signed({literal(t, fin.width + 1)})"
        if src != "*":
            at = f"({state} == {ulit(states.index(src), sw)})"
            cond = at if fixed else f"{at} && {cond}"
        rules.append((cond, ulit(states.index(dst), sw)))
    word = ulit(n.param("outputs")[-1], ow)
    for i in range(len(states) - 2, -1, -1):
        word = f"({state} == {ulit(i, sw)}) ? {ulit(n.param('outputs')[i], ow)} : {word}"
    view.net.wire(sig(n.name), ow, word, signed=False, own=True)
    checks = []
    for op, bound in (("lt", n.param("lo")), ("gt", n.param("hi"))):
        t = fsm_sem.threshold_int(bound, fin)
        fixed = fsm_sem.constant_outcome(op, t, fin)
        if fixed is None and (t > fin.min_int if op == "lt" else t < fin.max_int):
            checks.append(f"({_wide(inp, fin)} {ops[op]} $signed({literal(t, fin.width + 1)}))")
        elif fixed:
            checks.append("1'b1")
    if checks:
        ovf = view.net.wire(f"{sig(n.name)}_ovf", 1, " | ".join(checks), signed=False)
        view.net.overflow.append((ovf, n.name))
    view.fsms.append({"state": state, "width": sw, "reset": ulit(states.index(n.param("reset")), sw),
                      "rules": rules})


def _wide(inp: str, fin: QFormat) -> str:
    """The input one bit wider, signed, to compare with a literal of that width (the literal
    of a threshold inside the input's range fits)."""
    return f"$signed({extend(inp, fin.width, fin.signed, fin.width + 1)})"


def _emit_lut(view: CoreView, n, inp: str, fin: QFormat) -> None:
    net = view.net
    name = sig(n.name)
    p = dict(n.params)
    ab, shift, table, wo = p["addr_bits"], p["shift"], p["table"], n.qformat.width
    segments = 1 << ab
    base = lut_sem.lo_int(p["lo"], fin)
    if p["periodic"]:
        # only the low shift + ab bits of the difference count (the address wraps): a narrow
        # input's bits above it are its sign extension, a base beyond the bits wraps harmlessly
        dw = max(fin.width + 1, shift + ab + 1)
    else:   # the exact difference, whatever the base
        dw = max(fin.width + 1, signed_width(fin.min_int - base, fin.max_int - base))
    d = net.wire(f"{name}_d", dw, f"{extend(inp, fin.width, fin.signed, dw)} - {literal(wrap_signed(base, dw), dw)}")
    interp = p["interpolate"]
    aw = ab + 1 if interp else ab               # one more entry than segments when interpolating
    pad = "1'b0, " if interp else ""
    fw = max(shift, 1)
    if p["periodic"]:
        top = dw - 1
        if top >= shift + ab:
            net.wire(f"{name}_d_unused", top - (shift + ab) + 1, f"{d}[{top}:{shift + ab}]", signed=False)
        addr = net.wire(f"{name}_addr", aw, f"{{{pad}{d}[{shift + ab - 1}:{shift}]}}", signed=False)
        frac = net.wire(f"{name}_f", fw, f"{d}[{shift - 1}:0]" if shift else "1'b0", signed=False)
        outside = "1'b0"
    else:
        # index = d >> shift (a shift past every bit leaves the sign), fraction = low shift bits
        iw = dw - shift if shift < dw else 1
        idx = net.wire(f"{name}_idx", iw, bits(d, dw, dw - 1, shift) if shift < dw else bits(d, dw, dw - 1))
        raw_f = "1'b0" if not shift else bits(d, dw, shift - 1, 0) if shift <= dw else extend(d, dw, True, shift)
        below = net.wire(f"{name}_below", 1, bits(idx, iw, iw - 1), signed=False)
        cw = max(iw, ab + 1) + 1                # holds the index and the segment count, signed
        wide_idx = f"$signed({extend(idx, iw, True, cw)})"
        above = net.wire(f"{name}_above", 1, f"!{below} && ({wide_idx} >= $signed({literal(segments, cw)}))",
                         signed=False)
        last = segments if p["interpolate"] else segments - 1
        exact_end = f"({wide_idx} == $signed({literal(segments, cw)})) && ({raw_f} == {fw}'d0)"
        outside = net.wire(f"{name}_outside", 1, f"{below} | ({above} && !({exact_end}))" if p["interpolate"]
                           else f"{below} | {above}", signed=False)
        low_idx = bits(idx, iw, ab - 1, 0) if iw > ab else extend(idx, iw, False, ab)
        if iw > ab:
            net.wire(f"{name}_idx_unused", iw - ab, bits(idx, iw, iw - 1, ab), signed=False)
        addr = net.wire(f"{name}_addr", aw, f"{below} ? {ulit(0, aw)} : {above} ? {ulit(last, aw)} : {{{pad}{low_idx}}}",
                        signed=False)
        frac = net.wire(f"{name}_f", fw, f"({below} | {above}) ? {fw}'d0 : {raw_f}", signed=False)
    dwid = slope_bits(table)          # the stored slope needs only the largest neighbour difference
    word_w = wo + (dwid if interp else 0)
    words = []
    mask_o, mask_d = (1 << wo) - 1, (1 << dwid) - 1
    for i in range(len(table)):
        y0 = table[i]
        dy = table[i + 1] - y0 if interp and i + 1 < len(table) else 0
        word = ((y0 & mask_o) << dwid) | (dy & mask_d) if interp else (y0 & mask_o)
        words.append(f"{word:0{(word_w + 3) // 4}x}")
    q = net.fresh(f"{name}_q")
    net.decls.append((q, word_w, False))
    # The table word and its side registers load only in the cycle the address is valid and then
    # hold: a shared multiplier may interpolate cycles later, when the address wires hold another
    # phase's values.
    read_cycle = view.dp.schedule.lut_addr[n.name]
    en, en_q = view.dp.cycle_gate(read_cycle), view.dp.cycle_gate(read_cycle + 1)
    view.roms.append(Rom(name=f"{view.module}_rom_{n.name}", inst=net.fresh(f"u_rom_{n.name}"), addr_width=aw,
                         data_width=word_w, words=words, addr=addr, q=q, en=en))
    fr = net.fresh(f"{name}_f_r")
    view.lut_regs.append((fr, max(shift, 1), frac, en))
    if outside != "1'b0":
        orr = net.fresh(f"{name}_outside_r")
        view.lut_regs.append((orr, 1, outside, en))
        net.overflow.append((orr, n.name))
    if n.name in view.dp.schedule.rom_reg:       # ROM word through a fabric register: cuts clock-to-out
        q_r = net.fresh(f"{q}_r")
        view.lut_regs.append((q_r, word_w, q, en_q))
        q = q_r
    y0 = net.wire(f"{name}_y0", wo, f"{q}[{word_w - 1}:{dwid}]" if interp else q)
    if not interp or shift == 0:
        net.wire(name, wo, y0, own=True)
        return
    dy = net.wire(f"{name}_dy", dwid, f"{q}[{dwid - 1}:0]")
    pw = dwid + shift + 1
    fs = net.wire(f"{name}_fs", shift + 1, f"{{1'b0, {fr}}}")
    prod, _ = view.dp.product(f"{name}_p", n.name, (dy, dwid, None, True), (fs, shift + 1, None, True))
    sw_ = pw - shift + (1 if n.rounding is Rounding.NEAREST else 0)   # wide enough: never overflows
    step = requantize(net, f"{name}_step", prod, pw, shift, QFormat(True, sw_, 0), n.rounding,
                      Overflow.WRAP, n.name)
    tw = max(sw_, wo) + 1
    total = net.wire(f"{name}_sum", tw, f"{extend(y0, wo, n.qformat.signed, tw)} + {extend(step, sw_, True, tw)}")
    net.wire(f"{name}_sum_unused", tw - wo, f"{total}[{tw - 1}:{wo}]", signed=False)
    net.wire(name, wo, f"{total}[{wo - 1}:0]", own=True)
