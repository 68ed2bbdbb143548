"""Short-horizon simulation error (multiple shooting) for identification.

Why not one long simulation: the pendulum is lightly damped and the swing-up makes
it chaotic, and friction makes the cart stick or slip on tiny differences, so a
20 s free run diverges from the data for reasons unrelated to the parameters and
its error surface is ragged. Instead the data are cut into segments (default
0.5 s); each segment is simulated from the *measured* state at its start (positions
from the encoders, velocities from a Savitzky-Golay derivative of them, or, where that
derivative is too coarse, from the segment's own samples: :mod:`.start_rates`), and the
residual is the simulated-minus-measured output over every segment, each output
scaled by the larger of its spread and its resolution (see :mod:`.outputs`; held,
missing and unasked outputs are left out). Each data set is simulated under its own
experiment (the coordinates it holds and the bodies it removes, as the plant file declares), and sensor offsets of the model map
the simulated state to what the sensors read. Errors
cannot accumulate past a segment, yet each segment is long enough (hundreds of
samples) for friction, damping, lags and delays to shape it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import PendcError
from ..model.plant import PlantModel
from ..sim.signals import signals_of
from ..sim.simulator import Simulator
from ..sim.experiment_axes import irrelevant_axes
from .outputs import experiment_of, plan_outputs, signals_for
from .smoothing import SAVGOL_WINDOW, estimate_velocities  # noqa: F401 (re-exported: the one derivative filter)
from .start_rates import estimated_rates, run_segment, start_fit

HISTORY = 0.1          # s of input history handed to each segment (longest delay it can see)
STEPS_PER_SAMPLE = 10  # integration steps per data sample, at least
MODE_STEPS = 1000      # integration steps per time constant of the plant's fastest mode, at least
MAX_STEP = 1e-2        # s: the simulator's largest step


def integration_step(dt: float, t, model: PlantModel | None = None) -> float:
    """The step identification integrates at: ``dt`` (0.1 ms by default), or a tenth of the
    data's sample period when that is finer. Data fast enough to show a mode are integrated
    finely enough to follow it: RK4 at 0.1 ms lags a 1.2 kHz resonance by 8 % a period (an RLC
    ladder sampled at 10 kHz scored 87 % against its own exact run; at 10 us, 100 %). A slow
    ``model`` on slow data is integrated coarser, up to a tenth of a sample, a thousandth of its
    fastest mode's time constant and 10 ms: a heater sampled at 1 Hz (a 93 s time constant) took
    ten million steps of 0.1 ms for 12 minutes."""
    t = np.asarray(t, dtype=np.float64)
    if len(t) < 2:
        return float(dt)
    sample = float(np.median(np.diff(t))) / STEPS_PER_SAMPLE
    step = min(dt, sample)
    # a coarser step only where the data are slower than dt by more than rounding (1 kHz data
    # give sample = 1.0000000000000002e-4 against dt = 1e-4: the eigenvalue was asked for nothing)
    if model is not None and sample > dt * (1.0 + 1e-9):
        from ..model.modes import fastest_eigenvalue

        rate = abs(fastest_eigenvalue(model))
        slow = MAX_STEP if rate == 0 else min(MAX_STEP, 1.0 / (MODE_STEPS * rate))
        step = max(step, min(sample, slow))
    return float(step)


@dataclass(frozen=True)
class Record:
    """One data set prepared for shooting: samples, per position its measured values
    (``positions``) and velocities (``rates``, measured or estimated), segment bounds, its
    experiment and the outputs compared on it."""

    t: np.ndarray
    u: np.ndarray
    positions: dict
    rates: dict
    bounds: tuple      # (start, stop) sample indices of each segment (stop inclusive)
    experiment: str = "free"
    outputs: tuple = ()
    source: str = "<data>"
    rate_names: tuple = ()   # (position, name of its rate state) pairs
    estimated: tuple = ()    # positions whose rates come from the derivative filter

    def __getattr__(self, name: str):
        """A position or its rate by the state's name (``rec.<position>``, ``rec.d<position>``)."""
        if name.startswith("_") or name in ("positions", "rates", "rate_names"):
            raise AttributeError(name)
        if name in self.positions:
            return self.positions[name]
        for position, rate in self.rate_names:
            if rate == name:
                return self.rates[position]
        raise AttributeError(f"'Record' has no attribute or signal '{name}'")


def measured_motion(data, model=None) -> tuple[dict, dict]:
    """``({position: values}, {position: velocities})`` of a run, for every position of its
    plant: a position the file lacks is zeros (a held axis); velocities come from the data's
    rate columns (``d<position>``), else the Savitzky-Golay derivative of the position,
    and a position ``model``'s experiment holds has zero velocity. So every simulation that
    starts from the data (free run, horizon segments, diagnose, fit) starts from the same state."""
    sig = signals_for(data)
    t = np.asarray(data.t, dtype=np.float64)
    held = irrelevant_axes(model, experiment_of(data, model)) if model is not None else set()
    measured, velocity = {}, {}
    for pos in sig.positions:
        column = data.columns.get(pos)
        measured[pos] = np.zeros(len(t)) if column is None else np.asarray(data.column(pos), dtype=np.float64)
        rate = sig.rate(pos)
        given = data.columns.get(rate) if rate is not None else None
        if pos in held:
            velocity[pos] = np.zeros(len(t))
        elif given is not None:
            velocity[pos] = np.asarray(given, dtype=np.float64)
        else:
            velocity[pos] = estimate_velocities(t, measured[pos])
    return measured, velocity


