"""The Verilog of the two nodes with state beyond a register: table lookups (a synchronous
ROM, its address arithmetic and the interpolation) and the encoders' Moore machines.

Both append to the core's view-model (:class:`pendc.backend.viewmodel.CoreView`) in the
netlist block of their node; an FSM's input-range check goes in a block of its own after
every node, because the machine's input is computed after the machine's output is read.
"""

from __future__ import annotations

from ..ir import fsm as fsm_sem
from ..ir import lut as lut_sem
from ..ir.compare_ops import CompareOp
from ..ir.nodes import ANY_STATE
from ..ir.qformat import Overflow, QFormat, Rounding
from ..passes.resources import slope_bits
from .arith import bits, extend, literal, requantize, signed_width, ulit, wrap_signed

def _sig(name: str) -> str:
    return f"n_{name}"


def rom_module(module: str) -> str:
    """The one parameterised ROM module that every table of core ``module`` instantiates."""
    return f"{module}_rom"


def emit_fsm(view, n) -> None:
    """The machine's state register and its Moore output word ``n_<name>``."""
    p = n.params
    sw = max(1, (len(p.states) - 1).bit_length())
    ow = n.qformat.width
    state = view.net.reg(f"{_sig(n.name)}_state", sw, False)
    word = ulit(p.outputs[-1], ow)
    for i in range(len(p.states) - 2, -1, -1):
        word = f"({state} == {ulit(i, sw)}) ? {ulit(p.outputs[i], ow)} : {word}"
    view.net.wire(_sig(n.name), ow, word, signed=False, own=True)
    view.fsms.append({"node": n.name, "state": state, "width": sw, "reset": ulit(p.states.index(p.reset), sw),
                      "rules": []})


def emit_fsm_check(view, n, inp: str, fin: QFormat) -> None:
    """The machine's transition rules on its input ``inp`` and its input-range overflow term."""
    fsm = next(f for f in view.fsms if f["node"] == n.name)
    p, state, sw = n.params, fsm["state"], fsm["width"]
    for rule in p.transitions:
        t = fsm_sem.threshold_int(rule.threshold, fin)
        fixed = fsm_sem.constant_outcome(rule.op, t, fin)     # a threshold beyond the input's range
        if fixed is False:
            continue                                            # never fires
        cond = "1'b1" if fixed else f"{_wide(inp, fin)} {rule.op.symbol} $signed({literal(t, fin.width + 1)})"
        if rule.source != ANY_STATE:
            at = f"({state} == {ulit(p.states.index(rule.source), sw)})"
            cond = at if fixed else f"{at} && {cond}"
        fsm["rules"].append((cond, ulit(p.states.index(rule.target), sw)))
    checks = []
    for op, bound in ((CompareOp.LT, p.lo), (CompareOp.GT, p.hi)):
        t = fsm_sem.threshold_int(bound, fin)
        fixed = fsm_sem.constant_outcome(op, t, fin)
        if fixed is None and (t > fin.min_int if op is CompareOp.LT else t < fin.max_int):
            checks.append(f"({_wide(inp, fin)} {op.symbol} $signed({literal(t, fin.width + 1)}))")
        elif fixed:
            checks.append("1'b1")
    if checks:
        ovf = view.net.wire(f"{_sig(n.name)}_ovf", 1, " | ".join(checks), signed=False)
        view.net.overflow.append((ovf, n.name))


def _wide(inp: str, fin: QFormat) -> str:
    """The input one bit wider, signed, to compare with a literal of that width (the literal
    of a threshold inside the input's range fits)."""
    return f"$signed({extend(inp, fin.width, fin.signed, fin.width + 1)})"


