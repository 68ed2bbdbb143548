"""Round an operand before a sum or a select instead of the result after it (the short chain).

A sum whose output keeps fewer fraction bits than one of its inputs rounds the sum: a second
carry chain behind the adder, on every path through it (the delay model charges it, and in
the full core it is where a 10 ns schedule loses most cycles: one rounded sum per cycle). When
only one input carries the extra bits, rounding that input first gives the same number to the
bit: round-half-up and truncation are ``floor(v + c)``, and adding a value that is a whole
number of output LSBs commutes with them. So ``a + b`` with ``b`` on the output's grid is
``round(a) + b``, and the rounding of ``a`` runs beside whatever computes ``b``. For a select it
holds whatever the inputs: ``round(s ? a : b)`` is ``s ? round(a) : round(b)``.

Not for a difference whose subtrahend carries the extra bits (``floor(-b + c)`` is not
``-floor(b + c)`` at a tie), nor when both inputs of a sum do (two roundings are not one).
The casts keep one more integer bit than their input, so rounding up never overflows; the
golden model follows the graph as always, and this graph computes the same numbers.
"""

from __future__ import annotations

from ..ir.graph import Graph
from ..ir.nodes import Kind, make
from ..ir.qformat import QFormat


def round_operands_early(graph: Graph) -> Graph:
    """The typed ``graph`` with the roundings of sums and selects moved onto the operand (see
    the module doc); a graph with none to move is returned as it is."""
    casts: dict = {}
    used = set(graph.by_name)
    nodes = []

    def rounded(name: str, frac: int, like) -> str:
        """``name`` rounded to ``frac`` fraction bits as ``like`` rounds (a CAST, shared)."""
        key = (name, frac, like.rounding)
        if key not in casts:
            q = graph[name].qformat
            fmt = QFormat(q.signed, max(2, q.width - (q.frac - frac) + 1), frac)
            cast, i = f"{name}_r{frac}", 1
            while cast in used:
                i += 1
                cast = f"{name}_r{frac}_{i}"
            used.add(cast)
            casts[key] = make(cast, Kind.CAST, [name], qformat=fmt, rounding=like.rounding,
                              meaning=f"{name} rounded to {frac} fraction bits before {like.name}")
        return casts[key].name

    for n in graph.nodes:
        movable = _movable_inputs(graph, n)
        if movable:
            inputs = list(n.inputs)
            for k in movable:
                inputs[k] = rounded(inputs[k], n.qformat.frac, n)
            n = make(n.name, n.kind, inputs, meaning=n.meaning, qformat=n.qformat, rounding=n.rounding,
                     overflow=n.overflow, params=n.params)
        nodes.append(n)
    if not casts:
        return graph
    return Graph.build(graph.name, nodes + list(casts.values()), graph.outputs, info=graph.info)


def _movable_inputs(graph: Graph, n) -> list:
    """Positions of the inputs of ``n`` whose rounding may move onto them (see the module doc)."""
    if n.kind not in (Kind.ADD, Kind.SUB, Kind.MUX) or n.qformat is None:
        return []
    data = range(1, len(n.inputs)) if n.kind is Kind.MUX else range(len(n.inputs))
    excess = [k for k in data if graph[n.inputs[k]].qformat.frac > n.qformat.frac]
    if n.kind is Kind.MUX:
        return excess
    if len(excess) != 1 or (n.kind is Kind.SUB and excess[0] == 1):
        return []
    return excess
