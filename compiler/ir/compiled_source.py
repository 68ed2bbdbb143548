"""Python source of a graph's numba kernel (the code printer behind pendc.ir.compiled).

One straight-line step function per graph, every node a local variable ``v<i>`` (``i``
its index in evaluation order), registers and FSM states in ``s<i>``, constants baked
in. Fixed mode prints :func:`pendc.ir.qformat.requantize` inline with its constants;
range checks are left out where the operands' formats prove they cannot fire (a
node's value always lies in its own format, except raw integer INPUTs and LUTs whose
table does not fit the output format). Float mode mirrors ``FloatInterpreter``; LUTs
evaluate their expression printed as ``math`` calls.

Kernel arguments: ``ins[j, k]`` (value of the j-th INPUT node at step k), ``steps``,
``every``, ``tab`` (all LUT tables concatenated, fixed mode), ``sel`` (node indices
to record), ``out[row, j]``, ``track`` and ``mx``/``mn`` (running max/min per node;
float mode keeps max |v| in ``mx``), ``ov`` (first overflow step per node, -1 if none).
"""

from __future__ import annotations

import math

import sympy as sp

from ..codegen import NumbaPrinter

from . import fsm as fsm_sem
from . import lut as lut_sem
from .graph import Graph
from .compare_ops import CompareOp
from .nodes import SOURCE_KINDS, Kind
from .qformat import QFormat, Rounding, Overflow, shift_round
from .visitor import NodeVisitor

SOURCE_FORMAT = 1  # bump when the generated source changes shape
I64_MIN, I64_MAX = -(1 << 63), (1 << 63) - 1
UNKNOWN = (I64_MIN, I64_MAX)


class _ExprPrinter(NumbaPrinter):
    """sympy -> numba-compatible Python; the LUT variable ``v`` prints as ``var``."""

    def __init__(self, var: str):
        super().__init__()
        self.var = var

    def _print_Symbol(self, expr):
        return self.var if expr.name == "v" else super()._print_Symbol(expr)


def lut_expr_source(expr: str, var: str) -> str:
    """The LUT expression (parsed exactly as pendc.ir.lut does) printed in ``var``."""
    v = sp.Symbol("v", real=True)
    return _ExprPrinter(var).doprint(sp.sympify(expr, locals={"v": v}))


def _i(x: int) -> str:
    """An int64 literal numba types as int64 (the minimum needs spelling out)."""
    x = int(x)
    if not I64_MIN <= x <= I64_MAX:
        raise ValueError(f"constant {x} does not fit the 64-bit golden model")
    return f"({x + 1} - 1)" if x == I64_MIN else str(x)


def _f(x) -> str:
    x = float(x)
    if math.isnan(x):
        return "math.nan"
    if math.isinf(x):
        return "math.inf" if x > 0 else "(-math.inf)"
    return repr(x)


def _frange(fmt: QFormat) -> tuple:
    return fmt.min_int, fmt.max_int


def _union(*ranges) -> tuple:
    return min(r[0] for r in ranges), max(r[1] for r in ranges)


def lut_table_ok(node) -> bool:
    """True if every entry of the LUT's table lies in the node's own format."""
    t = node.params.table
    return bool(t) and all(node.qformat.min_int <= int(x) <= node.qformat.max_int for x in t)


class _Bounds(NodeVisitor):
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


