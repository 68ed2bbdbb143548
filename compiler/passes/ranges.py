"""Range analysis: simulate the untyped graph in real arithmetic over training stimuli.

The thesis took every variable's maximum from simulating its software model (§4.2);
this pass does the same on the IR itself, so every intermediate node gets a range,
not just the states. Each stimulus is a sampled voltage (ZOH); the graph runs one
step per ``dt``. Ranges can be overridden per node from the model file.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..ir.graph import Graph
from ..ir.nodes import Kind


@dataclass(frozen=True)
class Ranges:
    """Per node: the largest |value| seen, and for LUT inputs the smallest and largest value.

    ``sources`` names the stimuli that were simulated; ``overridden`` the nodes whose
    maximum the model file set by hand.
    """

    max_abs: dict
    lo: dict
    hi: dict
    sources: tuple
    overridden: tuple = ()

    def __getitem__(self, name: str) -> float:
        return self.max_abs[name]


def per_step(u: np.ndarray, t: np.ndarray, dt: float) -> np.ndarray:
    """Hold each sample of ``u`` for its interval: one value per step of ``dt``."""
    steps = np.maximum(1, np.round(np.diff(t) / dt).astype(np.int64))
    return np.repeat(u[:-1], steps)


def analyze_ranges(graph: Graph, stimuli: dict, dt: float, overrides: dict | None = None,
                   engine: str = "compiled") -> Ranges:
    """Record each node's max |value| over ``stimuli`` (name -> (t, u)) in float semantics.

    ``engine`` is "compiled" (numba kernel, for real runs) or "interpreter" (slow,
    for tiny tests). ``overrides`` (node -> max |value|) replace what was measured.
    """
    lut_inputs = sorted({n.inputs[0] for n in graph.of_kind(Kind.LUT)})
    max_abs = {n.name: 0.0 for n in graph.nodes}
    lo = {name: np.inf for name in lut_inputs}
    hi = {name: -np.inf for name in lut_inputs}
    for name, (t, u) in stimuli.items():
        steps = per_step(np.asarray(u, float), np.asarray(t, float), dt)
        trace = _runner(graph, engine).run({"u": steps}, track_max=True, record=tuple(lut_inputs), every=1)
        for node, value in trace.max_abs.items():
            max_abs[node] = max(max_abs[node], float(value))
        for node in lut_inputs:
            values = trace.outputs[node]
            lo[node] = min(lo[node], float(np.min(values)))
            hi[node] = max(hi[node], float(np.max(values)))
    overrides = dict(overrides or {})
    unknown = set(overrides) - set(max_abs)
    if unknown:
        raise ValueError(f"range override for unknown node(s): {', '.join(sorted(unknown))}")
    max_abs.update({k: float(v) for k, v in overrides.items()})
    return Ranges(max_abs=max_abs, lo=lo, hi=hi, sources=tuple(stimuli), overridden=tuple(sorted(overrides)))


def _runner(graph: Graph, engine: str):
    if engine == "compiled":
        from ..ir.compiled import CompiledGraph
        return CompiledGraph(graph, "float")
    if engine == "interpreter":
        from ..ir.interpret import FloatInterpreter
        return _RecordingInterpreter(FloatInterpreter(graph))
    raise ValueError(f"unknown engine {engine!r}")


class _RecordingInterpreter:
    """Adapts the reference interpreter to the ``record=`` argument of the compiled engine."""

    def __init__(self, interp):
        self.interp = interp

    def run(self, inputs, track_max=False, record=(), every=1):
        from dataclasses import replace
        from ..ir.graph import Graph as G
        g = self.interp.graph
        outputs = tuple(g.outputs) + tuple((f"rec:{n}", n) for n in record)
        graph = G(name=g.name, nodes=g.nodes, outputs=outputs, info=g.info)
        trace = type(self.interp)(graph).run(inputs, track_max=track_max, every=every)
        rec = {n: trace.outputs[f"rec:{n}"] for n in record}
        return replace(trace, outputs={**{p: v for p, v in trace.outputs.items() if not p.startswith("rec:")}, **rec})
