"""The error budget on inputs it was not tuned on, for ``pendc report qformat``.

The build meets its budget on its check stimuli (:func:`pendc.passes.error_budget.check_stimuli`:
the first seconds of the training chirp and swing-up, and the training steps' levels). Here the
same build runs, over the same horizon and in the same (segmented) form, on one input of each
class a user drives a plant with, made independently of those (other bands, amplitudes, levels
and seeds), on whatever input range the model file declares:

* ``chirp`` - a sweep over another band (0.5-5 Hz) at twice the training chirp's amplitude;
* ``steps`` - held levels other than the training steps';
* ``switching`` - the input's two ends in turn after random holds of 10-100 ms (a seed of its own);
* ``closed_loop`` - the input that the builtin controller (a plant without one: ``hold``)
  answered on this build's golden plant through the loop's DAC, replayed;
* ``tap`` - a tap of 0.1 % of the input's span for 20 ms, then the neutral input: the plant moves
  by little on its own, where a product narrowed for the ranges' large motion rounds a small
  acceleration to nothing (round G's Pendubot swung freely 50 % off within its budget's horizon
  while every other class met it; docs/error_budget.md).

Both forms are kept: ``errors`` (segmented, what the verdict reads) and ``plain``.
"""

from __future__ import annotations

from ..errors import PendcError

CLASSES = ("chirp", "steps", "switching", "closed_loop", "tap")
CHIRP = {"f0": 0.5, "f1": 5.0, "amplitude": 2.0}
STEP_LEVELS = (1.1, -0.6, 2.3, -1.7)
SWITCHING = {"hold": (0.01, 0.1), "seed": 23}
TAP = {"level": 0.01, "width": 0.02}


def held_out_stimuli(build, seconds: float) -> tuple[dict, dict]:
    """({class: (t, u)}, {class: why it was left out}) for ``build`` over ``seconds``."""
    from ..sim.stimuli import Stimuli

    on = Stimuli(build.model.interface.input)
    stimuli = {"chirp": on.chirp(duration=seconds, **CHIRP),
               "steps": on.steps(duration=seconds, levels=STEP_LEVELS),
               "switching": on.switching(duration=seconds, **SWITCHING)}
    skipped = {}
    try:
        stimuli["closed_loop"] = closed_loop_input(build, seconds)
    except PendcError as exc:
        skipped["closed_loop"] = str(exc)
    stimuli["tap"] = on.tap(duration=seconds, **TAP)
    return stimuli, skipped


def closed_loop_input(build, seconds: float) -> tuple:
    """(t, u) of the builtin controller (else ``hold``) against ``build``'s golden plant for
    ``seconds``, one row a control period (1 ms): deterministic, so the same on every run."""
    from ..hil.controllers.controller_spec import make_controller
    from ..hil.loop import run_closed_loop
    from ..hil.plants import make_plant

    model = build.model
    try:
        controller = make_controller("builtin", model)
    except PendcError:
        controller = make_controller("hold", model)
    period = 1e-3
    plant = make_plant("golden", model, dt=build.options.dt, build=build)
    run = run_closed_loop(plant, controller, max(seconds, 2 * period), period=period)
    if run.stopped:
        raise PendcError(f"the closed loop stopped: {run.stopped}")
    return run.t, run.u


def held_out_check(build, seconds: float | None = None, budgets: dict | None = None) -> dict:
    """The held-out report of ``build`` (horizon: the budget's, unless ``seconds``; ``budgets``:
    the build's unless given): per class the segmented and plain max |fixed - float| per state,
    the restarts, and whether each budget holds."""
    from ..passes.segmented_error import FORM, compare_segmented
    from ..passes.twin import BudgetError

    if build.error is None:
        raise PendcError("the build has no error budget (error_budget = false): nothing to hold out")
    seconds = build.error.seconds if seconds is None else seconds
    budgets = dict(build.error.budgets if budgets is None else budgets)
    stimuli, skipped = held_out_stimuli(build, seconds)
    try:
        runs = compare_segmented(build.graph, stimuli, build.options.dt)
    except BudgetError as exc:
        return {"seconds": seconds, "form": FORM, "budgets": budgets, "stimuli": {}, "skipped": skipped,
                "overflow": str(exc), "met": False}
    out = {}
    for name, run in runs.items():
        met = {s: run.segmented[s] <= b for s, b in budgets.items()}
        out[name] = {"errors": run.segmented, "plain": run.plain, "restarts": run.restarts,
                     "first_restarts": list(run.restart_steps), "met": all(met.values()),
                     "over": sorted(s for s, ok in met.items() if not ok)}
    return {"seconds": seconds, "form": FORM, "budgets": budgets, "stimuli": out, "skipped": skipped,
            "overflow": None, "met": all(r["met"] for r in out.values())}


def format_budget(error_budget: dict | None, held_out: dict | None) -> list:
    """The report's lines on the error budget: the form, the training stimuli (the budget loop's,
    with its rounds) and the held-out ones, per state against the budget."""
    if not error_budget:
        return []
    budgets = error_budget["budgets"]
    lines = ["", f"Error budget over the first {error_budget['seconds']:g} s (bit-accurate vs float), "
                 + "  ".join(f"{s} <= {b:.3g}" for s, b in budgets.items()),
             f"  form: {error_budget.get('form') or 'plain max |fixed - float|'}",
             "  training (the budget loop's check stimuli): " + ("met" if error_budget["met"] else "NOT met")]
    plain = error_budget.get("plain") or {}
    restarts = error_budget.get("restarts") or {}
    for stim, errs in error_budget["errors"].items():
        lines.append(_row(stim, errs, plain.get(stim), restarts.get(stim), budgets))
    for a in error_budget["actions"]:
        lines.append(f"    round: {a}")
    if held_out is not None:
        lines.append(f"  held out (inputs the budget was not tuned on, same horizon): "
                     + ("met" if held_out["met"] else "NOT met"))
        if held_out.get("overflow"):
            lines.append(f"    overflow: {held_out['overflow']}")
        for stim, r in held_out["stimuli"].items():
            lines.append(_row(stim, r["errors"], r["plain"], r["restarts"], budgets))
        for stim, why in held_out["skipped"].items():
            lines.append(f"    {stim:12s} left out: {why}")
    return lines


def _row(stim: str, errs: dict, plain: dict | None, restarts: int | None, budgets: dict) -> str:
    """One stimulus: each budgeted state's segmented error, met or not, then the other states;
    the plain errors and restarts where they differ."""
    cells = []
    for s, v in errs.items():
        mark = "" if s not in budgets else (" ok" if v <= budgets[s] else " OVER")
        extra = f" (plain {plain[s]:.3g})" if plain and s in budgets and plain[s] != v else ""
        cells.append(f"{s} {v:.3g}{mark}{extra}")
    tail = f"  [{restarts} restart{'s' if restarts != 1 else ''}]" if restarts else ""
    return f"    {stim:12s} " + "  ".join(cells) + tail
