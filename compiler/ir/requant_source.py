"""Requantisation as printed Python, and the static value bounds that keep it short.

The fixed-point kernel (pendc.ir.compiled_source) prints
:func:`pendc.ir.qformat.requantize` inline for every node; a range check is left out
where the operands' formats prove it cannot fire (a node's value always lies in its own
format, except raw integer INPUTs and LUTs whose table does not fit the output format):
:class:`Bounds` is that proof, per kind.
"""

from __future__ import annotations

from .qformat import Overflow, QFormat, Rounding, shift_round
from .visitor import NodeVisitor

I64_MIN, I64_MAX = -(1 << 63), (1 << 63) - 1
UNKNOWN = (I64_MIN, I64_MAX)


def int_literal(x: int) -> str:
    """An int64 literal numba types as int64 (the minimum needs spelling out)."""
    x = int(x)
    if not I64_MIN <= x <= I64_MAX:
        raise ValueError(f"constant {x} does not fit the 64-bit golden model")
    return f"({x + 1} - 1)" if x == I64_MIN else str(x)


def _frange(fmt: QFormat) -> tuple:
    return fmt.min_int, fmt.max_int


def _union(*ranges) -> tuple:
    return min(r[0] for r in ranges), max(r[1] for r in ranges)


def lut_table_ok(node) -> bool:
    """True if every entry of the LUT's table lies in the node's own format."""
    t = node.params.table
    return bool(t) and all(node.qformat.min_int <= int(x) <= node.qformat.max_int for x in t)


class Bounds(NodeVisitor):
    """Integer range a node's value provably stays in (fixed mode): ``visit_<kind>(node, gen, seen)``."""

    def _own(self, n, gen, seen):
        return _frange(n.qformat)

    visit_gain = visit_add = visit_sub = visit_neg = visit_mul = visit_mux = visit_cast = _own

    def visit_input(self, n, gen, seen):
        return UNKNOWN          # a raw integer port is not checked against the format

    def visit_const(self, n, gen, seen):
        c = n.qformat.from_float(float(n.params.value))
        return (c, c)

    def visit_register(self, n, gen, seen):
        r = n.qformat.from_float(float(n.params.reset))
        src = n.inputs[0]
        return (r, r) if src in seen else _union((r, r), gen.bounds(src, seen + (n.name,)))

    def visit_fsm(self, n, gen, seen):
        return min(n.params.outputs), max(n.params.outputs)

    def visit_compare(self, n, gen, seen):
        return (0, 1)

    def visit_slice(self, n, gen, seen):
        return (0, (1 << n.params.width) - 1)

    def visit_lut(self, n, gen, seen):
        return _frange(n.qformat) if lut_table_ok(n) else UNKNOWN


def requant_lines(i: int, node, expr: str, rng: tuple, frac: int) -> list:
    """Lines assigning ``requantize(expr, frac, node's format, rounding, overflow)`` to ``v<i>``,
    flagging ``ov[i]``; ``rng`` bounds ``expr``, so checks that cannot fire are left out."""
    fmt, rnd, ovf = node.qformat, node.rounding, node.overflow
    tgt, t = f"v{i}", f"t{i}"
    lo, hi = rng
    shift = frac - fmt.frac
    if shift < 0:
        n = -shift
        shifted = f"{t} << {n}" if n < 64 else "0"   # shifts >= 64: only 0 can be in range
        if fmt.contains(lo << n) and fmt.contains(hi << n):
            return [f"{t} = {expr}", f"{tgt} = {shifted}"]
        up, down = fmt.max_int >> n, -((-fmt.min_int) >> n)
        conds = (([f"{t} > {int_literal(up)}"] if hi > up else [])
                 + ([f"{t} < {int_literal(down)}"] if lo < down else []))
        if ovf is Overflow.SATURATE:
            fix = f"{int_literal(fmt.max_int)} if {t} > 0 else {int_literal(fmt.min_int)}"
        else:
            fix = wrap_expr(f"({t} << {n})", fmt) if n < 64 else "0"
        return [f"{t} = {expr}", f"if {' or '.join(conds)}:", f"    if ov[{i}] < 0:", f"        ov[{i}] = k",
                f"    {tgt} = {fix}", "else:", f"    {tgt} = {shifted}"]
    lines = []
    if shift > 0:
        if rnd is Rounding.TRUNCATE:
            e = f"({expr}) >> {min(shift, 63)}"
        elif shift >= 64:
            e = "0"
        elif I64_MIN <= lo + (1 << (shift - 1)) and hi + (1 << (shift - 1)) <= I64_MAX:
            e = f"(({expr}) + {int_literal(1 << (shift - 1))}) >> {shift}"
        else:  # floor((v + half) / 2**s) without forming v + half
            lines.append(f"{t} = {expr}")
            e = f"({t} >> {shift}) + (({t} >> {shift - 1}) & 1)"
        lo, hi = shift_round(lo, shift, rnd), shift_round(hi, shift, rnd)
    else:
        e = expr
    lines.append(f"{tgt} = {e}")
    if fmt.signed and fmt.width == 64:
        return lines  # int64 itself: nothing can leave the range
    conds = ([f"{tgt} > {int_literal(fmt.max_int)}"] if hi > fmt.max_int else []) + \
            ([f"{tgt} < {int_literal(fmt.min_int)}"] if lo < fmt.min_int else [])
    if not conds:
        return lines
    if ovf is Overflow.SATURATE:
        top, bottom = int_literal(fmt.max_int), int_literal(fmt.min_int)
        fix = (f"{top} if {tgt} > {top} else {bottom}" if len(conds) == 2
               else top if hi > fmt.max_int else bottom)
    else:
        fix = wrap_expr(tgt, fmt)
    return lines + [f"if {' or '.join(conds)}:", f"    if ov[{i}] < 0:", f"        ov[{i}] = k",
                    f"    {tgt} = {fix}"]


def wrap_expr(e: str, fmt: QFormat) -> str:
    """``e`` wrapped into ``fmt``'s width (two's complement, or modulo for unsigned)."""
    if fmt.width == 64:
        return e
    if fmt.signed:
        s = 64 - fmt.width
        return f"({e} << {s}) >> {s}"
    return f"{e} & {int_literal((1 << fmt.width) - 1)}"