class _Gen(NodeVisitor, abstract=True, elsewhere=SOURCE_KINDS):
    """Printer of one kernel: ``visit_<kind>(node, i)`` returns the lines computing ``v<i>``
    (sources and state elements are printed by :func:`kernel_source` itself)."""

    fixed = False

    def __init__(self, graph: Graph):
        self.g = graph
        self.idx = {n.name: i for i, n in enumerate(graph.nodes)}
        self.offsets, self.tab_len = {}, 0
        self._bounds: dict = {}
        self._bounder = _Bounds()

    def bounds(self, name: str, seen=()) -> tuple:
        """Integer range a node's value provably stays in."""
        if name not in self._bounds:
            self._bounds[name] = self._bounder.visit(self.g[name], self, seen)
        return self._bounds[name]

    # -- fixed-point requantisation ----------------------------------------------------------
    def requant(self, i: int, node, expr: str, rng: tuple, frac: int) -> list:
        """Lines assigning requantize(expr, frac, node's format...) to v<i>, flagging ov[i]."""
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
            conds = ([f"{t} > {_i(up)}"] if hi > up else []) + ([f"{t} < {_i(down)}"] if lo < down else [])
            if ovf is Overflow.SATURATE:
                fix = f"{_i(fmt.max_int)} if {t} > 0 else {_i(fmt.min_int)}"
            else:
                fix = self.wrap(f"({t} << {n})", fmt) if n < 64 else "0"
            return [f"{t} = {expr}", f"if {' or '.join(conds)}:", f"    if ov[{i}] < 0:", f"        ov[{i}] = k",
                    f"    {tgt} = {fix}", "else:", f"    {tgt} = {shifted}"]
        lines = []
        if shift > 0:
            if rnd is Rounding.TRUNCATE:
                e = f"({expr}) >> {min(shift, 63)}"
            elif shift >= 64:
                e = "0"
            elif I64_MIN <= lo + (1 << (shift - 1)) and hi + (1 << (shift - 1)) <= I64_MAX:
                e = f"(({expr}) + {_i(1 << (shift - 1))}) >> {shift}"
            else:  # floor((v + half) / 2**s) without forming v + half
                lines.append(f"{t} = {expr}")
                e = f"({t} >> {shift}) + (({t} >> {shift - 1}) & 1)"
            lo, hi = shift_round(lo, shift, rnd), shift_round(hi, shift, rnd)
        else:
            e = expr
        lines.append(f"{tgt} = {e}")
        if fmt.signed and fmt.width == 64:
            return lines  # int64 itself: nothing can leave the range
        conds = ([f"{tgt} > {_i(fmt.max_int)}"] if hi > fmt.max_int else []) + \
                ([f"{tgt} < {_i(fmt.min_int)}"] if lo < fmt.min_int else [])
        if not conds:
            return lines
        if ovf is Overflow.SATURATE:
            fix = (f"{_i(fmt.max_int)} if {tgt} > {_i(fmt.max_int)} else {_i(fmt.min_int)}" if len(conds) == 2
                   else _i(fmt.max_int) if hi > fmt.max_int else _i(fmt.min_int))
        else:
            fix = self.wrap(tgt, fmt)
        return lines + [f"if {' or '.join(conds)}:", f"    if ov[{i}] < 0:", f"        ov[{i}] = k",
                        f"    {tgt} = {fix}"]

    @staticmethod
    def wrap(e: str, fmt: QFormat) -> str:
        if fmt.width == 64:
            return e
        if fmt.signed:
            s = 64 - fmt.width
            return f"({e} << {s}) >> {s}"
        return f"{e} & {_i((1 << fmt.width) - 1)}"

    def aligned(self, name: str, frac: int) -> tuple:
        """(expression, bounds) of a node's integer shifted left to ``frac`` fraction bits."""
        n = frac - self.g[name].qformat.frac
        lo, hi = self.bounds(name)
        v = f"v{self.idx[name]}"
        return (f"({v} << {n})" if n else v), (lo << n, hi << n)

    # -- state -------------------------------------------------------------------------------
    def num(self, x) -> str:
        return _i(x) if self.fixed else _f(x)

    def reset(self, node) -> str:
        if node.kind is Kind.FSM:
            return str(node.params.reset_index)
        value = float(node.params.reset)
        return _i(node.qformat.from_float(value)) if self.fixed else _f(value)

    def fsm_output(self, i: int, node) -> list:
        outs = node.params.outputs
        lines = []
        for s, o in enumerate(outs):
            head = "if" if s == 0 else "elif" if s < len(outs) - 1 else "else"
            lines += [f"{head} s{i} == {s}:" if head != "else" else "else:", f"    v{i} = {self.num(int(o))}"]
        return lines if len(outs) > 1 else [f"v{i} = {self.num(int(outs[0]))}"]

    def fsm_update(self, i: int, node) -> list:
        src = node.inputs[0]
        v = f"v{self.idx[src]}"
        p = node.params
        if self.fixed:      # thresholds on the input's grid; beyond its range a test is a constant
            fin = self.g[src].qformat

            def test(op, x):
                t = fsm_sem.threshold_int(x, fin)
                fixed = fsm_sem.constant_outcome(op, t, fin)
                return f"{v} {op.symbol} {_i(t)}" if fixed is None else str(fixed)
        else:
            def test(op, x):
                return f"{v} {op.symbol} {_f(x)}"
        outside = (f"{test(CompareOp.LT, p.lo)} or {test(CompareOp.GT, p.hi)}" if self.fixed
                   else f"not ({_f(p.lo)} <= {v} <= {_f(p.hi)})")   # NaN is outside
        lines = [f"if {outside}:",
                 f"    if ov[{i}] < 0:", f"        ov[{i}] = k"]
        per_state = [p.rules_from(s) for s in range(len(p.states))]
        shared = all(r == per_state[0] for r in per_state)   # only "*" rules: no dispatch on the state
        dispatch = [(None, per_state[0])] if shared else [(s, r) for s, r in enumerate(per_state) if r]
        for d, (s, rules) in enumerate(dispatch):
            pad = "" if shared else "    "
            if not shared:
                lines.append(f"{'if' if d == 0 else 'elif'} s{i} == {s}:")
            for r, rule in enumerate(rules):
                lines += [f"{pad}{'if' if r == 0 else 'elif'} {test(rule.op, rule.threshold)}:",
                          f"{pad}    s{i} = {p.states.index(rule.target)}"]
        return lines


