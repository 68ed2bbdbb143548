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


def requant_lines(i: int, node, expr: str, rng: tuple, frac: int, tgt: str = "", flag: str = "") -> tuple:
    """(lines, flagged): lines assigning ``requantize(expr, frac, node's format, rounding, overflow)``
    to ``tgt`` (default ``v<i>``), and, where ``rng`` (the bounds of ``expr``) lets a range check fire,
    the check's outcome to the bool ``flag`` (default ``b<i>``; ``flagged`` tells whether it exists).

    Branch-free and single-assignment (saturation by min/max, wrapping unconditionally since it
    is the identity in range): numba's SSA pass costs blocks x redefined variables."""
    fmt, rnd, ovf = node.qformat, node.rounding, node.overflow
    tgt, flag = tgt or f"v{i}", flag or f"b{i}"
    t, r = "t" + tgt[1:], "r" + tgt[1:]
    lo, hi = rng
    shift = frac - fmt.frac
    if shift < 0:
        n = -shift
        shifted = f"{t} << {n}" if n < 64 else "0"   # shifts >= 64: only 0 can be in range
        if fmt.contains(lo << n) and fmt.contains(hi << n):
            return [f"{t} = {expr}", f"{tgt} = {shifted}"], False
        up, down = fmt.max_int >> n, -((-fmt.min_int) >> n)
        conds = (([f"({t} > {int_literal(up)})"] if hi > up else [])
                 + ([f"({t} < {int_literal(down)})"] if lo < down else []))
        top, bottom = int_literal(fmt.max_int), int_literal(fmt.min_int)
        if ovf is not Overflow.SATURATE:
            fix = wrap_expr(f"({t} << {n})", fmt) if n < 64 else "0"
        elif n >= 64:
            fix = f"{top} * ({t} > 0) + {bottom} * ({t} < 0)"
        elif I64_MIN <= (down - 1) << n and (up + 1) << n <= I64_MAX:
            # clamp to one step beyond the range first, so the shift cannot leave int64
            c = f"max({t}, {int_literal(down - 1)})" if lo < down else t
            c = f"min({c}, {int_literal(up + 1)})" if hi > up else c
            fix = f"min(max({c} << {n}, {bottom}), {top})"
        else:
            fix = f"{top} * ({t} > {int_literal(up)}) + {bottom} * ({t} < {int_literal(down)})" \
                  f" + ({t} << {n}) * (({t} <= {int_literal(up)}) & ({t} >= {int_literal(down)}))"
        return [f"{t} = {expr}", f"{flag} = {' | '.join(conds)}", f"{tgt} = {fix}"], True
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
    if fmt.signed and fmt.width == 64:
        return lines + [f"{tgt} = {e}"], False  # int64 itself: nothing can leave the range
    top, bottom = int_literal(fmt.max_int), int_literal(fmt.min_int)
    conds = ([f"({r} > {top})"] if hi > fmt.max_int else []) + ([f"({r} < {bottom})"] if lo < fmt.min_int else [])
    if not conds:
        return lines + [f"{tgt} = {e}"], False
    if ovf is Overflow.SATURATE:
        fix = f"max({r}, {bottom})" if lo < fmt.min_int else r
        fix = f"min({fix}, {top})" if hi > fmt.max_int else fix
    else:
        fix = wrap_expr(r, fmt)
    return lines + [f"{r} = {e}", f"{flag} = {' | '.join(conds)}", f"{tgt} = {fix}"], True


def wrap_expr(e: str, fmt: QFormat) -> str:
    """``e`` wrapped into ``fmt``'s width (two's complement, or modulo for unsigned)."""
    if fmt.width == 64:
        return e
    if fmt.signed:
        s = 64 - fmt.width
        return f"({e} << {s}) >> {s}"
    return f"{e} & {int_literal((1 << fmt.width) - 1)}"
