"""Constant folding and algebraic simplification of the untyped graph.

Runs before range analysis and Q-format assignment, so every rewrite only has to
preserve the real-number semantics of :class:`~pendc.ir.interpret.FloatInterpreter`
(folded values are computed by that interpreter itself). Removing work here means
fewer nodes to range, type, tabulate and synthesise.

Rewrites, applied in graph order until nothing changes:

* a combinational node whose inputs are all CONST becomes a CONST of its value
  (not a MUX: see below; a SLICE only for the sign bit, because other bit fields of
  a fractional constant depend on the Q-format it gets later; not if the value is
  not finite or the interpreter flags an out-of-domain LUT input);
* a REGISTER fed by a CONST equal to its reset value is that CONST;
* ``a + 0``, ``0 + a``, ``a - 0`` are ``a``; ``0 - a`` is ``-a``;
* a GAIN by 1 is its input, by 0 the constant 0, by -1 a NEG; a GAIN of a GAIN that
  nothing else reads is one GAIN by the product (a shared inner GAIN stays: merging
  would save no multiplier and would round differently from the value it shares, e.g.
  the encoder increment must see exactly the integrator's increment);
  ``--a`` is ``a``; a MUL by a CONST is a GAIN;
* a MUX with a CONST select is the chosen input; a MUX whose data inputs are all the
  same node is that node.

A node replaced by another one disappears and its consumers and outputs read the
replacement (which inherits the meaning if it had none); a node rewritten in place
keeps its name and meaning. Finally every node that no longer reaches an output is
removed.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..ir.graph import Graph, GraphError
from ..ir.interpret import FloatInterpreter
from ..ir.nodes import Kind, Node, make
from ..ir.visitor import NodeVisitor

def fold_constants(graph: Graph) -> Graph:
    """Fold constants and apply the identities above; returns a new, smaller graph.

    The graph must be untyped (the rewrites keep the real value, not a Q-format's bits).
    """
    typed = [n.name for n in graph.nodes if n.qformat is not None]
    if typed:
        raise GraphError(f"fold_constants runs before Q-format assignment, but node '{typed[0]}' is typed")
    nodes = {n.name: n for n in graph.nodes}     # the current graph, in the original order
    alias: dict = {}                             # removed node -> the node that replaces it

    def resolve(name: str) -> str:
        while name in alias:
            name = alias[name]
        return name

    changed = True
    while changed:
        changed = False
        # dead readers must not count as uses (they would block the GAIN-of-GAIN rule)
        outputs = tuple((port, resolve(n)) for port, n in graph.outputs)
        nodes = {n.name: n for n in live_nodes([_resolved(n, resolve) for n in nodes.values()], outputs)}
        for name in list(nodes):
            node = _resolved(nodes[name], resolve)
            result = _rewrite(node, nodes, lambda n: _single_use(n, nodes, outputs, resolve))
            if isinstance(result, str):
                result = resolve(result)
                del nodes[name]
                alias[name] = result
                if node.meaning and not nodes[result].meaning:
                    nodes[result] = replace(nodes[result], meaning=node.meaning)
                changed = True
            else:
                changed |= result != nodes[name]
                nodes[name] = result

    outputs = tuple((port, resolve(n)) for port, n in graph.outputs)
    final = [_resolved(n, resolve) for n in nodes.values()]
    return Graph.build(graph.name, live_nodes(final, outputs), outputs, graph.info)


def _rewrite(node: Node, nodes: dict, single_use):
    """The node's replacement: the same node, a rewritten node with its name, or the name
    of an existing node that computes the same value. ``single_use(name)`` says whether
    only one node reads ``name`` and it is no output."""
    ins = [nodes[i] for i in node.inputs]
    consts = [n.params.value if n.kind is Kind.CONST else None for n in ins]
    return _REWRITE.visit(node, ins, consts, single_use)


class _Rewrite(NodeVisitor):
    """The folding rules per kind: ``visit_<kind>(node, input nodes, constant input values or None,
    single_use)``. A kind whose value depends only on the step's inputs folds when they are all
    constant (:meth:`_evaluated`); then come its identities."""

    @staticmethod
    def _evaluated(node, ins, consts):
        """A CONST replacing ``node`` if every input is constant and the value is finite, else None."""
        if ins and all(c is not None for c in consts):
            value = _evaluate(node, ins)
            if value is not None:
                return _const(node, value)
        return None

    def _unchanged(self, node, ins, consts, single_use):
        return node

    visit_const = visit_input = visit_fsm = _unchanged     # sources; an FSM holds state

    def _evaluate_only(self, node, ins, consts, single_use):
        return self._evaluated(node, ins, consts) or node

    visit_cast = visit_compare = visit_lut = _evaluate_only

    def visit_slice(self, node, ins, consts, single_use):
        # only the sign bit of a real constant is defined before Q-formats fix its bits
        return (self._evaluated(node, ins, consts) if node.params.sign_bit else None) or node

    def visit_mux(self, node, ins, consts, single_use):
        sel = consts[0]
        if sel is not None and float(sel).is_integer() and 0 <= int(sel) < len(ins) - 1:
            return node.inputs[1 + int(sel)]
        if len(set(node.inputs[1:])) == 1:
            return node.inputs[1]
        return node

    def visit_register(self, node, ins, consts, single_use):
        if consts[0] is not None and float(consts[0]) == float(node.params.reset):
            return _const(node, float(consts[0]))
        return node

    def visit_add(self, node, ins, consts, single_use):
        folded = self._evaluated(node, ins, consts)
        if folded is not None:
            return folded
        if consts[1] == 0:
            return node.inputs[0]
        if consts[0] == 0:
            return node.inputs[1]
        return node

    def visit_sub(self, node, ins, consts, single_use):
        folded = self._evaluated(node, ins, consts)
        if folded is not None:
            return folded
        if consts[1] == 0:
            return node.inputs[0]
        if consts[0] == 0:
            return _rebuild(node, Kind.NEG, node.inputs[1:])
        return node

    def visit_gain(self, node, ins, consts, single_use):
        folded = self._evaluated(node, ins, consts)
        if folded is not None:
            return folded
        c = node.params.value
        if c == 1:
            return node.inputs[0]
        if c == 0:
            return _const(node, 0.0)
        if c == -1:
            return _rebuild(node, Kind.NEG, node.inputs)
        if ins[0].kind is Kind.GAIN and single_use(ins[0].name):
            return _rebuild(node, Kind.GAIN, ins[0].inputs, value=ins[0].params.value * c)
        return node

    def visit_neg(self, node, ins, consts, single_use):
        folded = self._evaluated(node, ins, consts)
        if folded is not None:
            return folded
        if ins[0].kind is Kind.NEG:
            return ins[0].inputs[0]
        return node

    def visit_mul(self, node, ins, consts, single_use):
        folded = self._evaluated(node, ins, consts)
        if folded is not None:
            return folded
        for j in (0, 1):
            if consts[j] is not None:
                return _rebuild(node, Kind.GAIN, [node.inputs[1 - j]], value=float(consts[j]))
        return node


_REWRITE = _Rewrite()


def _single_use(name: str, nodes: dict, outputs: tuple, resolve) -> bool:
    if any(resolve(n) == name for _, n in outputs):
        return False
    return sum(resolve(i) == name for n in nodes.values() for i in n.inputs) == 1


def _evaluate(node: Node, ins: list) -> float | None:
    """The node's value by FloatInterpreter on a graph of just it and its constant inputs;
    None if the result is not finite or the interpreter flagged the step."""
    sources = list({n.name: n for n in ins}.values())
    tiny = Graph.build("fold", sources + [node], [("v", node.name)])
    with np.errstate(all="ignore"):          # 1/v at v = 0 is simply not folded
        trace = FloatInterpreter(tiny).run({}, steps=1)
    value = float(trace.outputs["v"][0])
    if trace.overflows or not math.isfinite(value):
        return None
    return value


def _const(node: Node, value: float) -> Node:
    return make(node.name, Kind.CONST, (), node.meaning, value=float(value))


def _rebuild(node: Node, kind: Kind, inputs, **params) -> Node:
    """``node`` as another kind under the same name, keeping its rounding and overflow choices."""
    return make(node.name, kind, inputs, node.meaning, None, node.rounding, node.overflow, **params)


def _resolved(node: Node, resolve) -> Node:
    """``node`` reading the replacements of removed nodes."""
    inputs = tuple(resolve(i) for i in node.inputs)
    return node if inputs == node.inputs else replace(node, inputs=inputs)


def live_nodes(nodes: list, outputs, keep=()) -> list:
    """The nodes that reach an output (or a node named in ``keep``) through consumers
    (registers and FSMs included), in order."""
    by_name = {n.name: n for n in nodes}
    live, todo = set(), [name for _, name in outputs] + list(keep)
    while todo:
        name = todo.pop()
        if name not in live:
            live.add(name)
            todo.extend(by_name[name].inputs)
    return [n for n in nodes if n.name in live]