class _FixedGen(_Gen):
    """Bit-accurate int64 kernel: ``requantize`` printed inline per node."""

    fixed = True

    def visit_gain(self, node, i):
        a = node.inputs[0]
        c = node.params.constant
        lo, hi = self.bounds(a)
        return self.requant(i, node, f"v{self.idx[a]} * {_i(c)}", (min(lo * c, hi * c), max(lo * c, hi * c)),
                            self.g[a].qformat.frac + node.params.cfmt.frac)

    def _pair(self, node) -> tuple:
        frac = max(self.g[x].qformat.frac for x in node.inputs)
        return self.aligned(node.inputs[0], frac), self.aligned(node.inputs[1], frac), frac

    def visit_add(self, node, i):
        (x, (xl, xh)), (y, (yl, yh)), frac = self._pair(node)
        return self.requant(i, node, f"{x} + {y}", (xl + yl, xh + yh), frac)

    def visit_sub(self, node, i):
        (x, (xl, xh)), (y, (yl, yh)), frac = self._pair(node)
        return self.requant(i, node, f"{x} - {y}", (xl - yh, xh - yl), frac)

    def visit_compare(self, node, i):
        (x, _), (y, _), _ = self._pair(node)
        return [f"v{i} = 1 if {x} {node.params.op.symbol} {y} else 0"]

    def visit_neg(self, node, i):
        a = node.inputs[0]
        lo, hi = self.bounds(a)
        return self.requant(i, node, f"-v{self.idx[a]}", (-hi, -lo), self.g[a].qformat.frac)

    def visit_mul(self, node, i):
        a, b = node.inputs
        (al, ah), (bl, bh) = self.bounds(a), self.bounds(b)
        p = [al * bl, al * bh, ah * bl, ah * bh]
        return self.requant(i, node, f"v{self.idx[a]} * v{self.idx[b]}", (min(p), max(p)),
                            self.g[a].qformat.frac + self.g[b].qformat.frac)

    def visit_cast(self, node, i):
        a = node.inputs[0]
        return self.requant(i, node, f"v{self.idx[a]}", self.bounds(a), self.g[a].qformat.frac)

    def visit_mux(self, node, i):
        # a select beyond the data inputs picks the last one (pendc.ir.nodes)
        ins = node.inputs
        lines = []
        for j in range(1, len(ins)):
            last = j == len(ins) - 1
            lines.append("else:" if last else f"{'if' if j == 1 else 'elif'} v{self.idx[ins[0]]} == {j - 1}:")
            lines += ["    " + s for s in self.requant(i, node, f"v{self.idx[ins[j]]}", self.bounds(ins[j]),
                                                       self.g[ins[j]].qformat.frac)]
        return lines

    def visit_slice(self, node, i):
        hi, lo = node.params.bits(self.g[node.inputs[0]].qformat.width)
        if hi - lo + 1 > 63 or lo < 0:
            raise ValueError(f"SLICE '{node.name}': bits {hi}..{lo} do not fit the 64-bit golden model")
        return [f"v{i} = (v{self.idx[node.inputs[0]]} >> {min(lo, 63)}) & {_i((1 << (hi - lo + 1)) - 1)}"]

    def visit_lut(self, node, i):
        p = node.params
        a = f"v{self.idx[node.inputs[0]]}"
        fin = self.g[node.inputs[0]].qformat
        table, shift, bits, interp = p.table, p.shift, p.addr_bits, bool(p.interpolate)
        seg = 1 << bits
        if table is None or shift is None:
            raise ValueError(f"LUT '{node.name}' has no table yet (run fill_lut_tables)")
        if len(table) != seg + interp:
            raise ValueError(f"LUT '{node.name}': table has {len(table)} entries, expected {seg + interp}")
        off = self.offsets[node.name] = self.tab_len
        self.tab_len += len(table)
        d, j, f = f"d{i}", f"j{i}", f"f{i}"
        lines = [f"{d} = {a} - {_i(lut_sem.lo_int(p.lo, fin))}", f"{j} = {d} >> {shift}",
                 f"{f} = {d} & {_i((1 << shift) - 1)}"]
        flag = [f"    if ov[{i}] < 0:", f"        ov[{i}] = k"]
        if p.periodic:
            lines.append(f"{j} = {j} & {seg - 1}")
        else:
            lines += [f"if {j} < 0:"] + flag + [f"    {j} = 0", f"    {f} = 0", f"elif {j} >= {seg}:"]
            lines += ([f"    if {j} != {seg} or {f} != 0:"] + ["    " + s for s in flag] if interp else flag)
            lines += [f"    {j} = {seg if interp else seg - 1}", f"    {f} = 0"]
        if not interp or shift == 0:
            return lines + [f"v{i} = tab[{off} + {j}]"]
        step = f"(tab[{off + 1} + {j}] - v{i}) * {f}"
        rnd = f"({step} + {_i(1 << (shift - 1))})" if node.rounding is Rounding.NEAREST else step
        return lines + [f"v{i} = tab[{off} + {j}]", f"if {f} != 0:", f"    v{i} = v{i} + ({rnd} >> {shift})"]


