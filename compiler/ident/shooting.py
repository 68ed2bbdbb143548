"""Short-horizon simulation error (multiple shooting) for identification.

Why not one long simulation: the pendulum is lightly damped and the swing-up makes
it chaotic, and friction makes the cart stick or slip on tiny differences, so a
20 s free run diverges from the data for reasons unrelated to the parameters and
its error surface is ragged. Instead the data are cut into segments (default
0.5 s); each segment is simulated from the *measured* state at its start (positions
from the encoders, velocities from a Savitzky-Golay derivative of them), and the
residual is the simulated-minus-measured output over every segment, each output
scaled by the larger of its spread and its resolution (see :mod:`.outputs`; held,
missing and unasked outputs are left out). Each data set is simulated under its own
experiment (held cart, removed pendulum, free), and sensor offsets of the model map
the simulated state to what the sensors read. Errors
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
from .outputs import experiment_of, plan_outputs

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
    """One data set prepared for shooting: samples, estimated velocities, segment bounds,
    its experiment and the outputs compared on it."""

    t: np.ndarray
    u: np.ndarray
    x: np.ndarray
    theta: np.ndarray
    dx: np.ndarray
    dtheta: np.ndarray
    bounds: tuple      # (start, stop) sample indices of each segment (stop inclusive)
    experiment: str = "free"
    outputs: tuple = ("x", "theta")
    source: str = "<data>"


def prepare(data, segment: float, outputs: tuple = ("x", "theta")) -> Record:
    """Cut ``data`` into segments of ``segment`` seconds and estimate the velocities."""
    t, u = np.asarray(data.t, float), np.asarray(data.u, float)
    if len(t) < 3:
        raise PendcError(f"{data.source}: too short for identification ({len(t)} samples)")
    x, th = np.asarray(data.column("x"), float), np.asarray(data.column("theta"), float)
    dx = data.dx if data.dx is not None else estimate_velocities(t, x)
    dth = data.dtheta if data.dtheta is not None else estimate_velocities(t, th)
    h = float(np.median(np.diff(t)))
    n = max(2, int(round(segment / h)))
    bounds = tuple((i, min(i + n, len(t) - 1)) for i in range(0, len(t) - 1, n) if min(i + n, len(t) - 1) - i >= 2)
    if not bounds:
        raise PendcError(f"{data.source}: too short for identification ({len(t)} samples)")
    exp = experiment_of(data)
    if exp == "cart_held":
        dx = np.zeros_like(t)
    elif exp == "pendulum_removed":
        dth = np.zeros_like(t)
    return Record(t=t, u=u, x=x, theta=th, dx=np.asarray(dx, float), dtheta=np.asarray(dth, float), bounds=bounds,
                  experiment=exp, outputs=tuple(outputs), source=getattr(data, "source", "<data>"))


def _subset(record: Record, subset: str) -> Record:
    """All segments, or every other one: fitting on even and scoring on odd segments is a
    held-out check that a flexible effect cannot pass by flexibility alone."""
    if subset == "all":
        return record
    if subset not in ("even", "odd"):
        raise ValueError(f"subset must be all, even or odd, got {subset!r}")
    keep = record.bounds[0 if subset == "even" else 1::2] or record.bounds
    return Record(**{**record.__dict__, "bounds": keep})


_COLUMN = {"x": 0, "theta": 2}


class ShootingProblem:
    """Residuals of ``model`` with the parameters ``free`` set to given values.

    ``residual(values)`` is the stacked, scaled (simulated - measured) outputs over all
    segments of all data sets; ``cost`` is half its squared norm. ``outputs`` restricts
    the compared outputs (e.g. ``("theta",)``); ``scales`` overrides the output scales
    (to score other data on the same footing). ``notes`` says what was left out and why.
    """

    def __init__(self, model: PlantModel, datasets: list, free: list, dt: float = 1e-4, method: str = "rk4",
                 segment: float = 0.5, subset: str = "all", outputs=None, scales: dict | None = None):
        self.model = model
        self.free = list(free)
        plan = plan_outputs(datasets, outputs)
        self.notes = plan.notes
        self.scales = dict(plan.scales, **(scales or {}))
        self.resolution = plan.resolution
        self.records = [_subset(prepare(d, segment, o), subset) for d, o in zip(datasets, plan.outputs)]
        self.sims = {}
        for r in self.records:
            if r.experiment not in self.sims:
                self.sims[r.experiment] = Simulator(model.for_experiment(r.experiment), dt=dt, method=method)
        self.sim = next(iter(self.sims.values()))
        unknown = [p for p in self.free if p not in self.sim.param_names]
        if unknown:
            raise PendcError(f"unknown parameter(s) to fit: {', '.join(unknown)} "
                             f"(the model has: {', '.join(self.sim.param_names)})")
        self.index = [self.sim.param_names.index(p) for p in self.free]
        self.size = sum(len(r.outputs) * (b - a) for r in self.records for a, b in r.bounds)
        h = float(np.median(np.diff(self.records[0].t)))
        self.history = int(np.ceil(HISTORY / h))   # input samples before a segment, for delays

    def start_values(self) -> np.ndarray:
        return self.sim.param_vector[self.index].copy()

    def vector(self, values) -> np.ndarray:
        p = self.sim.param_vector.copy()
        p[self.index] = values
        return p

    def errors(self, values) -> list:
        """Unscaled simulated-minus-measured outputs: per record, per segment, a dict
        output -> array (None for a diverged segment)."""
        p = self.vector(values)
        out = []
        for r in self.records:
            sim = self.sims[r.experiment]
            off = sim.offset_values(p)
            segs = []
            for a, b in r.bounds:
                s0 = sim.true_state(np.array([r.x[a], r.dx[a], r.theta[a], r.dtheta[a]]), p)
                h0 = max(0, a - self.history)
                states, valid = sim.raw(r.t[h0:b + 1], r.u[h0:b + 1], s0, p, a - h0)
                states, valid = states[a - h0:], valid - (a - h0)
                if valid <= b - a:
                    segs.append(None)
                    continue
                measured = {"x": r.x, "theta": r.theta}
                segs.append({o: states[1:, _COLUMN[o]] + off[o] - measured[o][a + 1:b + 1] for o in r.outputs})
            out.append(segs)
        return out

    def residual(self, values) -> np.ndarray:
        out = np.empty(self.size)
        k = 0
        for r, segs in zip(self.records, self.errors(values)):
            for (a, b), e in zip(r.bounds, segs):
                n = b - a
                for o in r.outputs:
                    # diverged: a large, finite penalty keeps the optimiser going
                    out[k:k + n] = 1e3 if e is None else e[o] / self.scales[o]
                    k += n
        return out

    def segment_blocks(self) -> list:
        """(start, stop) rows of each segment's residuals in the residual vector."""
        blocks, k = [], 0
        for r in self.records:
            for a, b in r.bounds:
                blocks.append((k, k + len(r.outputs) * (b - a)))
                k += len(r.outputs) * (b - a)
        return blocks

    def cost(self, values) -> float:
        r = self.residual(values)
        return 0.5 * float(r @ r)


