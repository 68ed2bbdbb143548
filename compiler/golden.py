"""The golden model: the compiled core's exact integer behaviour, in physical units.

:class:`GoldenModel` runs the typed IR bit-accurately — through the numba kernel by
default, or the reference interpreter (``engine="interpreter"``, slow, for cross
checks) — on sampled inputs, and returns states at the sample times like the float
simulator does, so the two can be compared column by column. The Verilog must match
its integers bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import PendcError
from .ir.compiled import CompiledGraph
from .ir.graph import Graph
from .ir.interpret import FixedInterpreter
from .sim.simulator import SimResult

STATES = ("x", "dx", "theta", "dtheta")


@dataclass(frozen=True)
class GoldenRun:
    """States at the sample times (``result``), raw integers of every output per recorded step
    (``raw``), and the nodes that left their range with the first step they did (``overflows``)."""

    result: SimResult
    raw: dict
    overflows: dict


def steps_per_sample(t: np.ndarray, dt: float) -> np.ndarray:
    steps = np.round(np.diff(t) / dt).astype(np.int64)
    if np.any(steps < 1) or not np.allclose(steps * dt, np.diff(t), rtol=1e-6, atol=1e-12):
        raise PendcError(f"sample times must be whole multiples of the model step dt = {dt:g} s")
    return steps


class GoldenModel:
    """Bit-accurate runs of a typed graph (``BuildResult.graph``) with step ``dt``."""

    def __init__(self, graph: Graph, dt: float, engine: str = "compiled"):
        self.graph = graph
        self.dt = dt
        self.engine = engine
        self.u_format = graph["u"].qformat
        self._run = CompiledGraph(graph, "fixed").run if engine == "compiled" else FixedInterpreter(graph).run

    def quantize_input(self, u) -> np.ndarray:
        """Input voltages as the core's input-port integers (nearest, saturating)."""
        f = self.u_format
        scaled = np.floor(np.ldexp(np.asarray(u, dtype=np.float64), f.frac) + 0.5)
        return np.clip(scaled, f.min_int, f.max_int).astype(np.int64)

    def run_steps(self, u_per_step, every: int = 1, record: tuple = ()):
        """Raw trace for one input integer (or voltage) per step."""
        u = np.asarray(u_per_step)
        ints = u if np.issubdtype(u.dtype, np.integer) else self.quantize_input(u)
        if self.engine == "compiled":
            return self._run({"u": ints}, every=every, record=record)
        return self._run({"u": [int(v) for v in ints]}, every=every)

    def __call__(self, t, u) -> GoldenRun:
        """States at the sample times ``t`` for ZOH input samples ``u`` (from reset, t[0] = 0 state)."""
        t = np.asarray(t, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        steps = steps_per_sample(t, self.dt)
        per_step = np.repeat(self.quantize_input(u[:-1]), steps)
        total = int(steps.sum())
        trace = self.run_steps(np.append(per_step, per_step[-1:] if total else self.quantize_input(u[:1])))
        rows = np.concatenate([[0], np.cumsum(steps)])
        states = {s: np.asarray(trace.outputs[s], dtype=np.float64)[rows] * self.graph.output(s).qformat.lsb
                  for s in STATES}
        result = SimResult(t=t, u=u, states=states)
        return GoldenRun(result=result, raw={k: np.asarray(v) for k, v in trace.outputs.items()},
                         overflows=dict(trace.overflows))
