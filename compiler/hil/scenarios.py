"""The thesis' HIL tests (Fig. IV.21-IV.23) and a model-mismatch test, each with its pass criterion.

Every scenario runs the builtin controllers against a stepping plant and returns a
:class:`ScenarioResult`: the run, the figures the criterion looks at, and the list of
criteria that failed (empty when it passes). The plants start hanging at rest (power-on),
so the step-disturbance scenario first swings the pendulum up and then, balanced, moves
the cart's set point 4 cm to the left as Fig. IV.21 does. The criteria are the thesis' for
a cart on a track (metres); the states are named as the plant interface names them
(:class:`~pendc.hil.controllers.pendulum.PendulumConstants`: the actuated position, the pendulum angle).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..model.interface import is_dimensionless, with_unit
from ..model.plant import PlantModel
from .controllers.pendulum import CATCH_ANGLE, EnergySwingUp, PendulumConstants, Supervisor
from .loop import UPRIGHT_TOLERANCE, HilRun, run_closed_loop

TRACK_LIMIT = 0.3        # m: |x| allowed throughout (the track ends at ±0.375 m)
HOLD_SECONDS = 3.0       # upright for the last 3 s of the run
STEP_SIZE = 0.04         # m, to the left (+x), Fig. IV.21
STEP_AT = 7.0            # s, when the set point moves (the pendulum is balanced by then)
SETTLE_LIMIT = 2.0       # s
SETTLE_BAND = 0.1        # of the step: within 4 mm of the set point counts as settled


@dataclass(frozen=True)
class ScenarioResult:
    """A scenario's run, its figures of merit and the criteria it failed."""

    name: str
    criterion: str
    run: HilRun
    figures: dict
    failures: tuple = field(default_factory=tuple)

    @property
    def passed(self) -> bool:
        """True when every criterion holds."""
        return not self.failures


def _phi(run: HilRun, consts: PendulumConstants) -> np.ndarray:
    return np.array([consts.upright_error(v) for v in run.column(consts.angle)])


def _common_failures(run: HilRun, consts: PendulumConstants) -> list:
    out = []
    if run.stopped is not None:
        out.append(f"the run stopped early: {run.stopped}")
    travel = run.column(consts.actuated)
    if travel.size and np.max(np.abs(travel)) >= TRACK_LIMIT:
        unit = consts.roles.actuated.unit
        out.append(f"|{consts.actuated}| reached {with_unit(f'{np.max(np.abs(travel)):.3f}', unit)} "
                   f"(limit {with_unit(str(TRACK_LIMIT), unit)})")
    return out


def travel_ratio(run: HilRun, consts: PendulumConstants) -> float | None:
    """The driven position's largest |value| over the track limit (1: at the limit)."""
    travel = run.column(consts.actuated)
    return float(np.max(np.abs(travel)) / TRACK_LIMIT) if travel.size else None


def judge_swing_up(run: HilRun, consts: PendulumConstants) -> tuple:
    """The swing-up-and-balance criterion on ``run``, whatever controlled it: its figures
    (the run's summary, ``worst_last_3s_rad``, ``travel_ratio``) and the criteria it failed."""
    phi = _phi(run, consts)
    last = run.t >= run.t[-1] - HOLD_SECONDS + 1e-9 if run.t.size else np.zeros(0, bool)
    worst = float(np.max(np.abs(phi[last]))) if last.any() else float("inf")
    failures = _common_failures(run, consts)
    if worst >= UPRIGHT_TOLERANCE:
        failures.append(f"{_upright(consts)} reached {worst:.3f} rad in the last {HOLD_SECONDS:g} s")
    figures = {**run.summary(), "worst_last_3s_rad": worst, "travel_ratio": travel_ratio(run, consts)}
    return figures, tuple(failures)


def swing_up_criterion(consts: PendulumConstants) -> str:
    """The swing-up-and-balance criterion in words, with the plant's names."""
    return (f"{_upright(consts)} < {UPRIGHT_TOLERANCE} rad for the last {HOLD_SECONDS:g} s of the run, "
            f"{_travel(consts)} throughout")


def _upright(consts: PendulumConstants) -> str:
    """|angle - upright| in words, with the plant's angle."""
    return f"|{consts.angle} - pi|"


def _travel(consts: PendulumConstants) -> str:
    """The track limit in words, with the plant's actuated position."""
    return f"|{consts.actuated}| < {with_unit(str(TRACK_LIMIT), consts.roles.actuated.unit)}"


def swing_up_and_balance(plant, model: PlantModel, seconds: float = 12.0, design: PlantModel | None = None,
                         period: float = 1e-3, plant_name: str = "",
                         consts: PendulumConstants | None = None) -> ScenarioResult:
    """Fig. IV.23: from rest, swing up and hold upright. Pass: the pendulum within 0.05 rad of the upright
    for the last 3 s and the driven position within the track limit throughout. ``design`` is the model the controller is
    designed on (default: the plant's own model); ``consts``: its constants, if already made."""
    consts = consts or PendulumConstants.from_model(design or model)
    run = run_closed_loop(plant, Supervisor(consts, period), seconds, period=period, plant_name=plant_name)
    figures, failures = judge_swing_up(run, consts)
    return ScenarioResult("swing-up and balance (Fig. IV.23)", swing_up_criterion(consts), run, figures, failures)


