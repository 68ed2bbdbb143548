"""The swing-up-and-balance scenario with any controller (``--controller pkg.mod:Class``, ``lqr``, ...).

:func:`pendc.hil.scenarios.swing_up_and_balance` builds its own supervisor; this runs the
controller ``--controller`` names, designed on the design model, and judges the run by the same
criterion with the same constants (upright within the scenario's tolerance for its last
``HOLD_SECONDS``, the driven position within ``TRACK_LIMIT`` throughout). Imports pendc.hil.
"""

from __future__ import annotations

from ..hil.controllers.pendulum import PendulumConstants
from ..hil.controllers.controller_spec import make_controller
from ..hil.loop import run_closed_loop
from ..hil.scenarios import ScenarioResult, judge_swing_up, swing_up_criterion


def swing_up_balance_with(controller_spec: str, plant, design, seconds: float, period: float,
                          plant_name: str, consts: PendulumConstants | None = None) -> ScenarioResult:
    """Run ``controller_spec`` (designed on ``design``, whose constants ``consts`` are if already
    made) against ``plant`` for ``seconds`` and judge it."""
    consts = consts or PendulumConstants.from_model(design)
    controller = make_controller(controller_spec, design, period)
    run = run_closed_loop(plant, controller, seconds, period=period, plant_name=plant_name)
    figures, failures = judge_swing_up(run, consts)
    return ScenarioResult(f"swing-up and balance with {controller_spec}", swing_up_criterion(consts),
                          run, figures, failures)
