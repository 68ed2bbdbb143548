"""The swing-up-and-balance scenario with any controller (``--controller pkg.mod:Class``, ``lqr``, ...).

:func:`pendc.hil.scenarios.swing_up_and_balance` builds its own supervisor; this runs the
controller ``--controller`` names, designed on the design model, and judges the run by the same
criterion with the same constants (upright within the scenario's tolerance for its last
``HOLD_SECONDS``, the driven position within ``TRACK_LIMIT`` throughout). Imports pendc.hil.
"""

from __future__ import annotations

import numpy as np

from ..hil.controllers.pendulum import PendulumConstants
from ..hil.controllers.controller_spec import make_controller
from ..hil.loop import UPRIGHT_TOLERANCE, run_closed_loop
from ..hil.scenarios import HOLD_SECONDS, TRACK_LIMIT, ScenarioResult


def swing_up_balance_with(controller_spec: str, plant, design, seconds: float, period: float,
                          plant_name: str, consts: PendulumConstants | None = None) -> ScenarioResult:
    """Run ``controller_spec`` (designed on ``design``, whose constants ``consts`` are if already
    made) against ``plant`` for ``seconds`` and judge it."""
    consts = consts or PendulumConstants.from_model(design)
    controller = make_controller(controller_spec, design, period)
    run = run_closed_loop(plant, controller, seconds, period=period, plant_name=plant_name)
    phi = np.array([consts.upright_error(v) for v in run.column(consts.angle)])
    last = run.t >= run.t[-1] - HOLD_SECONDS + 1e-9 if run.t.size else np.zeros(0, bool)
    worst = float(np.max(np.abs(phi[last]))) if last.any() else float("inf")
    failures = []
    if run.stopped is not None:
        failures.append(f"the run stopped early: {run.stopped}")
    travel = run.column(consts.actuated)
    unit = consts.roles.actuated.unit
    if travel.size and np.max(np.abs(travel)) >= TRACK_LIMIT:
        failures.append(f"|{consts.actuated}| reached {np.max(np.abs(travel)):.3f} {unit} (limit {TRACK_LIMIT} {unit})")
    if worst >= UPRIGHT_TOLERANCE:
        failures.append(f"|{consts.angle} - pi| reached {worst:.3f} rad in the last {HOLD_SECONDS:g} s")
    return ScenarioResult(f"swing-up and balance with {controller_spec}",
                          f"|{consts.angle} - pi| < {UPRIGHT_TOLERANCE} rad for the last {HOLD_SECONDS:g} s, "
                          f"|{consts.actuated}| < {TRACK_LIMIT} {unit} throughout",
                          run, {**run.summary(), "worst_last_3s_rad": worst}, tuple(failures))
