"""``pendc compare``: how well does a model reproduce one measured run, where and why not.

The model is simulated in free run (no resets to the data) from the data's initial
state (velocities as diagnose and fit estimate them: the data's rate columns, else a
31 ms Savitzky-Golay derivative) on the measured input (zero-order hold), and in 0.5 s segments that restart from
the measured state (:mod:`pendc.ident.horizon`). Every figure says which it is:

* **free-run fit** and **horizon fit** per output, as MATLAB's ``compare``:
  ``100 (1 - ||y - yhat|| / ||y - mean y||)``; for the last periodic position (the swinging
  angle) also the **wrapped** free-run fit, whose error is the angle difference folded into
  (-pi, pi], because an unwrapped angle counts every extra turn of the simulated body as
  2 pi of error;
* the **headline**: which of the two fits means something on these data
  (:mod:`pendc.ident.headline`), and why;
* **worst windows**: the non-overlapping 0.5 s windows with the largest RMS residual;
* **regimes**: the share of the squared residual that falls in each operating regime
  (the first position's body standing or moving either way, small or large swing, weak or
  strong drive, centre or ends of a translation's travel, input saturated or not), next to the share of time
  spent there, so a concentration of the error shows at a glance;
* **whiteness**: residual autocorrelation and residual-input cross-correlation with
  99 % bands, as MATLAB's ``resid`` (:mod:`pendc.ident.whiteness`).

Windows and regimes examine the residual of the headline's simulation: a free run that
diverged has its error everywhere after the divergence, which says nothing. Whiteness
always tests the free-run residual (angles wrapped): a horizon residual restarts from zero
every segment, so it is correlated by construction.
The regimes are classified on the *measured* motion (the first position's rate from the
data's rate column, else a Savitzky-Golay derivative of the position): a wrong model must not
decide which regime the real rig was in. :func:`compare_models` puts several models
side by side on the same runs. The reports (text, HTML) live in
:mod:`pendc.ident.report_text` and :mod:`pendc.ident.report_html`, which import this module.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import PendcError
from ..model.plant import PlantModel
from ..sim.measurements import Measurement
from ..sim.signals import signals_of
from ..sim.simulator import SimResult, Simulator
from . import headline as hl
from .horizon import DEFAULT_HORIZON, HorizonRun, horizon_run, integration_step, measured_motion
from .outputs import experiment_of, plan_outputs
from .smoothing import SAVGOL_WINDOW, estimate_velocities
from .start_rates import data_start_fit, free_run_start
from .regimes import CENTRE_NAME, centre_and_name, input_centre, regime_partitions, regimes, swing_angle, wrap_angle  # noqa: F401
from .whiteness import (LAGS, MIN_WHITENESS_SAMPLES, WHITENESS_DT, Z99, allowed_outside,  # noqa: F401 (re-exported)
                        autocorrelation, cross_correlation, decimate, whiteness)

WORST_WINDOW = 0.5           # s, length of a worst-error window
TOP_WINDOWS = 5              # per output
TURN = 2 * math.pi


@dataclass(frozen=True)
class Comparison:
    """Everything :func:`compare` computes. ``to_json()`` is the CLI's ``--json`` output.

    ``fit`` is the **free-run** fit% keyed by output; ``fit_horizon`` (a property) the
    horizon fit% of ``horizon_run``; ``fit_wrapped`` the free-run fit of :attr:`angle` with
    the angle error wrapped to (-pi, pi]; ``turns`` the largest number of whole turns by
    which simulated and measured :attr:`angle` differ (first reached at ``turn_time`` s).
    ``headline`` says which fit leads and why. ``residual`` (measured minus simulated, m
    and rad) is the residual that ``windows`` and ``regimes`` examine: the free run's or
    the horizon simulation's, as ``residual_of`` says; ``free_residual`` is always the free
    run's, and ``whiteness`` tests it (angles wrapped to (-pi, pi]). ``measured`` holds the data's
    positions and the first position's rate used to classify regimes (``motion_source`` says
    where it came from). ``outputs`` are the positions compared (a run that holds a coordinate
    compares the others only); ``notes`` say which were left out and why. ``v_off`` is the
    input's centre (:func:`~pendc.ident.regimes.input_centre`), ``centre_name`` what holds it
    (the drive's offset parameter, else :data:`~pendc.ident.regimes.CENTRE_NAME`): the JSON
    key of its value.
    """

    fit: dict
    simulated: SimResult
    residual: dict
    windows: list
    regimes: list
    whiteness: dict
    measured: dict = field(default_factory=dict)
    model: PlantModel | None = None
    data_source: str = ""
    dt: float = 1e-4
    method: str = "rk4"
    v_off: float = 0.0              # the input's centre (where the drive pushes nothing at rest)
    centre_name: str = CENTRE_NAME  # the parameter that holds it, else CENTRE_NAME
    motion_source: str = ""
    outputs: tuple = ()
    experiment: str = "free"
    free_residual: dict = field(default_factory=dict)
    fit_wrapped: float = float("nan")
    turns: int = 0
    turn_time: float | None = None
    horizon_run: HorizonRun | None = None
    headline: hl.Headline | None = None
    residual_of: str = "free run"
    notes: tuple = ()
    band: object = None             # a PredictionBand (pendc.ident.prediction_band) when asked for

    @property
    def fit_horizon(self) -> dict:
        """Horizon fit% per output (empty without a horizon run)."""
        return dict(self.horizon_run.fit) if self.horizon_run is not None else {}

    @property
    def horizon(self) -> float:
        """The horizon of ``fit_horizon`` in seconds."""
        return self.horizon_run.horizon if self.horizon_run is not None else DEFAULT_HORIZON

    def headline_fit(self) -> dict:
        """The fit% per output of the headline's metric."""
        return self.fit_horizon if self.headline is not None and self.headline.metric == hl.HORIZON else self.fit

    def rms(self) -> dict:
        """RMS of ``residual`` per output (m, rad)."""
        return {k: float(np.sqrt(np.mean(r * r))) for k, r in self.residual.items()}

    @property
    def angle(self) -> str | None:
        """The plant's periodic position whose wrapped fit and turns are reported (e.g. a
        pendulum's angle), or None; its figures are NaN and 0 when it is not compared."""
        return angle_of(self.model)

    def rms_free_run(self) -> dict:
        """RMS free-run residual per output (m, rad); a periodic output also wrapped
        (``<name>_wrapped``)."""
        out = {k: float(np.sqrt(np.mean(r * r))) for k, r in self.free_residual.items()}
        if self.angle is not None and self.angle in self.free_residual:
            w = wrap_difference(self.free_residual[self.angle])
            out[f"{self.angle}_wrapped"] = float(np.sqrt(np.mean(w * w)))
        return out

    def to_json(self) -> dict:
        """Plain JSON types only; an undefined number (e.g. fit% of a constant output) is null.
        Every fit carries its ``label``."""
        m = self.model
        return _clean({
            "model": model_name(m), "effects": list(m.effects) if m is not None else [], "data": self.data_source,
            "experiment": self.experiment, "outputs": list(self.outputs), "dt": self.dt, "method": self.method,
            "samples": len(self.simulated.t),
            "headline": {**self.headline.to_json(), "fit": self.headline_fit()} if self.headline else None,
            "fit": {"label": "free-run fit (%)", **self.fit},
            **({f"fit_{self.angle}_wrapped": {
                "label": f"free-run fit of {self.angle}, angle error wrapped to (-pi, pi] (%)",
                self.angle: self.fit_wrapped}} if self.angle else {}),
            "fit_horizon": {"label": f"{hl.horizon_label(self.horizon)} (%)", "horizon_s": self.horizon,
                            **self.fit_horizon},
            "turns": {"max": self.turns, "first_t": self.turn_time,
                      "label": f"largest whole number of turns between simulated and measured {self.angle} (free run)"},
            "rms_free_run": self.rms_free_run(), "residual_of": self.residual_of, "rms": self.rms(),
            "windows": self.windows, "regimes": self.regimes, "whiteness": self.whiteness,
            self.centre_name: self.v_off,
            f"{self.motion_rate}_source": self.motion_source, "notes": list(self.notes),
            **({"prediction_band": self.band.to_json()} if self.band is not None else {})})

    @property
    def motion_rate(self) -> str:
        """The rate the regimes classify the motion by (the first position's)."""
        sig = signals_of(self.model)
        return sig.rate(sig.positions[0]) or sig.positions[0]


def angle_of(model) -> str | None:
    """The periodic position of ``model``'s plant whose swing is reported (:func:`.regimes.swing_angle`:
    e.g. a pendulum's angle), or None."""
    return swing_angle(model) if model is not None else None


def model_name(model) -> str:
    """How a report names a model: its file, or ``(in memory)``."""
    if model is None:
        return "(none)"
    return model.source or "(in memory)"


def _clean(obj):
    """numpy scalars/arrays to Python numbers and lists, NaN/inf to None (strict JSON)."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [_clean(v) for v in obj]
    if isinstance(obj, (bool, np.bool_, int, np.integer)):
        return obj.item() if isinstance(obj, np.generic) else obj
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    return obj


def compare(model: PlantModel, data: Measurement, dt: float = 1e-4, method: str = "rk4",
            horizon: float = DEFAULT_HORIZON, outputs=None) -> Comparison:
    """Simulate ``model`` on ``data``'s input, in free run and with a ``horizon`` s restart,
    and compare the outputs (see the module docstring).

    The model is set to the experiment the data declare (a held coordinate does not move), and
    the outputs compared are chosen as diagnose and fit choose them
    (:func:`pendc.ident.outputs.plan_outputs`: held, constant or missing ones are left out,
    ``notes`` says which; ``outputs``, a tuple of position names, restricts them further).
    Why 0.1 ms RK4 and not the 1 us Euler reference: identification calls this many
    times (every candidate, every data set), and 0.1 ms RK4 is ~40x faster. Measured
    on the 20 s chirp (``stimuli.chirp()``) with the default model, it stays within
    0.8 counts of the pendulum angle (0.26 mrad) of the 1 us Euler run; the cart's
    position differs by up to 9 counts (22 um, RMS 3.8 counts, against 44000 counts of
    travel), and fit% by less than 0.05 points. The position error is first order, not
    RK4's: an exact-zero sticking test makes friction jump at every velocity reversal, and
    a fixed step lands on the jump at a random phase (1e-5 RK4 still differs by 0.5 counts). Pass
    ``dt=1e-6, method="euler"`` to compare with the hardware's own integrator.
    """
    model, plan, outputs, t, u, y, sim, x0, run, head = _free_run(model, data, dt, method, outputs, horizon)
    sig = sim.signals
    limits = sim.limits_reached(y)
    simulated = {k: sim.reading(k, run.measured(k), limits) for k in outputs}
    free_residual = {k: y[k] - simulated[k] for k in outputs}
    hrun = horizon_run(model, data, outputs=outputs, horizon=horizon, dt=dt, method=method)
    if head.metric == hl.HORIZON:
        residual = {k: np.nan_to_num(y[k] - hrun.outputs[k], nan=0.0) for k in outputs}   # restarts are exact
        residual_of = hl.horizon_label(horizon).replace(" fit", " simulation")
    else:
        residual, residual_of = free_residual, "free run"
    periodic = [k for k in outputs if sig.period(k) is not None]
    angle = angle_of(model)                            # the last periodic position
    turns, turn_time, wrapped_fit = 0, None, float("nan")
    if angle in outputs:
        turns, turn_time = turns_apart(t, free_residual[angle])
        wrapped_fit = fit_percent(y[angle], y[angle] - wrap_difference(free_residual[angle]))
    # the whiteness tests need an uninterrupted residual: a horizon residual restarts at zero every
    # segment and is correlated by construction, so they always see the free run (whole turns wrapped)
    white_input = {k: (wrap_difference(r) if k in periodic else r) for k, r in free_residual.items()}
    # the regimes: the motion of the first position, where along its travel it is (a
    # translation), the swing of the last periodic one, the input
    lead = sig.positions[0]
    lead_rate = sig.rate(lead)
    lead_measured = y[lead] if lead in y else np.zeros_like(t)
    if lead_rate is not None and data.columns.get(lead_rate) is not None:
        lead_velocity, motion_source = np.asarray(data.columns[lead_rate], dtype=np.float64), f"measured {lead_rate} column"
    elif lead in y:
        lead_velocity = estimate_velocities(t, lead_measured)
        motion_source = f"Savitzky-Golay derivative of measured {lead} ({SAVGOL_WINDOW * 1e3:.0f} ms, cubic)"
    else:
        lead_velocity, motion_source = np.zeros_like(t), f"{sig.body_of(lead)} held (not measured)"
    missing = set(getattr(data, "missing", ()) or ())
    # partitions by an axis the run did not have (a held coordinate, an input the file lacked) say nothing
    motion = {k: v for k, v in y.items()}
    if lead in outputs and lead_rate is not None:
        motion[lead_rate] = lead_velocity
    v_off, centre_name = centre_and_name(model)
    partitions = regime_partitions(model, motion, u, v_off, centre_name=centre_name,
                                   skip=("drive", "input saturation") if sig.input in missing else ())
    return Comparison(
        fit={k: fit_percent(y[k], simulated[k]) for k in outputs},
        simulated=SimResult(t=run.t, u=run.u, states={**run.states, **simulated}, signals=sig),
        residual=residual, windows=[w for k in outputs for w in worst_windows(t, residual[k], k)],
        regimes=regimes(residual, partitions),
        whiteness=whiteness(t, white_input, u, input_missing=sig.input in missing),
        measured={**y, **({lead_rate: lead_velocity} if lead_rate else {})},
        model=model, data_source=data.source, dt=sim.dt, method=method, v_off=v_off, centre_name=centre_name,
        motion_source=motion_source,
        outputs=outputs, experiment=model.experiment, free_residual=free_residual, fit_wrapped=wrapped_fit,
        turns=turns, turn_time=turn_time, horizon_run=hrun, headline=head, residual_of=residual_of,
        notes=tuple(plan.notes))


def headline_of(model: PlantModel, data: Measurement, dt: float = 1e-4, method: str = "rk4", outputs=None,
                horizon: float = DEFAULT_HORIZON) -> hl.Headline:
    """The headline :func:`compare` would give ``model`` on ``data`` (which fit means something
    there, and why), without the rest of the comparison: three free runs."""
    return _free_run(model, data, dt, method, outputs, horizon)[-1]


def _free_run(model, data, dt, method, outputs, horizon) -> tuple:
    """What compare and its headline share: the model under the data's experiment, the output
    plan, the data, the simulator, the initial state, the free run and the headline."""
    experiment = experiment_of(data, model)
    if experiment != model.experiment:
        model = model.for_experiment(experiment)
    if len(data.t) < 3:
        raise PendcError(f"{data.source}: too short to compare ({len(data.t)} samples; at least 3 needed)")
    # the same choice as diagnose and fit: held, constant, missing or unasked outputs are left out
    plan = plan_outputs([data], requested=outputs, model=model)
    outputs = plan.outputs[0]
    t, u = np.asarray(data.t, dtype=np.float64), np.asarray(data.u, dtype=np.float64)
    y = {k: np.asarray(data.column(k), dtype=np.float64) for k in outputs}
    sim = Simulator(model, dt=integration_step(dt, t, model), method=method)
    position, velocity = measured_motion(data, model)
    x0 = sim.true_state(sim.initial_vector(position, velocity, 0))
    # a coarse sensor's rate at the first sample: from the first samples, with the model
    x0 = free_run_start(sim, t, u, x0, data_start_fit(sim, data, model, position, outputs))
    run = sim(t, u, x0=tuple(x0))

    limits = sim.limits_reached(y)

    def free_run(start) -> dict:
        again = run if np.array_equal(start, x0) else sim(t, u, x0=tuple(start))
        return {k: sim.reading(k, again.measured(k), limits) for k in outputs}

    try:
        twin = hl.twin_fit(free_run, x0, y, sim.signals)
    except PendcError:                 # a twin run that diverges: the free run is as sensitive as can be
        twin = {k: -math.inf for k in outputs}
    head = hl.choose(twin, horizon, controller=(data.meta or {}).get("controller"), signals=sim.signals)
    return model, plan, outputs, t, u, y, sim, x0, run, head


def wrap_difference(angle):
    """An angle difference folded into (-pi, pi]: whole turns do not count."""
    return -((-np.asarray(angle, dtype=np.float64) + np.pi) % TURN - np.pi)


def turns_apart(t, angle_error) -> tuple[int, float | None]:
    """The largest whole number of turns in ``|angle_error|`` and when one turn is first reached."""
    e = np.abs(np.asarray(angle_error, dtype=np.float64))
    turns = int(np.floor(e.max() / TURN)) if len(e) else 0
    return turns, (float(t[int(np.argmax(e >= TURN))]) if turns else None)


def fit_percent(y, yhat) -> float:
    """MATLAB's normalized-RMSE fit: 100 (1 - ||y - yhat|| / ||y - mean(y)||).

    100 is a perfect match, 0 is no better than the data's mean, and it is unbounded
    below. NaN when the measured output is constant (the ratio is undefined).
    """
    y, yhat = np.asarray(y, dtype=np.float64), np.asarray(yhat, dtype=np.float64)
    spread = float(np.linalg.norm(y - y.mean()))
    return 100.0 * (1.0 - float(np.linalg.norm(y - yhat)) / spread) if spread > 0 else float("nan")


def worst_windows(t, residual, output: str, width: float = WORST_WINDOW, count: int = TOP_WINDOWS) -> list:
    """The ``count`` non-overlapping windows [t0, t1) of ``width`` s with the largest RMS residual.

    Every sample can start a window (not a fixed grid), so a burst of error is not
    split between two grid cells; windows are then taken greedily, worst first,
    skipping any that overlaps one already taken. Sorted by RMS, worst first. Each
    entry: ``t0, t1, output, rms`` and ``share`` (its part of the output's squared error).
    """
    t, r = np.asarray(t, dtype=np.float64), np.asarray(residual, dtype=np.float64)
    sq = np.concatenate([[0.0], np.cumsum(r * r)])
    total = sq[-1]
    h = float(np.median(np.diff(t)))
    if t[-1] - t[0] + h <= width:      # shorter than one window: the whole run is the window
        starts, ends = np.array([0]), np.array([len(t)])
        width = float(t[-1] - t[0])
    else:
        ends = np.searchsorted(t, t + width, side="left")
        starts = np.flatnonzero(t + width <= t[-1] + h * (1 + 1e-9))   # full windows only
        ends = ends[starts]
    mean_sq = (sq[ends] - sq[starts]) / (ends - starts)
    taken = []
    for k in np.argsort(-mean_sq, kind="stable"):
        t0 = t[starts[k]]
        if all(abs(t0 - t[starts[j]]) >= width * (1 - 1e-9) for j in taken):
            taken.append(k)
            if len(taken) == count:
                break
    return [{"t0": float(t[starts[k]]), "t1": float(t[starts[k]] + width), "output": output,
             "rms": float(np.sqrt(mean_sq[k])),
             "share": float((sq[ends[k]] - sq[starts[k]]) / total) if total > 0 else 0.0} for k in taken]
