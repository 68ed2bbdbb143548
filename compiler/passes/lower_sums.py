"""A sum's last term pushed through the selects that choose it (the short chain's ``sum_into_mux``).

``acc + (s ? a : b)`` is ``s ? acc + a : acc + b``: the adders then run beside the selection
instead of after it, and ``acc + (-y)`` is ``acc - y``, so a term chosen among ``y``, ``-y`` and
``0`` (``y * sgn(v)``) costs one adder and the muxes behind it, not a negation, the muxes and an
adder. Under a select ``v != 0`` the chosen branch needs no ``v == 0`` test: the nested select on
it keeps its other input. In real numbers nothing changes; in fixed point each new adder gets
its own format from its range (the golden model follows the graph).

On the friction loop of the cart (docs/hardware.md, "The short-chain arithmetic") this is the
force: ``F_in - b dx + (moving ? (dx < 0 ? -T : T) : stick)``, the friction table ``T`` read
from this step's velocity, one adder and two muxes from ``T`` to the force instead of a negation,
three muxes and an adder.
"""

from __future__ import annotations

from collections import Counter

from ..ir.compare_ops import CompareOp
from ..ir.graph import name_allocator
from ..ir.nodes import Kind, make


def push_sums_into_muxes(nodes: list) -> list:
    """``nodes`` with every ADD/SUB whose second input is a two-way MUX read by nothing else
    (and whose range is not declared: a counter keeps its form) rewritten as that MUX over sums (recursively through nested single-use muxes and
    negations); the rewritten sum keeps its name and meaning. Nodes left unread stay in the
    list (the caller's dead-node sweep drops them)."""
    by_name = {n.name: n for n in nodes}
    uses = Counter(i for n in nodes for i in n.inputs)
    out = []

    def own(name: str) -> bool:
        return uses[name] == 1 and by_name[name].kind in (Kind.MUX, Kind.NEG)

    fresh = name_allocator(by_name)

    def nonzero_when(sel: str):
        """(value known non-zero when the select is 1, ... when it is 0) of a compare with 0."""
        s = by_name[sel]
        if s.kind is not Kind.COMPARE or not _is_zero(by_name.get(s.inputs[1])):
            return None, None
        op = s.params.op
        return (s.inputs[0], None) if op is CompareOp.NE else (None, s.inputs[0]) if op is CompareOp.EQ else (None, None)

    def plus(acc: str, term: str, negative: bool, name: str, known: frozenset) -> str:
        t = by_name[term]
        if _is_zero(t):
            return acc
        if own(term) and t.kind is Kind.NEG:
            return plus(acc, t.inputs[0], not negative, name, known)
        if own(term) and t.kind is Kind.MUX and len(t.inputs) == 3:
            sel, if0, if1 = t.inputs
            when1, when0 = nonzero_when(sel)
            if when1 is not None and when1 in known:        # v != 0 is known: the select is 1
                return plus(acc, if1, negative, name, known)
            if when0 is not None and when0 in known:        # v == 0 is known false: the select is 0
                return plus(acc, if0, negative, name, known)
            a = plus(acc, if0, negative, fresh(f"{name}_if0"), known | ({when0} - {None}))
            b = plus(acc, if1, negative, fresh(f"{name}_if1"), known | ({when1} - {None}))
            out.append(make(name, Kind.MUX, [sel, a, b]))
            return name
        out.append(make(name, Kind.SUB if negative else Kind.ADD, [acc, term]))
        return name

    for n in nodes:
        if n.kind in (Kind.ADD, Kind.SUB) and n.params.max_abs is None and own(n.inputs[1]) \
                and by_name[n.inputs[1]].kind is Kind.MUX and len(by_name[n.inputs[1]].inputs) == 3:
            start = len(out)
            plus(n.inputs[0], n.inputs[1], n.kind is Kind.SUB, n.name, frozenset())
            top = next(i for i in range(start, len(out)) if out[i].name == n.name)
            out[top] = make(n.name, out[top].kind, out[top].inputs, meaning=n.meaning)
            continue
        out.append(n)
    return out


def _is_zero(node) -> bool:
    return node is not None and node.kind is Kind.CONST and node.params.value == 0.0
