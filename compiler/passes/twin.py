"""A typed graph against its float twin: the graph in real arithmetic with exact tables.

The error budget (:mod:`.error_budget`) and its segmented form (:mod:`.segmented_error`) both
measure |fixed - float| with these: the twin (the graph without its CASTs), the states whose
error counts, and the plain comparison over check stimuli (per state the max error, per node a
sampled max error).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..ir.compiled import CompiledGraph, run_side_by_side
from ..ir.graph import Graph
from ..ir.nodes import Kind
from ..model.interface import graph_interface
from .ranges import input_port, per_step, per_step_integers


class BudgetError(ValueError):
    """The check run overflowed: a range problem that more fraction bits cannot fix."""


def budget_states(graph: Graph) -> tuple:
    """The states whose error is measured and whose accumulators the budget widens: the states
    the plant interface reports (for a graph built by hand, its outputs that are registers)."""
    iface = graph_interface(graph)
    if iface is not None:
        return iface.outputs
    return tuple(port for port, node in graph.outputs if graph[node].kind is Kind.REGISTER)


def float_twin(graph: Graph) -> tuple[Graph, dict]:
    """The graph without its CASTs, in an order independent of where they stood, and {CAST: the
    node whose value it has}. A CAST is the identity in real arithmetic, and the budget's rounds
    differ mostly in the operand CASTs in front of products: their float twins then print the
    same kernel source, so one compile serves every round (numbers are bit-identical: every
    evaluation order of the same nodes computes the same values)."""
    alias = {}
    for n in graph.nodes:        # evaluation order: a chain of CASTs resolves to its first input
        if n.kind is Kind.CAST:
            alias[n.name] = alias.get(n.inputs[0], n.inputs[0])
    nodes = [replace(n, inputs=tuple(alias.get(i, i) for i in n.inputs))
             for n in sorted(graph.nodes, key=lambda n: n.name) if n.kind is not Kind.CAST]
    outputs = tuple((port, alias.get(node, node)) for port, node in graph.outputs)
    return Graph.build(graph.name, nodes, outputs, graph.info), alias


def compare_fixed_float(graph: Graph, stimuli: dict, dt: float, engine: str = "compiled",
                        every: int = 1000, like: Graph | None = None,
                        float_runs: dict | None = None, states: bool = True, nodes: bool = True) -> tuple:
    """Per stimulus and state the max |fixed - float|, and per node the sampled max |fixed - float|
    (``like``: an earlier typing whose kernel this one may share, see CompiledGraph); ``states``
    or ``nodes`` False leaves that half out (None in its place: each is a run of every stimulus).

    ``float_runs``: a dict kept across calls on the same ``stimuli`` (the budget's rounds). The
    rounds' float twins mostly print the same kernel with the same data, so they compute the
    same numbers: a run is looked up by everything it reads instead of run again."""
    names = tuple(n.name for n in graph.nodes if n.kind not in (Kind.CONST,))
    twin, alias = float_twin(graph)
    fixed, flt = CompiledGraph(graph, "fixed", like=like), CompiledGraph(twin, "float")
    errors, node_errors = ({} if states else None), ({n: 0.0 for n in names} if nodes else None)
    compared, port = budget_states(graph), input_port(graph)
    in_fmt = next(n.qformat for n in graph.of_kind(Kind.INPUT))
    recorded = tuple(sorted({alias.get(n, n) for n in names}))     # in no round's order: rounds share the run
    for name, (t, u) in stimuli.items():
        u, t = np.asarray(u, float), np.asarray(t, float)
        steps = {port: per_step(u, t, dt)}
        ints = {port: per_step_integers(u, t, dt, in_fmt)}      # what each fixed run would quantise anew
        if states:
            a, b = run_side_by_side([lambda: fixed.run(ints), lambda: _float_run(flt, steps, name, float_runs)])
            if a.overflows:
                node, step = min(a.overflows.items(), key=lambda kv: (kv[1], kv[0]))
                raise BudgetError(f"node '{node}' left its range at step {step} of check stimulus '{name}': the "
                                  f"training ranges do not cover it (raise margin_bits or override its range)")
            errors[name] = {s: float(np.max(np.abs(a.outputs[s] * graph.output(s).qformat.lsb - b.outputs[s])))
                            for s in compared}
        if nodes:
            sa, sb = run_side_by_side([lambda: fixed.run(ints, every=every, record=names),
                                       lambda: _float_run(flt, steps, name, float_runs, every=every,
                                                          record=recorded)])
            for n in names:
                lsb = graph[n].qformat.lsb
                diff = np.abs(np.asarray(sa.outputs[n], np.float64) * lsb
                              - np.asarray(sb.outputs[alias.get(n, n)], np.float64))
                node_errors[n] = max(node_errors[n], float(np.max(diff)) if diff.size else 0.0)
    return errors, node_errors


def _float_run(flt, steps: dict, stimulus: str, memo: dict | None, every: int = 1, record: tuple = ()):
    """``flt.run(steps, every=, record=)``, or the same run's Trace from ``memo``: the key holds the
    kernel source, its tables and resets, the stimulus and what is recorded (the inputs of one
    stimulus name are the same within one budget)."""
    if memo is None:
        return flt.run(steps, every=every, record=record)
    key = (flt.source, flt.tables.tobytes(), flt.resets.tobytes(), stimulus, every, record)
    if key not in memo:
        memo[key] = flt.run(steps, every=every, record=record)
    return memo[key]


