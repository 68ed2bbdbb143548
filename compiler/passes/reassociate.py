"""A state's last increment term added to the state directly (the short chain, typed graph).

The cart's velocity is ``dx + (acc + term)`` with ``term`` (the friction force's product) the
last value of the step, then a clamp whose compares read the increment. In the full core a
10 ns cycle does not hold ``acc + term``, the 56-bit sum and the clamp's muxes (routed 10.6-11 ns,
docs/hardware.md), so this rewrite takes the increment's adder off that path:

* ``state + (a + b)`` becomes ``(state + a) + b``, the first sum in the state sum's format;
* a compare ``(a + b) > x`` of the increment with an early value becomes ``b > x - a``.

Both are the same integers when the increment's own sum neither rounds nor overflows (its
fraction holds both terms', and its range, with the margin of its format, holds every value: it is chosen
so) and the new nodes are exact: their formats keep every fraction bit and one integer bit more
than their inputs. The increment's own node, read by nothing else, goes (with its overflow term:
a value its range analysis never saw).
"""

from __future__ import annotations

from ..ir.graph import Graph, name_allocator
from ..ir.nodes import Kind, make
from ..ir.qformat import QFormat


def add_last_term_to_state(graph: Graph) -> Graph:
    """The typed ``graph`` with every state sum ``s + (a + b)`` whose increment adds exactly
    rewritten as ``(s + a) + b``, and every compare of that increment as ``b`` against the other
    side less ``a`` (see the module doc); unchanged if there is none."""
    changed, extra = {}, []

    fresh = name_allocator(graph.by_name)

    for reg in graph.of_kind(Kind.REGISTER):
        total = _state_sum(graph, reg.name)
        if total is None:
            continue
        inc = graph[total.inputs[1]]
        a, b = inc.inputs
        early = make(fresh(f"{total.name}_early"), Kind.ADD, [reg.name, a], qformat=total.qformat,
                     meaning=f"{reg.name} plus every term of its increment but the last")
        extra.append(early)
        changed[total.name] = make(total.name, Kind.ADD, [early.name, b], meaning=total.meaning,
                                   qformat=total.qformat, rounding=total.rounding, overflow=total.overflow)
        for n in graph.nodes:
            if n.kind is Kind.COMPARE and n.inputs[0] == inc.name:
                other = graph[n.inputs[1]]
                fmt = _exact_difference(other.qformat, graph[a].qformat)
                rest = make(fresh(f"{n.name}_less_{a}"), Kind.SUB, [other.name, a], qformat=fmt,
                            meaning=f"{other.name} less {a}: the room left for {b}")
                extra.append(rest)
                changed[n.name] = make(n.name, Kind.COMPARE, [b, rest.name], meaning=n.meaning,
                                       qformat=n.qformat, params=n.params)
    if not changed:
        return graph
    nodes = [changed.get(n.name, n) for n in graph.nodes] + extra
    read = {i for n in nodes for i in n.inputs} | {node for _, node in graph.outputs}
    nodes = [n for n in nodes if n.name in read or n.kind is Kind.REGISTER]     # the increments now unread
    return Graph.build(graph.name, nodes, graph.outputs, info=graph.info)


def _state_sum(graph: Graph, reg: str):
    """The ADD ``reg + inc`` that updates a register (through the clamp's muxes), when ``inc`` is
    an ADD read by nothing but that sum and compares, whose sum is exact, as is the state's."""
    name = graph[reg].inputs[0]
    while graph[name].kind is Kind.MUX:
        data = [i for i in graph[name].inputs[1:] if graph[i].kind is not Kind.CONST]
        if len(data) != 1:
            return None
        name = data[0]
    total = graph[name]
    if total.kind is not Kind.ADD or total.inputs[0] != reg:
        return None
    inc = graph[total.inputs[1]]
    if inc.kind is not Kind.ADD:
        return None
    readers = [n for n in graph.nodes if inc.name in n.inputs]
    if any(n.name != total.name and not (n.kind is Kind.COMPARE and n.inputs[0] == inc.name) for n in readers):
        return None
    if any(inc.name == port_node for _, port_node in graph.outputs):
        return None
    fa, fb = (graph[i].qformat.frac for i in inc.inputs)
    if max(fa, fb) > inc.qformat.frac or max(graph[reg].qformat.frac, inc.qformat.frac) > total.qformat.frac:
        return None
    return total


def _exact_difference(x: QFormat, y: QFormat) -> QFormat:
    """A format that holds ``x - y`` exactly for any values of the two formats."""
    frac = max(x.frac, y.frac)
    integer = max(x.width - x.frac, y.width - y.frac) + 1
    return QFormat(True, integer + frac, frac)
