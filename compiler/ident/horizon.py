"""The k-step (prediction-horizon) simulation of one measured run, for figures and plots.

Every ``horizon`` seconds the simulation restarts from the *measured* state (positions
from the data, velocities from the data's rate columns or a Savitzky-Golay
derivative of the positions, as :mod:`pendc.ident.shooting` does) and runs on the
measured input until the next restart. What it shows: the error a model makes within
half a second, which a chaotic swing or a sticking cart cannot blow up, so it is what
tells two models apart where a free run diverges. :func:`horizon_run` keeps every
segment's trajectory so the HTML report can draw them over the data.

This is a second, independent implementation of the figure that
:func:`pendc.ident.shooting.horizon_fit` computes for diagnose and fit (the tests check
that they agree); compare reports the number of ``horizon_fit`` and plots these segments.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import PendcError
from ..model.modes import fastest_eigenvalue
from ..model.plant import PlantModel
from ..sim.simulator import Simulator
from .shooting import HISTORY, integration_step, measured_motion  # noqa: F401 (measured_motion re-exported)
from .start_rates import data_start_fit, run_segment

DEFAULT_HORIZON = 0.5   # s: the segment length diagnose and fit use


@dataclass(frozen=True)
class HorizonRun:
    """Segments of a k-step simulation of one run.

    ``outputs`` maps output name to the simulated sensor reading at every sample, each
    sample predicted by the segment that ends at or runs through it (sample 0, and any
    tail too short for a segment, is NaN); ``starts`` are the sample indices where a
    segment restarts from the measured state, whose values are in ``restarts``.
    ``fit`` is the horizon fit% per output over every predicted sample, normalised by
    the spread of the whole run (MATLAB's ``compare`` with a prediction horizon).
    """

    horizon: float
    t: np.ndarray
    outputs: dict
    starts: tuple
    restarts: dict
    fit: dict

    def plot_lines(self, output: str) -> tuple[np.ndarray, np.ndarray]:
        """(t, y) of every segment from its restart to its end, NaN between segments, so one
        plotted line shows each segment on its own."""
        t, y = self.t, self.outputs[output]
        tt, yy = [], []
        for i, a in enumerate(self.starts):
            b = self.starts[i + 1] if i + 1 < len(self.starts) else len(t) - 1
            tt += [t[a:b + 1], [np.nan]]
            yy += [[self.restarts[output][i]], y[a + 1:b + 1], [np.nan]]
        return np.concatenate(tt), np.concatenate(yy)


def horizon_run(model, data, outputs=None, horizon: float = DEFAULT_HORIZON, dt: float = 1e-4,
                method: str = "rk4", params: dict | None = None, motion: tuple | None = None) -> HorizonRun:
    """Simulate ``data`` with restarts from the measured state every ``horizon`` s.

    ``model`` is a PlantModel (already set to the data's experiment); ``outputs`` the
    positions to compare (default: all of the plant's). Raises PendcError when a segment
    diverges (a non-finite state).
    """
    if not horizon > 0:
        raise PendcError(f"the horizon must be positive, got {horizon:g} s")
    t = np.asarray(data.t, dtype=np.float64)
    u = np.asarray(data.u, dtype=np.float64)
    if len(t) < 3:
        raise PendcError(f"{data.source}: too short for a horizon fit ({len(t)} samples)")
    measured, velocity = motion if motion is not None else measured_motion(data, model)
    sim = Simulator(model, dt=integration_step(dt, t, model), method=method)
    positions = sim.signals.positions
    outputs = positions if outputs is None else tuple(outputs)
    p = sim.vector(params)
    offset = sim.offset_values(p)
    h = float(np.median(np.diff(t)))
    step = max(2, int(round(horizon / h)))
    history = int(np.ceil(HISTORY / h))
    predicted = {k: np.full(len(t), np.nan) for k in positions}
    # as shooting does: a tail shorter than two samples is no segment
    starts = tuple(a for a in range(0, len(t) - 1, step) if min(a + step, len(t) - 1) - a >= 2)
    fit = data_start_fit(sim, data, model, measured, outputs)
    limits = sim.limits_reached(measured)
    for a in starts:
        b = min(a + step, len(t) - 1)
        s0 = sim.true_state(sim.initial_vector(measured, velocity, a), p)
        h0 = max(0, a - history)
        _, states, valid = run_segment(sim, p, t, u, s0, a, b, h0, fit, offset)
        if valid < b + 1 - h0:
            raise PendcError(f"{data.source}: the simulation diverged in the horizon segment at t = {t[a]:.6g} s")
        for k in positions:
            predicted[k][a + 1:b + 1] = sim.reading(k, states[a - h0 + 1:, sim.signals.index(k)] + offset[k], limits)
    fit = {k: _segment_fit(measured[k], predicted[k]) for k in outputs}
    return HorizonRun(horizon=float(horizon), t=t, outputs={k: predicted[k] for k in outputs}, starts=starts,
                      restarts={k: measured[k][list(starts)] for k in outputs}, fit=fit)


def _segment_fit(y, yhat) -> float:
    """fit% over the predicted samples (NaN marks the unpredicted ones); NaN for a constant output."""
    y, yhat = np.asarray(y, dtype=np.float64), np.asarray(yhat, dtype=np.float64)
    keep = np.isfinite(yhat)
    spread = float(np.linalg.norm(y[keep] - np.mean(y)))
    if spread == 0.0:
        return float("nan")
    return 100.0 * (1.0 - float(np.linalg.norm(y[keep] - yhat[keep])) / spread)


VISIBLE_STEPS = 4.0   # sensor steps a typical segment must move for the horizon to see the dynamics
MIN_SEGMENTS = 8      # segments the records must hold: diagnose fits on four and scores on four
MODE_SPANS = 10.0     # time constants (1/|eigenvalue|) of the plant's fastest mode a segment must span


def horizon_for(datasets: list, signals, model=None) -> tuple[float, str]:
    """The horizon diagnose, fit and compare use unless told, with the reason when it is not
    :data:`DEFAULT_HORIZON`.

    Slow plants: doubled while the measured positions move less than :data:`VISIBLE_STEPS` sensor
    steps in a typical (median) segment and a record still holds eight segments. A pendulum moves
    hundreds of encoder counts in half a second; a heater's sink (a 93 s time constant) less than
    one 0.32 K converter code, so every candidate scored the same on 0.5 s and diagnose called the
    error noise.

    Fast plants on short records: where the records hold fewer than :data:`MIN_SEGMENTS` segments,
    shortened along 0.2, 0.1, 0.05, 0.02, ... s for as long as a segment still spans
    :data:`MODE_SPANS` time constants of ``model``'s fastest mode (the restart's start state then
    no longer decides the prediction: the model's dynamics do) and the data still move
    :data:`VISIBLE_STEPS` sensor steps in it; to the first that holds eight segments, else the
    shortest that qualified. A 0.3 s record of a buck converter (3.4 kHz, 47 us) is one 0.5 s
    segment, which no parameter can be fitted on, and fifteen of 0.02 s. The shipped mechanical
    plants' ten time constants are 0.2 s or more (a ball on a beam's: 0.21 s), so their records
    keep the half second whatever their length."""
    horizon = DEFAULT_HORIZON
    longest = max((float(d.t[-1] - d.t[0]) for d in datasets if len(d.t) > 1), default=0.0)
    moved = _median_movement(datasets, signals, horizon)
    while moved < VISIBLE_STEPS and 2 * horizon * 8 <= longest:
        horizon *= 2
        moved = _median_movement(datasets, signals, horizon)
    if horizon != DEFAULT_HORIZON:
        return horizon, (f"the horizon is {horizon:g} s, not {DEFAULT_HORIZON:g} s: in {DEFAULT_HORIZON:g} s these "
                         f"data move less than {VISIBLE_STEPS:g} sensor steps, too little to tell models apart "
                         f"(--horizon sets it)")
    have = segment_count(datasets, horizon)
    if model is None or not datasets or have >= MIN_SEGMENTS:
        return horizon, ""
    shorter, count = shorter_horizon(datasets, signals, model, horizon, MIN_SEGMENTS)
    if shorter is None or count <= have:
        return horizon, ""
    return shorter, (f"the horizon is {shorter:g} s, not {DEFAULT_HORIZON:g} s: these data hold {have} segment(s) "
                     f"of {DEFAULT_HORIZON:g} s, too few to fit a parameter on; {count} of {shorter:g} s "
                     f"still span {MODE_SPANS:g} time constants of the plant's fastest mode ({_mode_hz(model):.4g} Hz) "
                     f"and see the data move (--horizon sets it)")


def chosen_horizon(given, datasets: list, model, label: str = "horizon") -> tuple[float, str]:
    """``(horizon, why)``: ``given`` checked (``label`` names it in the error), or when it is None
    the data's own (:func:`horizon_for`; ``why`` says why it is not the default, else empty)."""
    import math

    from ..sim.signals import signals_of

    if given is None:
        return horizon_for(list(datasets), signals_of(model), model)
    if not (math.isfinite(given) and given > 0):
        raise PendcError(f"{label} must be a positive number of seconds, got {given:g}")
    return float(given), ""


def shorter_horizon(datasets: list, signals, model, horizon: float, need: int) -> tuple:
    """``(h, segments)``: the longest horizon below ``horizon`` (along 0.2, 0.1, 0.05, ... s) whose
    segments number ``need`` or more across ``datasets``, else the shortest qualifying one; each
    candidate must span :data:`MODE_SPANS` time constants of ``model``'s fastest mode and see the
    data move :data:`VISIBLE_STEPS` sensor steps. ``(None, 0)`` when none qualifies (a slow
    plant, data that hardly move, a model without dynamics at its start state)."""
    rate = _mode_rate(model)
    if rate == 0.0:
        return None, 0
    best, have = (None, 0), segment_count(datasets, horizon)
    for h in _one_two_five_below(horizon):
        if h * rate < MODE_SPANS:
            break
        count = segment_count(datasets, h)
        if count <= have:     # still longer than the records: no segment to measure movement in
            continue
        if _median_movement(datasets, signals, h) < VISIBLE_STEPS:
            break
        best, have = (h, count), count
        if count >= need:
            break
    return best


def segment_count(datasets: list, horizon: float) -> int:
    """How many segments of ``horizon`` s the shooting fit cuts ``datasets`` into
    (:func:`pendc.ident.shooting.prepare`'s rule, without its velocity estimates)."""
    count = 0
    for d in datasets:
        t = np.asarray(d.t, dtype=np.float64)
        if len(t) < 3:
            continue
        n = max(2, int(round(horizon / float(np.median(np.diff(t))))))
        count += sum(1 for a in range(0, len(t) - 1, n) if min(a + n, len(t) - 1) - a >= 2)
    return count


def _one_two_five_below(horizon: float) -> list:
    """0.2, 0.1, 0.05, ... s below ``horizon``, down to a microsecond: values a command line shows
    as typed (halving 0.5 s would suggest --horizon 0.03125)."""
    values = [float(f"{m}e{e}") for e in range(1, -7, -1) for m in (5, 2, 1)]
    return [v for v in values if v < horizon * (1 - 1e-9)]


def _mode_rate(model) -> float:
    """|eigenvalue| (1/s) of ``model``'s fastest mode at its start state; 0 when unknown."""
    # an interface alone has no equations to linearise
    return float(abs(fastest_eigenvalue(model))) if isinstance(model, PlantModel) else 0.0


def _mode_hz(model) -> float:
    return _mode_rate(model) / (2 * np.pi)


def _median_movement(datasets: list, signals, horizon: float) -> float:
    """The largest, over the measured positions, median of (max - min) / sensor step per segment."""
    best = 0.0
    for d in datasets:
        if len(d.t) < 3:
            continue
        per = max(1, int(round(horizon / float(np.median(np.diff(d.t))))))
        for name in signals.positions:
            step = d.resolution.get(name) or signals.resolution(name)
            if name not in d.columns or name in d.missing or not step:
                continue
            y = d.columns[name]
            n = len(y) // per
            if n == 0:
                continue
            blocks = y[:n * per].reshape(n, per)
            best = max(best, float(np.median(blocks.max(axis=1) - blocks.min(axis=1))) / float(step))
    return best
