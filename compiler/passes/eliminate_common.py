"""Common-subexpression elimination: one node for each distinct computation.

Two nodes compute the same value every step when they have the same kind, read the
same nodes (in any order for the commutative ADD and MUL), and carry the same params,
Q-format, rounding and overflow. Such a pair is merged into the one that comes first
in graph order; consumers and outputs of the other read the survivor. INPUT, REGISTER
and FSM nodes are never merged: they have identity (a port, a state element), and
keeping every state element is what the designer asked for.

Works on typed and untyped graphs alike, because equal keys include the Q-format.
"""

from __future__ import annotations

from dataclasses import replace

from ..ir.graph import Graph
from ..ir.nodes import Kind, Node

_IDENTITY = (Kind.INPUT, Kind.REGISTER, Kind.FSM)
_COMMUTATIVE = (Kind.ADD, Kind.MUL)


def eliminate_common_subexpressions(graph: Graph) -> Graph:
    """Merge equal nodes until none are left (see module docstring); returns a new graph.

    The survivor keeps its name and its meaning, or takes the first non-empty meaning
    of the nodes merged into it.
    """
    nodes = {n.name: n for n in graph.nodes}
    alias: dict = {}

    def resolve(name: str) -> str:
        while name in alias:
            name = alias[name]
        return name

    # One sweep in evaluation order already sees every input resolved (combinational
    # inputs come first, and the stateful nodes that break cycles are never merged);
    # the loop is a guard that makes the fixed point explicit rather than assumed.
    changed = True
    while changed:
        changed = False
        seen: dict = {}
        for name in list(nodes):
            node = _with_inputs(nodes[name], tuple(resolve(i) for i in nodes[name].inputs))
            nodes[name] = node
            if node.kind in _IDENTITY:
                continue
            key = _key(node)
            first = seen.setdefault(key, name)
            if first != name:
                alias[name] = first
                del nodes[name]
                if node.meaning and not nodes[first].meaning:
                    nodes[first] = replace(nodes[first], meaning=node.meaning)
                changed = True

    final = [_with_inputs(n, tuple(resolve(i) for i in n.inputs)) for n in nodes.values()]
    outputs = tuple((port, resolve(n)) for port, n in graph.outputs)
    return Graph.build(graph.name, final, outputs, graph.info)


def _key(node: Node) -> tuple:
    inputs = tuple(sorted(node.inputs)) if node.kind in _COMMUTATIVE else node.inputs
    # params hold floats: -0.0 == 0.0 would merge a CONST -0.0 into 0.0, which is harmless
    return (node.kind, inputs, node.params, node.qformat, node.rounding, node.overflow)


def _with_inputs(node: Node, inputs: tuple) -> Node:
    return node if inputs == node.inputs else replace(node, inputs=inputs)