class _FloatGen(_Gen):
    """float64 kernel mirroring ``FloatInterpreter``."""

    def _a(self, node) -> list:
        return [f"v{self.idx[x]}" for x in node.inputs]

    def visit_gain(self, node, i):
        return [f"v{i} = {self._a(node)[0]} * {_f(node.params.value)}"]

    def visit_add(self, node, i):
        a = self._a(node)
        return [f"v{i} = {a[0]} + {a[1]}"]

    def visit_sub(self, node, i):
        a = self._a(node)
        return [f"v{i} = {a[0]} - {a[1]}"]

    def visit_mul(self, node, i):
        a = self._a(node)
        return [f"v{i} = {a[0]} * {a[1]}"]

    def visit_neg(self, node, i):
        return [f"v{i} = -{self._a(node)[0]}"]

    def visit_cast(self, node, i):
        return [f"v{i} = {self._a(node)[0]}"]

    def visit_compare(self, node, i):
        a = self._a(node)
        return [f"v{i} = 1.0 if {a[0]} {node.params.op.symbol} {a[1]} else 0.0"]

    def visit_mux(self, node, i):
        a = self._a(node)
        lines = [f"m{i} = int({a[0]})"]
        for j in range(1, len(a)):
            last = j == len(a) - 1
            lines += ["else:" if last else f"{'if' if j == 1 else 'elif'} m{i} == {j - 1}:", f"    v{i} = {a[j]}"]
        return lines

    def visit_slice(self, node, i):
        p, a = node.params, self._a(node)[0]
        if p.sign_bit:
            return [f"v{i} = 1.0 if {a} < 0 else 0.0"]
        return [f"v{i} = float((int({a}) >> {min(p.lo, 63)}) & {_i((1 << p.width) - 1)})"]

    def visit_lut(self, node, i):
        p, x = node.params, f"x{i}"
        lo, hi = p.lo, p.hi
        lines = [f"{x} = {self._a(node)[0]}"]
        if p.periodic:
            lines.append(f"{x} = {_f(lo)} + ({x} - {_f(lo)}) % {_f(hi - lo)}")
        elif lo is not None:
            lines += [f"if not ({_f(lo)} <= {x} <= {_f(hi)}):", f"    if ov[{i}] < 0:", f"        ov[{i}] = k",
                      f"    if {_f(lo)} > {x}:", f"        {x} = {_f(lo)}",
                      f"    if {_f(hi)} < {x}:", f"        {x} = {_f(hi)}"]
        return lines + [f"v{i} = float({lut_expr_source(p.expr, x)})"]


