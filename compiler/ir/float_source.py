"""The float64 kernel printer (the kernel :class:`~pendc.ir.compiled.CompiledGraph` runs in
float mode, and the range analysis's training runs): each node as ``FloatInterpreter`` computes it.

LUTs evaluate their expression (no table). Functions of an angle dominate a large plant's
step (the double pendulum on a cart: 112 tables of sines and cosines of three angles, 80 % of
its float step), so LUTs of one input share it: the group's first LUT wraps or clamps the input
once, and a call that several of the group's expressions make (``math.cos(2*math.pi*x)``) is
made once into a variable. The expressions are otherwise printed exactly as alone and the
shared call returns the same bits, so each LUT's value is unchanged to the last bit.
"""

from __future__ import annotations

import re

from .compiled_source import _f, _Gen, _i, lut_expr_source
from .graph import Graph
from .nodes import Kind

# the innermost calls of a printed expression: math.<function>(arguments without calls)
_CALL = re.compile(r"math\.[a-z0-9_]+\([^()]*\)")


class FloatGen(_Gen):
    """float64 kernel mirroring ``FloatInterpreter``."""

    def __init__(self, graph: Graph, runtime_resets: bool = False):
        super().__init__(graph, runtime_resets)
        # LUTs reading the same input over the same domain share one wrapped or clamped input and
        # their common calls
        self.group_luts(lambda n: (n.inputs[0], n.params.lo, n.params.hi, bool(n.params.periodic)))

    def _a(self, node) -> list:
        return [f"v{self.idx[x]}" for x in node.inputs]

    def visit_gain(self, node, i):
        return [f"v{i} = {self._a(node)[0]} * {_f(node.params.value)}"]

    def _binary(self, node, i, op: str) -> list:
        a = self._a(node)
        return [f"v{i} = {a[0]} {op} {a[1]}"]

    def visit_add(self, node, i):
        return self._binary(node, i, "+")

    def visit_sub(self, node, i):
        return self._binary(node, i, "-")

    def visit_mul(self, node, i):
        return self._binary(node, i, "*")

    def visit_neg(self, node, i):
        return [f"v{i} = -{self._a(node)[0]}"]

    def visit_cast(self, node, i):
        return [f"v{i} = {self._a(node)[0]}"]

    def visit_compare(self, node, i):
        a = self._a(node)
        return [f"v{i} = 1.0 * ({a[0]} {node.params.op.symbol} {a[1]})"]

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
        if i in self.lut_member:
            return []       # printed with its group's first LUT
        p, x = node.params, f"x{i}"
        lo, hi = p.lo, p.hi
        members = self.defined_by(i)
        lines = [f"{x} = {self._a(node)[0]}"]
        if p.periodic:
            lines.append(f"{x} = {_f(lo)} + ({x} - {_f(lo)}) % {_f(hi - lo)}")
        elif lo is not None:
            lines += [f"if not ({_f(lo)} <= {x} <= {_f(hi)}):"]
            for j in members:
                lines += [f"    if ov[{j}] < 0:", f"        ov[{j}] = k"]
            lines += [f"    if {_f(lo)} > {x}:", f"        {x} = {_f(lo)}", f"    if {_f(hi)} < {x}:", f"        {x} = {_f(hi)}"]
        exprs = [lut_expr_source(self.g.nodes[j].params.expr, x) for j in members]
        calls = [c for e in exprs for c in _CALL.findall(e)]
        shared = sorted({c for c in calls if calls.count(c) > 1}, key=calls.index)
        for n, call in enumerate(shared):
            lines.append(f"t{i}_{n} = {call}")
            exprs = [e.replace(call, f"t{i}_{n}") for e in exprs]
        return lines + [f"v{j} = float({e})" for j, e in zip(members, exprs)]