def _address(net, n, name: str, inp: str, fin: QFormat) -> tuple:
    """``(addr, frac, outside)``: the table address, the position within the segment and the
    out-of-domain flag (``"1'b0"`` for a periodic table, whose address wraps)."""
    p = n.params
    ab, shift, segments = p.addr_bits, p.shift, p.segments
    base = lut_sem.lo_int(p.lo, fin)
    periodic, interp = p.periodic, p.interpolate
    if periodic:
        # only the low shift + ab bits of the difference count (the address wraps): a narrow
        # input's bits above it are its sign extension, a base beyond the bits wraps harmlessly
        dw = max(fin.width + 1, shift + ab + 1)
    else:   # the exact difference, whatever the base
        dw = max(fin.width + 1, signed_width(fin.min_int - base, fin.max_int - base))
    d = net.wire(f"{name}_d", dw, f"{extend(inp, fin.width, fin.signed, dw)} - {literal(wrap_signed(base, dw), dw)}")
    aw = ab + 1 if interp else ab               # one more entry than segments when interpolating
    pad = "1'b0, " if interp else ""
    fw = max(shift, 1)
    if periodic:
        top = dw - 1
        if top >= shift + ab:
            net.wire(f"{name}_d_unused", top - (shift + ab) + 1, f"{d}[{top}:{shift + ab}]", signed=False)
        addr = net.wire(f"{name}_addr", aw, f"{{{pad}{d}[{shift + ab - 1}:{shift}]}}", signed=False)
        frac = net.wire(f"{name}_f", fw, f"{d}[{shift - 1}:0]" if shift else "1'b0", signed=False)
        return addr, frac, "1'b0"
    # index = d >> shift (a shift past every bit leaves the sign), fraction = low shift bits
    iw = dw - shift if shift < dw else 1
    idx = net.wire(f"{name}_idx", iw, bits(d, dw, dw - 1, shift) if shift < dw else bits(d, dw, dw - 1))
    raw_f = "1'b0" if not shift else bits(d, dw, shift - 1, 0) if shift <= dw else extend(d, dw, True, shift)
    below = net.wire(f"{name}_below", 1, bits(idx, iw, iw - 1), signed=False)
    cw = max(iw, ab + 1) + 1                # holds the index and the segment count, signed
    wide_idx = f"$signed({extend(idx, iw, True, cw)})"
    above = net.wire(f"{name}_above", 1, f"!{below} && ({wide_idx} >= $signed({literal(segments, cw)}))",
                     signed=False)
    last = segments if interp else segments - 1
    exact_end = f"({wide_idx} == $signed({literal(segments, cw)})) && ({raw_f} == {fw}'d0)"
    outside = net.wire(f"{name}_outside", 1, f"{below} | ({above} && !({exact_end}))" if interp
                       else f"{below} | {above}", signed=False)
    low_idx = bits(idx, iw, ab - 1, 0) if iw > ab else extend(idx, iw, False, ab)
    if iw > ab:
        net.wire(f"{name}_idx_unused", iw - ab, bits(idx, iw, iw - 1, ab), signed=False)
    addr = net.wire(f"{name}_addr", aw, f"{below} ? {ulit(0, aw)} : {above} ? {ulit(last, aw)} : {{{pad}{low_idx}}}",
                    signed=False)
    frac = net.wire(f"{name}_f", fw, f"({below} | {above}) ? {fw}'d0 : {raw_f}", signed=False)
    return addr, frac, outside


def _words(table, wo: int, dwid: int, interp: bool) -> list:
    """The ROM's words as hex: the entry, and with interpolation the slope to the next entry."""
    word_w = wo + (dwid if interp else 0)
    words = []
    mask_o, mask_d = (1 << wo) - 1, (1 << dwid) - 1
    for i in range(len(table)):
        y0 = table[i]
        dy = table[i + 1] - y0 if interp and i + 1 < len(table) else 0
        word = ((y0 & mask_o) << dwid) | (dy & mask_d) if interp else (y0 & mask_o)
        words.append(f"{word:0{(word_w + 3) // 4}x}")
    return words


def emit_lut(view, n, inp: str, fin: QFormat, rom_class) -> None:
    """Address arithmetic, the ROM (``rom_class``: the view-model's record of one) and its
    instance, the side registers, and the interpolation between neighbouring entries."""
    net = view.net
    name = _sig(n.name)
    p = n.params
    shift, table, wo, interp = p.shift, p.table, n.qformat.width, p.interpolate
    addr, frac, outside = _address(net, n, name, inp, fin)
    dwid = slope_bits(table)          # the stored slope needs only the largest neighbour difference
    word_w = wo + (dwid if interp else 0)
    q = net.net(f"{name}_q", word_w)
    # The table word and its side registers load only in the cycle the address is valid and then
    # hold: a shared multiplier may interpolate cycles later, when the address wires hold another
    # phase's values.
    read_cycle = view.dp.schedule.lut_addr[n.name]
    en, en_q = view.dp.cycle_gate(read_cycle), view.dp.cycle_gate(read_cycle + 1)
    rom = rom_class(table=n.name, file=f"{view.module}_rom_{n.name}.mem", inst=net.fresh(f"u_rom_{n.name}"),
                    addr_width=p.addr_bits + (1 if interp else 0), data_width=word_w,
                    words=_words(table, wo, dwid, interp), addr=addr, q=q, en=en,
                    layout=f"entry [{word_w - 1}:{dwid}], slope to the next entry [{dwid - 1}:0]" if interp
                    else f"entry [{wo - 1}:0]")
    view.roms.append(rom)
    net.instance(rom_module(view.module), f".ADDR_WIDTH({rom.addr_width}), .DATA_WIDTH({word_w}), "
                 f".DEPTH({len(rom.words)}), .INIT_FILE(\"{rom.file}\")",
                 rom.inst, f".clk(clk), .en({en}), .addr({addr}), .q({q})")
    fr = net.reg(f"{name}_f_r", max(shift, 1), False)
    view.lut_regs.append((fr, max(shift, 1), frac, en))
    if outside != "1'b0":
        orr = net.reg(f"{name}_outside_r", 1, False)
        view.lut_regs.append((orr, 1, outside, en))
        net.overflow.append((orr, n.name))
    if n.name in view.dp.schedule.rom_reg:       # ROM word through a fabric register: cuts clock-to-out
        q_r = net.reg(f"{q}_r", word_w, False)
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