def kernel_source(graph: Graph, mode: str) -> tuple[str, dict]:
    """(source of the kernel module, {LUT node name: offset into the table array})."""
    if mode not in ("fixed", "float"):
        raise ValueError(f"mode must be 'fixed' or 'float', got {mode!r}")
    gen = (_FixedGen if mode == "fixed" else _FloatGen)(graph)
    nodes = graph.nodes
    dtype = "np.int64" if gen.fixed else "np.float64"
    head, body, update = [], [], []
    const_idx = [i for i, n in enumerate(nodes) if n.kind is Kind.CONST]
    inputs = [i for i, n in enumerate(nodes) if n.kind is Kind.INPUT]
    for i, n in enumerate(nodes):
        k = n.kind
        comment = " ".join(f"# {n.name} = {k.value}({', '.join(n.inputs)})".split())
        comment += f" : {n.qformat}" if gen.fixed else ""
        if k is Kind.CONST:
            value = float(n.params.value)
            head += [comment, f"v{i} = {_i(n.qformat.from_float(value)) if gen.fixed else _f(value)}",
                     f"buf[{i}] = v{i}"]
        elif k in (Kind.REGISTER, Kind.FSM):
            head += [comment, f"s{i} = {gen.reset(n)}"]
            body += [comment] + ([f"v{i} = s{i}"] if k is Kind.REGISTER else gen.fsm_output(i, n))
            update += ([f"s{i} = v{gen.idx[n.inputs[0]]}"] if k is Kind.REGISTER else gen.fsm_update(i, n))
        elif k is Kind.INPUT:
            body += [comment, f"v{i} = ins[{inputs.index(i)}, k]"]
        else:
            body += [comment] + gen.visit(n, i)
    varying = [i for i in range(len(nodes)) if i not in const_idx]
    if gen.fixed:
        track = ["    for i in range(buf.shape[0]):", "        x = buf[i]", "        if x > mx[i]:",
                 "            mx[i] = x", "        if x < mn[i]:", "            mn[i] = x"]
    else:
        track = ["    for i in range(buf.shape[0]):", "        x = abs(buf[i])",
                 "        if x > mx[i] or x != x:", "            mx[i] = x"]
    loop = (["for k in range(steps):"] + ["    " + s for s in body]
            + ["    if track or c == 0:"] + [f"        buf[{i}] = v{i}" for i in varying]
            + ["        if c == 0:", "            for j in range(sel.shape[0]):",
               "                out[row, j] = buf[sel[j]]", "            row += 1", "        if track:"]
            + ["        " + s for s in track]
            + ["    c += 1", "    if c == every:", "        c = 0"] + ["    " + s for s in update])
    lines = ([f"buf = np.zeros({len(nodes)}, {dtype})"] + head + ["c = 0", "row = 0"] + loop)
    fmt_note = "bit-accurate int64" if gen.fixed else "float64"
    src = (f'"""Generated by pendc.ir.compiled_source (format {SOURCE_FORMAT}): graph {graph.name}, '
           f'{fmt_note}."""\nimport math\n\nimport numpy as np\nfrom numba import njit\n\n\n'
           '@njit(cache=True, error_model="numpy")\n'
           "def kernel(ins, steps, every, tab, sel, out, track, mx, mn, ov):\n"
           + "".join(f"    {s}\n" for s in lines) + "    return row\n")
    return src, dict(gen.offsets)
