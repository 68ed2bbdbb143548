"""The fixed-point step printer of a graph's numba kernel (:mod:`pendc.ir.kernel_module` prints
the module around it; :mod:`pendc.ir.float_source` is the float64 printer).

One straight-line step, every node a local variable ``v<i>`` (``i`` its index in evaluation
order), registers and FSM states in ``s<i>``, constants baked in. Fixed mode prints
:func:`pendc.ir.qformat.requantize` inline with its constants; range checks are left out where
the operands' formats prove they cannot fire (a node's value always lies in its own format,
except raw integer INPUTs and LUTs whose table does not fit the output format).
"""

from __future__ import annotations

import math

import sympy as sp

from ..codegen import NumbaPrinter

from . import fsm as fsm_sem
from . import lut as lut_sem
from .graph import Graph
from .compare_ops import CompareOp
from .nodes import Kind
from .qformat import Rounding
from .requant_source import Bounds, int_literal as _i, requant_lines
from .visitor import NodeVisitor

SOURCE_FORMAT = 5  # bump when the generated source changes shape


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


def _f(x) -> str:
    x = float(x)
    if math.isnan(x):
        return "math.nan"
    if math.isinf(x):
        return "math.inf" if x > 0 else "(-math.inf)"
    return repr(x)


class _Gen(NodeVisitor, abstract=True):
    """Printer of one kernel: ``visit_<kind>(node, i)`` returns the lines computing ``v<i>`` in
    the step loop; constants add their lines to ``head`` (before the loop), state elements
    theirs to ``head`` (reset) and ``update`` (end of the step)."""

    fixed = False

    def __init__(self, graph: Graph, runtime_resets: bool = False):
        self.g, self.runtime_resets = graph, runtime_resets
        self.idx = {n.name: i for i, n in enumerate(graph.nodes)}
        self.inputs = [i for i, n in enumerate(graph.nodes) if n.kind is Kind.INPUT]
        self.offsets, self.tab_len = {}, 0
        self.head, self.update = [], []
        self._bounds: dict = {}
        self._bounder = Bounds()
        self.flags = []       # (node index, bool local): the node's range check fired this step
        self.late = []        # lines after the step's nodes (FSM checks read inputs computed later)
        self.lut_group, self.lut_member = {}, set()   # see group_luts

    def comment(self, node) -> str:
        """The comment line that names a node in the kernel."""
        text = " ".join(f"# {node.name} = {node.kind.value}({', '.join(node.inputs)})".split())
        return text + (f" : {node.qformat}" if self.fixed else "")

    # -- sources and state elements --------------------------------------------------------
    def visit_const(self, node, i):
        value = float(node.params.value)
        text = self.lit(node.qformat.from_float(value)) if self.fixed else _f(value)
        self.head += [self.comment(node), f"v{i} = {text}", f"buf[{i}] = v{i}"]
        return []

    def visit_input(self, node, i):
        return [f"v{i} = ins[{self.inputs.index(i)}, k]"]

    def visit_register(self, node, i):
        self.head += [self.comment(node), f"s{i} = {f'rst[{i}]' if self.runtime_resets else self.reset(node)}"]
        self.update.append(f"s{i} = v{self.idx[node.inputs[0]]}")
        return [f"v{i} = s{i}"]

    def visit_fsm(self, node, i):
        self.head += [self.comment(node), f"s{i} = {self.reset(node)}"]
        self.update += self.fsm_update(i, node)
        return self.fsm_output(i, node)

    def bounds(self, name: str, seen=()) -> tuple:
        """Integer range a node's value provably stays in."""
        if name not in self._bounds:
            self._bounds[name] = self._bounder.visit(self.g[name], self, seen)
        return self._bounds[name]

    def group_luts(self, key) -> None:
        """LUTs with the same ``key(node)`` are printed together by the first of them (in evaluation
        order), which computes what they share once: they read the same input the same way."""
        groups: dict = {}
        for i, n in enumerate(self.g.nodes):
            if n.kind is Kind.LUT:
                groups.setdefault(key(n), []).append(i)
        self.lut_group = {members[0]: members for members in groups.values() if len(members) > 1}
        self.lut_member = {i for members in self.lut_group.values() for i in members[1:]}

    def defined_by(self, i: int) -> list:
        """The nodes whose values node ``i``'s lines compute: itself, or a LUT group's first the group."""
        return self.lut_group.get(i, [i])

    # -- state -------------------------------------------------------------------------------
    def num(self, x) -> str:
        return _i(x) if self.fixed else _f(x)

    def lit(self, x: int) -> str:
        """A node's integer (a constant, a slice's shift and mask, a gain): an int64 literal here."""
        return _i(x)

    def reset(self, node) -> str:
        if node.kind is Kind.FSM:
            return str(node.params.reset_index)
        value = float(node.params.reset)
        return _i(node.qformat.from_float(value)) if self.fixed else _f(value)

    def fsm_output(self, i: int, node) -> list:
        # a sum of products, not an if-chain: the state is always one of its indices, so exactly
        # one term is nonzero (and the outputs are integers, exact in float too)
        outs = node.params.outputs
        if len(outs) == 1:
            return [f"v{i} = {self.num(int(outs[0]))}"]
        return [f"v{i} = " + " + ".join(f"{self.num(int(o))} * (s{i} == {s})" for s, o in enumerate(outs))]

    def threshold_test(self, v: str, op, x: float, fin) -> str:
        """``v op x`` for an FSM rule or range end: on the input's integer grid in fixed mode,
        where beyond the input's range a test is a constant."""
        if not self.fixed:
            return f"{v} {op.symbol} {_f(x)}"
        t = fsm_sem.threshold_int(x, fin)
        fixed = fsm_sem.constant_outcome(op, t, fin)
        return f"{v} {op.symbol} {_i(t)}" if fixed is None else str(fixed)

    def fsm_update(self, i: int, node) -> list:
        src = node.inputs[0]
        v = f"v{self.idx[src]}"
        p = node.params

        def test(op, x):
            return self.threshold_test(v, op, x, self.g[src].qformat)
        outside = (f"({test(CompareOp.LT, p.lo)}) | ({test(CompareOp.GT, p.hi)})" if self.fixed
                   else f"not (({_f(p.lo)} <= {v}) & ({v} <= {_f(p.hi)}))")   # NaN is outside
        self.late.append(f"b{i} = {outside}")
        self.flags.append(i)
        per_state = [p.rules_from(s) for s in range(len(p.states))]
        shared = all(r == per_state[0] for r in per_state)   # only "*" rules: no dispatch on the state
        dispatch = [(None, per_state[0])] if shared else [(s, r) for s, r in enumerate(per_state) if r]
        # first matching rule of the current state wins: guard = state & own test & no earlier test;
        # at most one guard holds, so the next state is the current one plus one difference
        terms = []
        for s, rules in dispatch:
            earlier = [] if s is None else [f"(s{i} == {s})"]
            for rule in rules:
                t = f"({test(rule.op, rule.threshold)})"
                terms.append(f"({p.states.index(rule.target)} - s{i}) * ({' & '.join(earlier + [t])})")
                earlier.append(f"(not {t})")
        return [f"s{i} = s{i} + " + " + ".join(terms)] if terms else []