def swing_up_only(plant, model: PlantModel, seconds: float = 8.0, period: float = 1e-3,
                  plant_name: str = "", within: float = 5.0, consts: PendulumConstants | None = None) -> ScenarioResult:
    """Fig. IV.22: the energy swing-up alone brings the pendulum into the supervisor's catch
    window (within 0.4 rad of the upright) within 5 s, the driven position within the track limit
    throughout. It does not
    hold it there: energy pumping keeps it swinging about the upright. ``consts``: the model's
    constants, if already made."""
    consts = consts or PendulumConstants.from_model(model)
    run = run_closed_loop(plant, EnergySwingUp(consts, period), seconds, period=period, plant_name=plant_name)
    phi = np.abs(_phi(run, consts))
    near = np.flatnonzero(phi < CATCH_ANGLE)
    failures = _common_failures(run, consts)
    if not near.size:
        failures.append(f"the pendulum came no closer than {phi.min():.3f} rad to the upright")
    elif run.t[near[0]] > within:
        failures.append(f"the pendulum first came within {CATCH_ANGLE} rad of the upright at "
                        f"t = {run.t[near[0]]:.3f} s (limit {within:g} s)")
    figures = {**run.summary(), "first_near_upright_s": float(run.t[near[0]]) if near.size else None,
               "closest_rad": float(phi.min()), "travel_ratio": travel_ratio(run, consts)}
    return ScenarioResult("swing-up alone (Fig. IV.22)",
                          f"within 0.4 rad of the upright (the catch window) by t = 5 s, {_travel(consts)} throughout",
                          run, figures, tuple(failures))


def step_disturbance(plant, model: PlantModel, period: float = 1e-3, plant_name: str = "",
                     consts: PendulumConstants | None = None) -> ScenarioResult:
    """Fig. IV.21: balanced upright, the cart's set point steps 4 cm left at t = 7 s. Pass: within
    2 s after the step, the driven position within 4 mm of its set point and the pendulum within
    0.05 rad of the upright, and they stay so until the end (t = 11 s); upright before the step; the
    driven position within the track limit throughout. ``consts``: the model's constants, if
    already made."""
    def set_point(t: float) -> float:
        return STEP_SIZE if t >= STEP_AT else 0.0

    seconds = STEP_AT + 2 * SETTLE_LIMIT
    consts = consts or PendulumConstants.from_model(model)
    run = run_closed_loop(plant, Supervisor(consts, period, position_ref=set_point), seconds, period=period,
                          plant_name=plant_name)
    phi = _phi(run, consts)
    travel = run.column(consts.actuated)
    after = run.t >= STEP_AT
    off = after & ((np.abs(travel - STEP_SIZE) >= SETTLE_BAND * STEP_SIZE) | (np.abs(phi) >= UPRIGHT_TOLERANCE))
    settle = float(run.t[np.flatnonzero(off)[-1]] - STEP_AT + period) if off.any() else 0.0
    before = (run.t >= STEP_AT - 1.0) & ~after
    failures = _common_failures(run, consts)
    if not (before.any() and np.all(np.abs(phi[before]) < UPRIGHT_TOLERANCE)):
        failures.append("the pendulum was not balanced in the second before the step")
    if settle > SETTLE_LIMIT:
        failures.append(f"settled {settle:.3f} s after the step (limit {SETTLE_LIMIT:g} s)")
    overshoot = float(np.max(travel[after]) - STEP_SIZE) if after.any() else None
    figures = {**run.summary(), "settle_s": settle, "overshoot_m": overshoot,
               "travel_ratio": travel_ratio(run, consts)}
    return ScenarioResult("4 cm set-point step while balancing (Fig. IV.21)",
                          f"settled (|{consts.actuated} - set point| < 4 mm, {_upright(consts)} < 0.05 rad) "
                          "within 2 s of the step",
                          run, figures, tuple(failures))


def balance_activity(run: HilRun) -> dict:
    """Input and translation activity while balancing (from 1 s after the balance starts):
    ``u_std_v`` and ``<state>_peak_to_peak_<unit>`` of every measured state but the angle."""
    up_at = run.summary()["upright_at_s"]
    mask = np.array([m == "balance" for m in run.mode]) & (run.t > (up_at if up_at is not None else np.inf) + 1.0)
    units = dict(run.units)
    others = [(s, c) for s, c in run.positions if s != run.angle]
    out = {"u_std_v": float(np.std(run.u[mask])) if mask.any() else None}
    for state, column in others:
        unit = units.get(state, "")
        key = f"{state}_peak_to_peak" + ("" if is_dimensionless(unit) else f"_{unit}")
        out[key] = float(np.ptp(column[mask])) if mask.any() else None
    return out


def model_mismatch(make, design: PlantModel, truth: PlantModel, seconds: float = 12.0,
                   plant_name: str = "") -> dict:
    """The controller designed on ``design`` run against ``design`` itself (what the designer's
    simulation predicts) and against ``truth`` (what HIL shows), beside the controller designed
    on ``truth``. ``make(model)`` builds a fresh plant. Returns the three results by name."""
    cases = {"predicted": (design, design), "hil": (design, truth), "matched": (truth, truth)}
    out = {}
    for name, (d, p) in cases.items():
        res = swing_up_and_balance(make(p), p, seconds, design=d, plant_name=plant_name)
        out[name] = res
    return out
