"""Range analysis: simulate the untyped graph in real arithmetic over training stimuli.

The thesis took every variable's maximum from simulating its software model (§4.2);
this pass does the same on the IR itself, so every intermediate node gets a range,
not just the states. Each stimulus is a sampled voltage (ZOH); the graph runs one
step per ``dt``. A node may declare a capacity (param ``max_abs``, e.g. the turn counter)
that its range then covers; ranges can be overridden per node from the model file.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..ir.compiled import quantize, run_side_by_side
from ..ir.graph import Graph
from ..ir.nodes import Kind
from ..model.interface import graph_interface


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


def input_port(graph: Graph) -> str:
    """The port name of the graph's one input (a plant step takes one input signal)."""
    ports = [n.params.port for n in graph.of_kind(Kind.INPUT)]
    if len(ports) != 1:
        raise ValueError(f"graph '{graph.name}' has {len(ports)} input ports; a plant step takes one")
    return ports[0]


def per_step(u: np.ndarray, t: np.ndarray, dt: float) -> np.ndarray:
    """Hold each sample of ``u`` for its interval: one value per step of ``dt``."""
    return np.repeat(u[:-1], _hold_steps(t, dt))


def per_step_integers(u: np.ndarray, t: np.ndarray, dt: float, fmt) -> np.ndarray:
    """``quantize(per_step(u, t, dt), fmt)``: each held sample quantised once, not at every step
    (the same integers; a stimulus holds a sample for a thousand steps)."""
    return np.repeat(quantize(u[:-1], fmt), _hold_steps(t, dt))


def _hold_steps(t: np.ndarray, dt: float) -> np.ndarray:
    return np.maximum(1, np.round(np.diff(t) / dt).astype(np.int64))