def horizon_figures(model: PlantModel, datasets: list, horizon: float = 0.5, dt: float = 1e-4,
                    outputs=None) -> dict:
    """The k-step horizon fit, labelled: ``{"label", "horizon_s", "pooled": {output: %},
    "files": [{"file", "experiment", "fit": {output: %}}]}``. fit% = 100 (1 - |sim - data| /
    |data - mean|) with the simulation restarted from the measured state every ``horizon``
    seconds (MATLAB's ``compare`` with a prediction horizon); only compared outputs appear."""
    problem = ShootingProblem(model, datasets, [], dt=dt, segment=horizon, outputs=outputs)
    num, den, files = {}, {}, []
    for rec, segs in zip(problem.records, problem.errors(np.array([]))):
        fn, fd = {}, {}
        for (a, b), e in zip(rec.bounds, segs):
            for o in rec.outputs:
                y = {"x": rec.x, "theta": rec.theta}[o]
                err = np.full(b - a, np.inf) if e is None else e[o]
                fn[o] = fn.get(o, 0.0) + float(np.sum(err ** 2))
                fd[o] = fd.get(o, 0.0) + float(np.sum((y[a + 1:b + 1] - np.mean(y)) ** 2))
        files.append({"file": rec.source, "experiment": rec.experiment, "fit": _percent(fn, fd)})
        for o in fn:
            num[o] = num.get(o, 0.0) + fn[o]
            den[o] = den.get(o, 0.0) + fd[o]
    return {"label": f"{horizon:g} s horizon fit", "horizon_s": horizon, "pooled": _percent(num, den),
            "files": files, "notes": list(problem.notes)}


def _percent(num: dict, den: dict) -> dict:
    out = {}
    for o in num:
        if den[o] > 0 and np.isfinite(num[o]):
            out[o] = 100.0 * (1.0 - float(np.sqrt(num[o] / den[o])))
        else:
            out[o] = -np.inf if den[o] > 0 else 0.0
    return out


def horizon_fit(model: PlantModel, datasets: list, horizon: float = 0.5, dt: float = 1e-4, outputs=None) -> dict:
    """Pooled fit% of x and theta with a ``horizon`` prediction horizon (see :func:`horizon_figures`).
    On this plant the free-run fit is dominated by chaos and stick-slip, not by the model;
    this one is what identification minimises and what tells two models apart. An output
    that is not compared (held, missing, outside the experiment) is NaN."""
    pooled = horizon_figures(model, datasets, horizon, dt, outputs)["pooled"]
    return {o: pooled.get(o, float("nan")) for o in ("x", "theta")}
