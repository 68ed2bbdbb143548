"""Greedy shrinking of a fuzz case that shows a mismatch (tests/fuzzharness.py).

Tries smaller variants one at a time (shorter input, default schedule, fewer flag outputs,
nodes replaced by a constant, by one of their inputs or by a cast of it) and keeps the first
that still shows a mismatch of the same engine, until none does or the budget is spent.
Cheap under Icarus (a build takes a fraction of a second).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from fuzzharness import check_batch
from graphgen import FuzzCase
from pendc.ir.graph import Graph
from pendc.ir.nodes import Kind


def _rebuild(case: FuzzCase, nodes: list, outputs: list, u: tuple | None = None) -> FuzzCase | None:
    """The case with ``nodes``/``outputs`` (dead nodes dropped), or None if that is not a valid core graph."""
    from pendc.ir.graph import GraphError
    from pendc.ir.verify import verify
    by = {n.name: n for n in nodes}
    live, todo = set(), [n for _, n in outputs]
    while todo:
        x = todo.pop()
        if x not in live and x in by:
            live.add(x)
            todo.extend(by[x].inputs)
    if "u" not in live:
        return None
    try:
        graph = Graph.build(case.graph.name, [n for n in nodes if n.name in live], outputs)
        verify(graph, typed=True)
    except (GraphError, ValueError):
        return None
    return replace(case, graph=graph, u=case.u if u is None else u)


def _candidates(case: FuzzCase, first_step: int):
    """Smaller variants of ``case``: shorter input, no schedule, fewer outputs, nodes replaced
    by constants, bypassed by one of their inputs or by a cast of it."""
    from pendc.ir.nodes import make
    g = case.graph
    if first_step + 2 < len(case.u):
        yield replace(case, u=case.u[:first_step + 2])
    if case.schedule is not None:
        yield replace(case, schedule=None)
    nodes, outputs = list(g.nodes), list(g.outputs)
    for k, (port, _) in enumerate(outputs):
        if port not in ("x", "dx", "theta", "dtheta"):
            yield _rebuild(case, nodes, outputs[:k] + outputs[k + 1:])
    probes = {name for _, name in outputs}
    for n in reversed(g.nodes):
        if n.kind in (Kind.INPUT,) or n.name in probes:
            continue
        for src in dict.fromkeys(n.inputs):
            if g[src].qformat == n.qformat and src != n.name:
                swapped = [replace(m, inputs=tuple(src if i == n.name else i for i in m.inputs)) for m in nodes
                           if m.name != n.name]
                yield _rebuild(case, swapped, outputs)
            elif src != n.name and n.kind is not Kind.CAST:
                cast = make(n.name, Kind.CAST, (src,), qformat=n.qformat, rounding=n.rounding, overflow=n.overflow)
                yield _rebuild(case, [cast if m.name == n.name else m for m in nodes], outputs)
        if n.kind is not Kind.CONST:
            const = make(n.name, Kind.CONST, qformat=n.qformat, value=0.0)
            yield _rebuild(case, [const if m.name == n.name else m for m in nodes], outputs)


def shrink(case: FuzzCase, work: Path, sim: str = "icarus", budget: int = 200, mutate=None) -> FuzzCase:
    """A smaller case that still shows a mismatch of the same engine (greedy, at most ``budget``
    runs); ``mutate`` alters the emitted Verilog as in :func:`fuzzharness.check_batch`."""
    first = check_batch([case], work, sim, golden=None, mutate=mutate).mismatches
    if not first:
        raise ValueError("the case does not fail")
    engine = first[0].engine
    runs = 0
    improved = True
    while improved and runs < budget:
        improved = False
        step = max(0, min(m.step for m in first))
        for cand in _candidates(case, step):
            if cand is None:
                continue
            runs += 1
            found = [m for m in check_batch([cand], work, sim, golden=None if engine == "golden" else 0,
                                            mutate=mutate).mismatches if m.engine == engine]
            if found:
                case, first, improved = cand, found, True
                break
            if runs >= budget:
                break
    return case