def prepare(data, segment: float, outputs: tuple = None, model=None) -> Record:
    """Cut ``data`` into segments of ``segment`` seconds and estimate the velocities
    (``model``: which positions its experiment holds; default the default model)."""
    from ..sim.experiment_axes import _model

    t, u = np.asarray(data.t, float), np.asarray(data.u, float)
    if len(t) < 3:
        raise PendcError(f"{data.source}: too short for identification ({len(t)} samples)")
    sig = signals_for(data)
    for pos in sig.positions:
        data.column(pos)            # a position the file must have: a one-line error if it has not
    plant = _model(model)
    positions, rates = measured_motion(data, plant)
    h = float(np.median(np.diff(t)))
    n = max(2, int(round(segment / h)))
    bounds = tuple((i, min(i + n, len(t) - 1)) for i in range(0, len(t) - 1, n) if min(i + n, len(t) - 1) - i >= 2)
    if not bounds:
        raise PendcError(f"{data.source}: too short for identification ({len(t)} samples)")
    return Record(t=t, u=u, positions=positions, rates=rates, bounds=bounds, experiment=experiment_of(data, plant),
                  outputs=tuple(sig.positions if outputs is None else outputs),
                  source=getattr(data, "source", "<data>"), rate_names=tuple((p, sig.rate(p)) for p in sig.positions),
                  estimated=estimated_rates(data, plant))


def _subset(record: Record, subset: str) -> Record:
    """All segments, or every other one: fitting on even and scoring on odd segments is a
    held-out check that a flexible effect cannot pass by flexibility alone."""
    if subset == "all":
        return record
    if subset not in ("even", "odd"):
        raise ValueError(f"subset must be all, even or odd, got {subset!r}")
    keep = record.bounds[0 if subset == "even" else 1::2] or record.bounds
    return replace(record, bounds=keep)


class ShootingProblem:
    """Residuals of ``model`` with the parameters ``free`` set to given values.

    ``residual(values)`` is the stacked, scaled (simulated - measured) outputs over all
    segments of all data sets; ``cost`` is half its squared norm. ``outputs`` restricts
    the compared outputs (a tuple of position names); ``scales`` overrides the output scales
    (to score other data on the same footing). ``notes`` says what was left out and why.
    """

    def __init__(self, model: PlantModel, datasets: list, free: list, dt: float = 1e-4, method: str = "rk4",
                 segment: float = 0.5, subset: str = "all", outputs=None, scales: dict | None = None):
        self.model = model
        self.dt = dt
        self.free = list(free)
        plan = plan_outputs(datasets, outputs, model)
        self.notes = plan.notes
        self.scales = dict(plan.scales, **(scales or {}))
        self.resolution = plan.resolution
        self.records = [_subset(prepare(d, segment, o, model), subset) for d, o in zip(datasets, plan.outputs)]
        self.sims = {}          # (experiment, step) -> its simulator: one kernel each, shared by the records
        steps = {id(r): integration_step(dt, r.t, model) for r in self.records}   # each record's, once
        for r in self.records:
            key = (r.experiment, steps[id(r)])
            if key not in self.sims:
                self.sims[key] = Simulator(model.for_experiment(r.experiment), method=method, dt=key[1])
        self.sim = next(iter(self.sims.values()))
        unknown = [p for p in self.free if p not in self.sim.param_names]
        if unknown:
            raise PendcError(f"unknown parameter(s) to fit: {', '.join(unknown)} "
                             f"(the model has: {', '.join(self.sim.param_names)})")
        self.index = [self.sim.param_names.index(p) for p in self.free]
        self.size = sum(len(r.outputs) * (b - a) for r in self.records for a, b in r.bounds)
        h = float(np.median(np.diff(self.records[0].t)))
        self.history = int(np.ceil(HISTORY / h))   # input samples before a segment, for delays
        # found once: the step's median over the record would otherwise be taken at every evaluation
        self._sim_of = {id(r): self.sims[(r.experiment, steps[id(r)])] for r in self.records}
        self.start_fits = [start_fit(self.sim_for(r), r.t, r.positions, r.estimated, r.outputs, self.resolution,
                                     self.scales) for r in self.records]
        self.limits = [self.sim_for(r).limits_reached(r.positions) for r in self.records]

    def sim_for(self, record: Record) -> Simulator:
        """The simulator of ``record``: its experiment's equations at its integration step."""
        return self._sim_of[id(record)]

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
        for r, fit, limits in zip(self.records, self.start_fits, self.limits):
            sim = self.sim_for(r)
            off = sim.offset_values(p)
            segs = []
            for a, b in r.bounds:
                s0 = sim.true_state(sim.initial_vector(r.positions, r.rates, a), p)
                h0 = max(0, a - self.history)
                _, states, valid = run_segment(sim, p, r.t, r.u, s0, a, b, h0, fit, off)
                states, valid = states[a - h0:], valid - (a - h0)
                if valid <= b - a:
                    segs.append(None)
                    continue
                segs.append({o: sim.reading(o, states[1:, sim.signals.index(o)] + off[o], limits)
                             - r.positions[o][a + 1:b + 1] for o in r.outputs})
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
                y = rec.positions[o]
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
    """Pooled fit% of each position with a ``horizon`` prediction horizon (see :func:`horizon_figures`).
    On this plant the free-run fit is dominated by chaos and stick-slip, not by the model;
    this one is what identification minimises and what tells two models apart. An output
    that is not compared (held, missing, outside the experiment) is NaN."""
    pooled = horizon_figures(model, datasets, horizon, dt, outputs)["pooled"]
    return {o: pooled.get(o, float("nan")) for o in signals_of(model).positions}