def full_scale_switching(duration: float = 5.0, seed: int = 9, fs: float = 1000.0,
                         levels: tuple = (0.0, 10.0)) -> tuple:
    """The input's low and high ``levels`` (default the SCT drive's 0 V and 10 V) in turn, switching
    after random holds of 1-50 ms: what a wild controller does."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(duration * fs)) + 1) / fs
    edges = np.cumsum(rng.integers(1, 51, size=len(t)))          # sample index of each switch
    high = (rng.integers(0, 2) + np.arange(len(edges) + 1)) % 2
    level = np.where(high == 1, float(levels[1]), float(levels[0]))
    return t, level[np.searchsorted(edges, np.arange(len(t)), side="right")]


def drive_to_both_ends(hold: float = 1.5, fs: float = 1000.0, levels: tuple = (0.0, 10.0)) -> tuple:
    """The high level for ``hold`` s, then the low one for twice as long: into both track ends."""
    t = np.arange(int(round(3 * hold * fs)) + 1) / fs
    return t, np.where(t < hold, float(levels[1]), float(levels[0]))


def envelope_runs(graph: Graph, hold: float = 0.0) -> list:
    """Training runs at the corners a controller can reach, beyond the identification stimuli:
    full-scale switching, driving into both track ends, and, for each state whose plant interface
    gives a ``training_rate`` (a pendulum spinning beyond its encoder's limit), a run with that
    register reset to the rate, and, when states declare a ``working_range`` (a thermal mass whose
    minutes-long time constant the seconds of training never span), a run from the low ends of
    all of them together and one from the high ends; with ``hold`` (``[hardware] hold_seconds``)
    as well, the input held at its top for ``hold`` seconds from the low ends and at its bottom from
    the high ends (what a held input makes of coupled slow states: a heater at full power for a
    minute parts two sinks by 20 K, which seconds of switching from ends they share never do).
    Full scale is the plant input's range (0 and 10 V for a graph without a plant interface).
    (name, graph, (t, u)) triples."""
    iface = graph_interface(graph)
    levels = (iface.input.lo, iface.input.hi) if iface else (0.0, 10.0)
    runs = [("envelope:full_scale_switching", graph, full_scale_switching(levels=levels)),
            ("envelope:track_ends", graph, drive_to_both_ends(levels=levels))]
    spun = [s for s in (iface.states if iface else ()) if s.training_rate is not None
            and s.name in graph.by_name and graph[s.name].kind is Kind.REGISTER]
    for spec in spun:
        spinning = graph.map_nodes(lambda n, s=spec: n.with_params(reset=float(s.training_rate))
                                   if n.name == s.name else n)
        name = "envelope:spin" if len(spun) == 1 else f"envelope:spin:{spec.name}"
        runs.append((name, spinning, full_scale_switching(3.0, seed=10, levels=levels)))
    # every state with a range starts at the same end of it, together: coupled positions (a motor
    # and its load through a gear) move as one instead of twisting their coupling by the whole range
    ranged = {s.name: s.working_range for s in (iface.states if iface else ())
              if s.working_range is not None and s.name in graph.by_name}
    for i, end in enumerate(("low", "high") if ranged else ()):
        started = graph.map_nodes(lambda n, i=i: n.with_params(reset=float(ranged[n.name][i]))
                                  if n.name in ranged else n)
        runs.append((f"envelope:range_{end}", started, full_scale_switching(3.0, seed=11, levels=levels)))
        if hold > 0:
            t = np.array([0.0, float(hold)])
            held = levels[0] if end == "high" else levels[1]
            runs.append((f"envelope:hold_{'low' if end == 'high' else 'high'}", started, (t, np.full(2, held))))
    return runs


def analyze_ranges(graph: Graph, stimuli: dict, dt: float, overrides: dict | None = None,
                   engine: str = "compiled", envelope: bool | None = None, hold: float = 0.0) -> Ranges:
    """Record each node's max |value| over ``stimuli`` (name -> (t, u)) in float semantics.

    ``engine`` is "compiled" (numba kernel, for real runs) or "interpreter" (slow,
    for tiny tests). ``overrides`` (node -> max |value|) replace what was measured. The envelope's
    runs from the declared ranges' ends and its held runs count only until a ranged state leaves
    its range by :data:`RANGE_SLACK` of it (a plant that runs away from there).
    ``envelope`` adds the runs of :func:`envelope_runs` (full-scale input, track ends, a
    spinning pendulum), so a controller's worst case stays in range; their names are listed
    in ``sources`` as ``envelope:...``. By default (None) they run for graphs lowered from a
    plant model (graph info "model") on the compiled engine; the interpreter is for tiny checks.
    """
    if envelope is None:
        envelope = engine == "compiled" and "model" in dict(graph.info)
    lut_inputs = sorted({n.inputs[0] for n in graph.of_kind(Kind.LUT)})
    max_abs = {n.name: 0.0 for n in graph.nodes}
    lo = {name: np.inf for name in lut_inputs}
    hi = {name: -np.inf for name in lut_inputs}
    runs = [(name, graph, tu) for name, tu in stimuli.items()]
    if envelope:
        runs += envelope_runs(graph, hold)
    port = input_port(graph)

    def training_run(runner, t, u, every=None):
        def run():
            steps = per_step(np.asarray(u, float), np.asarray(t, float), dt)
            # the kernel keeps each node's extremes; recording the outputs or the LUT inputs at every
            # step of the training runs (tens of millions) took gigabytes: one row is recorded
            return runner.run({port: steps}, track_max=True, every=every or max(1, len(steps)))
        return run

    ranged = _ranged_ports(graph)
    held = [name.startswith(("envelope:hold_", "envelope:range_")) and bool(ranged) for name, _, _ in runs]
    calls = [training_run(_runner(g, engine), t, u, _every(t, dt) if hold_run else None)
             for (_, g, (t, u)), hold_run in zip(runs, held)]
    traces = run_side_by_side(calls) if engine == "compiled" else [call() for call in calls]
    for k, ((_, g, (t, u)), hold_run) in enumerate(zip(runs, held)):
        # a run from the ranges' ends, or a held input, drives a plant that runs away (an exothermic
        # reactor from the top of its temperature range) far beyond the range its file declares it
        # works in: the run counts until a ranged state leaves that range by a tenth of it (beyond,
        # in operation, the core's overflow flag says so)
        out = _range_exit(traces[k], ranged) if hold_run else None
        if out is not None:
            steps = per_step(np.asarray(u, float), np.asarray(t, float), dt)
            end = _exit_step(lambda n, every, g=g: _runner(g, engine).run({port: steps[:n]}, track_max=True,
                                                                          every=every),
                             out * _every(t, dt), _every(t, dt), ranged)
            traces[k] = _runner(g, engine).run({port: steps[:max(end, 1)]}, track_max=True, every=max(end, 1))
    for trace in traces:
        for node, value in trace.max_abs.items():
            max_abs[node] = max(max_abs[node], float(value))
        for node in lut_inputs:
            low, high = trace.extremes[node]
            lo[node] = min(lo[node], low)
            hi[node] = max(hi[node], high)
    for node in graph.nodes:
        # a declared capacity (a turn counter, an input port's full scale) holds even when the
        # training stimuli never reach it
        declared = node.params.max_abs
        if declared is not None:
            max_abs[node.name] = max(max_abs[node.name], float(declared))
    overrides = dict(overrides or {})
    unknown = set(overrides) - set(max_abs)
    if unknown:
        raise ValueError(f"range override for unknown node(s): {', '.join(sorted(unknown))}")
    max_abs.update({k: float(v) for k, v in overrides.items()})
    return Ranges(max_abs=max_abs, lo=lo, hi=hi, sources=tuple(name for name, _, _ in runs),
                  overridden=tuple(sorted(overrides)))


RANGE_SLACK = 0.1       # of a declared range: how far a held run may leave it and still count
HOLD_ROWS = 4096        # rows a held run records of its ranged states, to find where it leaves them


def _ranged_ports(graph: Graph) -> dict:
    """``{output port: (low, high)}`` of the reported states whose plant file declares a range,
    widened by :data:`RANGE_SLACK` of it."""
    iface = graph_interface(graph)
    spans = {s.name: s.working_range for s in (iface.states if iface else ()) if s.working_range is not None}
    out = {}
    for port, node in graph.outputs:
        if node in spans:
            low, high = spans[node]
            slack = RANGE_SLACK * (high - low)
            out[port] = (low - slack, high + slack)
    return out


def _every(t, dt: float) -> int:
    """Steps between the recorded rows of a held run (about HOLD_ROWS rows)."""
    return max(1, int(round((float(t[-1]) - float(t[0])) / dt)) // HOLD_ROWS)


def _exit_step(run, n: int, every: int, ranged: dict) -> int:
    """The first step after which a ranged state lies outside its widened range, given that it
    does after ``n`` steps (a row recorded ``every`` steps): ``run(n, every)`` runs the first
    ``n`` steps recording every ``every``-th; the recording grows finer, HOLD_ROWS rows at a time."""
    while every > 1 and n > 1:
        every = max(1, n // HOLD_ROWS)
        row = _range_exit(run(n, every), ranged)
        if row is None:            # not within those steps after all (rounding): keep them all
            return n
        n = row * every
    return n


def _range_exit(trace, ranged: dict) -> int | None:
    """The first recorded row at which a ranged state lies outside its widened range, else None."""
    first = None
    for port, (low, high) in ranged.items():
        values = np.asarray(trace.outputs.get(port, ()), dtype=float)
        outside = np.flatnonzero((values < low) | (values > high))
        if outside.size:
            first = int(outside[0]) if first is None else min(first, int(outside[0]))
    return first


def _runner(graph: Graph, engine: str):
    if engine == "compiled":
        from ..ir.compiled import CompiledGraph
        return CompiledGraph(graph, "float")
    if engine == "interpreter":
        from ..ir.interpret import FloatInterpreter
        return _RecordingInterpreter(FloatInterpreter(graph))
    raise ValueError(f"unknown engine {engine!r}")


class _RecordingInterpreter:
    """Adapts the reference interpreter to the compiled float engine's ``extremes``: every node is
    recorded (the interpreter is for tiny graphs) and its smallest and largest value taken."""

    def __init__(self, interp):
        self.interp = interp

    def run(self, inputs, track_max=False, every=1):
        from dataclasses import replace
        from ..ir.graph import Graph as G
        g = self.interp.graph
        names = [n.name for n in g.nodes]
        outputs = tuple(g.outputs) + tuple((f"rec:{n}", n) for n in names)
        graph = G(name=g.name, nodes=g.nodes, outputs=outputs, info=g.info)
        trace = type(self.interp)(graph).run(inputs, track_max=track_max)
        extremes = {n: (float(np.min(trace.outputs[f"rec:{n}"])), float(np.max(trace.outputs[f"rec:{n}"])))
                    for n in names if trace.steps}
        return replace(trace, outputs={p: v[::every] for p, v in trace.outputs.items() if not p.startswith("rec:")},
                       extremes=extremes)