class _FixedGen(_Gen):
    """Bit-accurate int64 kernel: ``requantize`` printed inline per node.

    A visit prints a node's numbers through :meth:`lit`, its operands through :meth:`aligned` and
    its requantisation through :meth:`rq`: the shared kernels' general form
    (:class:`pendc.ir.shared_source._DataGen`) overrides those three and prints these same visits
    with every number read from its data argument."""

    fixed = True

    def __init__(self, graph: Graph, runtime_resets: bool = False, share_lut_index: bool = True):
        super().__init__(graph, runtime_resets)
        if share_lut_index:   # a LUT's address and fraction depend on its input and its grid only
            def grid(n):
                p = n.params
                lo = lut_sem.lo_int(p.lo, graph[n.inputs[0]].qformat) if p.shift is not None else None
                return n.inputs[0], lo, p.shift, p.addr_bits, bool(p.periodic), bool(p.interpolate)
            self.group_luts(grid)

    def aligned(self, name: str, frac: int) -> tuple:
        """(expression, bounds) of a node's integer shifted left to ``frac`` fraction bits."""
        n = frac - self.g[name].qformat.frac
        lo, hi = self.bounds(name)
        v = f"v{self.idx[name]}"
        return (f"({v} << {n})" if n else v), (lo << n, hi << n)

    def rq(self, i, node, expr, rng, frac, tgt="", flag="") -> list:
        """:func:`requant_lines`, noting the node's range-check flag."""
        lines, flagged = requant_lines(i, node, expr, rng, frac, tgt, flag)
        if flagged and not flag:
            self.flags.append(i)
        return lines

    def visit_gain(self, node, i):
        a = node.inputs[0]
        c = node.params.constant
        lo, hi = self.bounds(a)
        return self.rq(i, node, f"v{self.idx[a]} * {self.lit(c)}", (min(lo * c, hi * c), max(lo * c, hi * c)),
                            self.g[a].qformat.frac + node.params.cfmt.frac)

    def _pair(self, node) -> tuple:
        frac = max(self.g[x].qformat.frac for x in node.inputs)
        return self.aligned(node.inputs[0], frac), self.aligned(node.inputs[1], frac), frac

    def visit_add(self, node, i):
        (x, (xl, xh)), (y, (yl, yh)), frac = self._pair(node)
        return self.rq(i, node, f"{x} + {y}", (xl + yl, xh + yh), frac)

    def visit_sub(self, node, i):
        (x, (xl, xh)), (y, (yl, yh)), frac = self._pair(node)
        return self.rq(i, node, f"{x} - {y}", (xl - yh, xh - yl), frac)

    def visit_compare(self, node, i):
        (x, _), (y, _), _ = self._pair(node)
        return [f"v{i} = int({x} {node.params.op.symbol} {y})"]

    def visit_neg(self, node, i):
        a = node.inputs[0]
        lo, hi = self.bounds(a)
        return self.rq(i, node, f"-v{self.idx[a]}", (-hi, -lo), self.g[a].qformat.frac)

    def visit_mul(self, node, i):
        a, b = node.inputs
        (al, ah), (bl, bh) = self.bounds(a), self.bounds(b)
        p = [al * bl, al * bh, ah * bl, ah * bh]
        return self.rq(i, node, f"v{self.idx[a]} * v{self.idx[b]}", (min(p), max(p)),
                            self.g[a].qformat.frac + self.g[b].qformat.frac)

    def visit_cast(self, node, i):
        a = node.inputs[0]
        return self.rq(i, node, f"v{self.idx[a]}", self.bounds(a), self.g[a].qformat.frac)

    def visit_mux(self, node, i):
        # a select beyond the data inputs picks the last one (pendc.ir.nodes)
        # every candidate is computed (they have no side effects) and one selected arithmetically
        ins, sel = node.inputs, f"v{self.idx[node.inputs[0]]}"
        lines, terms, flags = [], [], []
        for j in range(1, len(ins)):
            guard = (f"({' & '.join(f'({sel} != {m})' for m in range(len(ins) - 2))})" if j == len(ins) - 1
                     else f"({sel} == {j - 1})")
            guard = "" if guard == "()" else guard
            lines += self.rq(i, node, f"v{self.idx[ins[j]]}", self.bounds(ins[j]), self.g[ins[j]].qformat.frac,
                             tgt=f"v{i}_{j}", flag=f"b{i}_{j}")
            if any(s.startswith(f"b{i}_{j} = ") for s in lines):
                flags.append(f"(b{i}_{j} & {guard})" if guard else f"b{i}_{j}")
            terms.append(f"v{i}_{j} * {guard}" if guard else f"v{i}_{j}")
        if flags:
            lines.append(f"b{i} = {' | '.join(flags)}")
            self.flags.append(i)
        return lines + [f"v{i} = {' + '.join(terms)}"]

    def visit_slice(self, node, i):
        hi, lo = node.params.bits(self.g[node.inputs[0]].qformat.width)
        if hi - lo + 1 > 63 or lo < 0:
            raise ValueError(f"SLICE '{node.name}': bits {hi}..{lo} do not fit the 64-bit golden model")
        a = f"v{self.idx[node.inputs[0]]}"
        return [f"v{i} = ({a} >> {self.lit(min(lo, 63))}) & {self.lit((1 << (hi - lo + 1)) - 1)}"]

    def visit_lut(self, node, i):
        if i in self.lut_member:
            return []       # printed with its group's first LUT
        p = node.params
        a = f"v{self.idx[node.inputs[0]]}"
        fin = self.g[node.inputs[0]].qformat
        shift, bits, interp = p.shift, p.addr_bits, bool(p.interpolate)
        seg = 1 << bits
        members = [self.g.nodes[m] for m in self.lut_group.get(i, [i])]
        for n in members:
            if n.params.table is None or n.params.shift is None:
                raise ValueError(f"LUT '{n.name}' has no table yet (run fill_lut_tables)")
            if len(n.params.table) != seg + interp:
                raise ValueError(f"LUT '{n.name}': table has {len(n.params.table)} entries, expected {seg + interp}")
        d, j, f = f"d{i}", f"j{i}", f"f{i}"
        lines = [f"{d} = {a} - {_i(lut_sem.lo_int(p.lo, fin))}", f"{j} = {d} >> {shift}",
                 f"{f} = {d} & {_i((1 << shift) - 1)}"]
        jj, ff = f"jj{i}", f"ff{i}"
        if p.periodic:
            lines += [f"{jj} = {j} & {seg - 1}", f"{ff} = {f}"]
            nxt = f"{jj} + 1"
        else:   # beyond the domain: the end entry, no interpolation (flagged unless exactly the end)
            out = (f"({j} < 0) | ({j} > {seg}) | (({j} == {seg}) & ({f} != 0))" if interp
                   else f"({j} < 0) | ({j} >= {seg})")
            lines += [f"b{i} = {out}", f"{jj} = min(max({j}, 0), {seg if interp else seg - 1})",
                      f"{ff} = {f} * (1 - b{i})"]
            self.flags.append(i)
            for n in members[1:]:       # each LUT reports its own overflow
                m = self.idx[n.name]
                lines.append(f"b{m} = b{i}")
                self.flags.append(m)
            nxt = f"min({jj} + 1, {seg})"    # at the end entry ff is 0: any entry of the table will do
        for n in members:
            m = self.idx[n.name]
            off = self.offsets[n.name] = self.tab_len
            self.tab_len += len(n.params.table)
            if not interp or shift == 0:
                lines.append(f"v{m} = tab[{off} + {jj}]")
                continue
            # ff == 0 adds (0 + half) >> shift == 0: the same as skipping the interpolation
            step = f"(tab[{off} + {nxt}] - y{m}) * {ff}"
            rnd = f"({step} + {_i(1 << (shift - 1))})" if n.rounding is Rounding.NEAREST else step
            lines += [f"y{m} = tab[{off} + {jj}]", f"v{m} = y{m} + ({rnd} >> {shift})"]
        return lines
