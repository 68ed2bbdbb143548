"""Short-horizon simulation error (multiple shooting) for identification.

Why not one long simulation: the pendulum is lightly damped and the swing-up makes
it chaotic, and friction makes the cart stick or slip on tiny differences, so a
20 s free run diverges from the data for reasons unrelated to the parameters and
its error surface is ragged. Instead the data are cut into segments (default
0.5 s); each segment is simulated from the *measured* state at its start (positions
from the encoders, velocities from a Savitzky-Golay derivative of them), and the
residual is the simulated-minus-measured x and theta over every segment, each
output scaled by its spread in the data so both weigh like MATLAB's fit%. Errors
cannot accumulate past a segment, yet each segment is long enough (hundreds of
samples) for friction, damping, lags and delays to shape it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter

from ..errors import PendcError
from ..model.plant import PlantModel
from ..sim.simulator import Simulator

HISTORY = 0.1          # s of input history handed to each segment (longest delay it can see)
SAVGOL_WINDOW = 0.031   # s: smooths encoder quantisation, short against the pendulum period (~1 s)


def estimate_velocities(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """dy/dt by a cubic Savitzky-Golay filter over ~31 ms (uniform sampling assumed)."""
    h = float(np.median(np.diff(t)))
    n = max(5, int(round(SAVGOL_WINDOW / h)) | 1)
    if len(y) < n:
        return np.gradient(y, t)
    return savgol_filter(y, n, 3, deriv=1, delta=h)


@dataclass(frozen=True)
class Record:
    """One data set prepared for shooting: samples, estimated velocities, segment bounds."""

    t: np.ndarray
    u: np.ndarray
    x: np.ndarray
    theta: np.ndarray
    dx: np.ndarray
    dtheta: np.ndarray
    bounds: tuple      # (start, stop) sample indices of each segment (stop inclusive)


def prepare(data, segment: float) -> Record:
    t, u = np.asarray(data.t, float), np.asarray(data.u, float)
    x, th = np.asarray(data.column("x"), float), np.asarray(data.column("theta"), float)
    dx = data.dx if data.dx is not None else estimate_velocities(t, x)
    dth = data.dtheta if data.dtheta is not None else estimate_velocities(t, th)
    h = float(np.median(np.diff(t)))
    n = max(2, int(round(segment / h)))
    bounds = tuple((i, min(i + n, len(t) - 1)) for i in range(0, len(t) - 1, n) if min(i + n, len(t) - 1) - i >= 2)
    if not bounds:
        raise PendcError(f"{data.source}: too short for identification ({len(t)} samples)")
    return Record(t=t, u=u, x=x, theta=th, dx=np.asarray(dx, float), dtheta=np.asarray(dth, float), bounds=bounds)


def _subset(record: Record, subset: str) -> Record:
    """All segments, or every other one: fitting on even and scoring on odd segments is a
    held-out check that a flexible effect cannot pass by flexibility alone."""
    if subset == "all":
        return record
    if subset not in ("even", "odd"):
        raise ValueError(f"subset must be all, even or odd, got {subset!r}")
    keep = record.bounds[0 if subset == "even" else 1::2] or record.bounds
    return Record(**{**record.__dict__, "bounds": keep})


class ShootingProblem:
    """Residuals of ``model`` with the parameters ``free`` set to given values.

    ``residual(values)`` is the stacked, scaled (simulated - measured) x and theta
    over all segments of all data sets; ``cost`` is half its squared norm.
    """

    def __init__(self, model: PlantModel, datasets: list, free: list, dt: float = 1e-4, method: str = "rk4",
                 segment: float = 0.5, subset: str = "all"):
        self.model = model
        self.free = list(free)
        self.sim = Simulator(model, dt=dt, method=method)
        unknown = [p for p in self.free if p not in self.sim.param_names]
        if unknown:
            raise PendcError(f"unknown parameter(s) to fit: {', '.join(unknown)} "
                             f"(the model has: {', '.join(self.sim.param_names)})")
        self.index = [self.sim.param_names.index(p) for p in self.free]
        self.records = [_subset(prepare(d, segment), subset) for d in datasets]
        xs = np.concatenate([r.x for r in self.records])
        ths = np.concatenate([r.theta for r in self.records])
        self.scale_x = max(float(np.std(xs)), 1e-6)
        self.scale_theta = max(float(np.std(ths)), 1e-5)
        self.size = 2 * sum(b - a for r in self.records for a, b in r.bounds)
        h = float(np.median(np.diff(self.records[0].t)))
        self.history = int(np.ceil(HISTORY / h))   # input samples before a segment, for delays

    def start_values(self) -> np.ndarray:
        return self.sim.param_vector[self.index].copy()

    def vector(self, values) -> np.ndarray:
        p = self.sim.param_vector.copy()
        p[self.index] = values
        return p

    def residual(self, values) -> np.ndarray:
        p = self.vector(values)
        out = np.empty(self.size)
        k = 0
        for r in self.records:
            for a, b in r.bounds:
                s0 = np.array([r.x[a], r.dx[a], r.theta[a], r.dtheta[a]])
                h0 = max(0, a - self.history)
                states, valid = self.sim.raw(r.t[h0:b + 1], r.u[h0:b + 1], s0, p, a - h0)
                states, valid = states[a - h0:], valid - (a - h0)
                n = b - a
                if valid <= n:   # diverged: a large, finite penalty keeps the optimiser going
                    out[k:k + 2 * n] = 1e3
                else:
                    out[k:k + n] = (states[1:, 0] - r.x[a + 1:b + 1]) / self.scale_x
                    out[k + n:k + 2 * n] = (states[1:, 2] - r.theta[a + 1:b + 1]) / self.scale_theta
                k += 2 * n
        return out

    def segment_blocks(self) -> list:
        """(start, stop) rows of each segment's residuals in the residual vector."""
        blocks, k = [], 0
        for r in self.records:
            for a, b in r.bounds:
                blocks.append((k, k + 2 * (b - a)))
                k += 2 * (b - a)
        return blocks

    def cost(self, values) -> float:
        r = self.residual(values)
        return 0.5 * float(r @ r)


def horizon_fit(model: PlantModel, datasets: list, horizon: float = 0.5, dt: float = 1e-4) -> dict:
    """fit% of x and theta when every ``horizon`` seconds the simulation restarts from the
    measured state (MATLAB's ``compare`` with a prediction horizon). On this plant the
    free-run fit is dominated by chaos and stick-slip, not by the model; this one is
    what identification minimises and what tells two models apart."""
    problem = ShootingProblem(model, datasets, [], dt=dt, segment=horizon)
    r = problem.residual(np.array([]))
    k = 0
    num = {"x": 0.0, "theta": 0.0}
    den = {"x": 0.0, "theta": 0.0}
    for rec in problem.records:
        for a, b in rec.bounds:
            n = b - a
            num["x"] += float(np.sum((r[k:k + n] * problem.scale_x) ** 2))
            num["theta"] += float(np.sum((r[k + n:k + 2 * n] * problem.scale_theta) ** 2))
            den["x"] += float(np.sum((rec.x[a + 1:b + 1] - np.mean(rec.x)) ** 2))
            den["theta"] += float(np.sum((rec.theta[a + 1:b + 1] - np.mean(rec.theta)) ** 2))
            k += 2 * n
    return {s: 100.0 * (1.0 - np.sqrt(num[s] / den[s])) if den[s] > 0 else 0.0 for s in num}
