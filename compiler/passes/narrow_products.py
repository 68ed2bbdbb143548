"""Products back to one DSP block where the error budget does not need them wider.

:func:`pendc.passes.error_budget.meet_error_budget` raises the operand level of a quarter of
the products a round (the ones its ranking suspects first) until the budget holds, so a
met budget usually carries products it never needed wide: on the default model's short chain
18 products end at level 1 (16 of them two DSP blocks) where two, the input's gain and the
cart's position increment, are what x needs (docs/hardware.md, "The thesis preset"). Narrowing
them back is what a DSP budget needs (41 blocks become 27) and shortens the step, since a
one-block product is 2.4 ns faster.

:func:`narrow_products` lowers the raised two-block products back to level 0 by group
testing: all at once if the budget still holds, else each half in turn (the other half
kept wide), down to the single products the budget needs. A set holds when the budget's own
check holds (``meet_error_budget`` for one round on the graph with the levels fixed: its check
stimuli and its form of the error) *and* the budget holds, in the same form and horizon, on
validation inputs of the classes a user drives the plant with (:func:`validation_stimuli`).
Narrowing decides on many sets, so it finds the edge of whatever it is checked on: against the
check stimuli alone it kept the position increment ``x_inc_dx_gain`` narrow, the training
errors at half the budget and the held-out steps and switching of ``pendc report qformat``
over it (x 1.33 and 1.42 um of 1.25; issue 23). The validation inputs are made independently
of the training and of the report's held-out ones, so the held-out check stays unseen. A final
check on the narrowed graph makes its report; if it misses (two halves that held apart), the
budget's own graph stays.
"""

from __future__ import annotations

from dataclasses import replace

from ..model.interface import require_interface
from ..sim.stimuli import Stimuli
from .error_budget import complete_report, meet_error_budget
from .resources import dsp_for, product_widths
from .segmented_error import compare_segmented
from .twin import BudgetError

# Two inputs of each held-out class (cli/heldout.py), none of them a training or held-out one:
# chirps of other bands and amplitudes, held levels of their own, switching with other seeds
# (the budget's steps: 0.8, -0.8, 1.4, -1.4, 0; the report's: 1.1, -0.6, 2.3, -1.7, seed 23; the
# ranges' switching: seeds 9 and 10). Only the narrowing reads them.
VALIDATION_CHIRPS = ({"f0": 1.0, "f1": 8.0, "amplitude": 1.5}, {"f0": 0.2, "f1": 3.0, "amplitude": 2.5})
VALIDATION_STEP_LEVELS = ((-1.9, 0.7, -1.2, 2.1), (1.6, -2.2, 0.4, -0.9))
VALIDATION_SWITCHING_SEEDS = (5, 7)
SWITCHING_HOLD = (0.01, 0.1)


def validation_stimuli(inp, seconds: float) -> dict:
    """name -> (t, u): the validation inputs over ``seconds`` on the input ``inp`` (an InputSpec)."""
    on, d = Stimuli(inp), max(seconds, 0.01)
    out = {f"chirp_{c['f0']:g}_{c['f1']:g}Hz": on.chirp(duration=d, **c) for c in VALIDATION_CHIRPS}
    out.update({f"steps_{i + 1}": on.steps(duration=d, levels=lv) for i, lv in enumerate(VALIDATION_STEP_LEVELS)})
    out.update({f"switching_{s}": on.switching(duration=d, hold=SWITCHING_HOLD, seed=s)
                for s in VALIDATION_SWITCHING_SEEDS})
    return out


def validation_errors(graph, budgets: dict, dt: float, seconds: float) -> dict | None:
    """Per budgeted state the worst segmented error of ``graph`` on the validation inputs; None
    where the fixed run overflows (a narrowing that overflows does not hold). A run stops once a
    state is over its budget (the worst is then a lower bound: the set does not hold either way)."""
    try:
        runs = compare_segmented(graph, validation_stimuli(require_interface(graph).input, seconds), dt, plain=False,
                                 stop_above=budgets)
    except BudgetError:
        return None
    return {s: max(r.segmented[s] for r in runs.values()) for s in budgets}


def narrow_products(typed, graph, report, budgets: dict, dt: float, seconds: float, shape: tuple,
                    engine: str = "compiled", grown: dict | None = None) -> tuple:
    """``(graph, report)`` with the products the budget does not need wide back at level 0 (see
    the module doc). ``typed(widen, addr_bits, levels)`` types the graph as in the budget,
    ``graph``/``report`` are the budget's result, ``grown`` the tables it enlarged."""
    levels = dict(report.levels or {})
    wide = sorted(p for p, lv in levels.items() if lv > 0 and p in graph.by_name
                  and dsp_for(*product_widths(graph, graph[p]), shape) > 1)
    if not wide or not report.met:
        return graph, report
    grown = dict(grown or {})
    checks: dict = {}

    def at_level_0(lowered: frozenset):
        fixed = {p: (0 if p in lowered else lv) for p, lv in levels.items()}

        def at(widen, addr, _levels=None):
            return typed({**report.widened, **widen}, {**grown, **addr}, fixed)
        return at

    def check(lowered: frozenset):
        """(graph, validation errors or None, holds) of ``lowered`` at level 0."""
        if lowered not in checks:
            # whether it holds is all a candidate set needs: the report's extra runs only for the one kept
            g, r = meet_error_budget(at_level_0(lowered), budgets, dt, seconds, engine=engine, max_rounds=1,
                                     inp=None, full_report=False)
            valid = validation_errors(g, budgets, dt, seconds) if r.met else None
            checks[lowered] = (g, valid, valid is not None and all(valid[s] <= b for s, b in budgets.items()), r)
        return checks[lowered]

    def prune(candidates: list, low: frozenset) -> frozenset:
        """The candidates that can go to level 0 with ``low`` already there."""
        if not candidates:
            return frozenset()
        if check(low | frozenset(candidates))[2]:
            return frozenset(candidates)
        if len(candidates) == 1:
            return frozenset()
        half = len(candidates) // 2
        first = prune(candidates[:half], low)
        return first | prune(candidates[half:], low | first)

    lowered = prune(wide, frozenset())
    if not lowered:
        return graph, report
    narrowed, valid, holds, answer = check(lowered)
    if not holds:
        return graph, report
    # the check's report with the node and plain errors a full one adds (its segmented runs ran to the end: met)
    checked = complete_report(narrowed, answer, dt, engine)
    action = ("products back to one DSP block, the budget holding on the check stimuli and the validation "
              "inputs (worst " + ", ".join(f"{s} {v:.3g}" for s, v in valid.items()) + f"): {', '.join(sorted(lowered))}")
    return narrowed, replace(checked, actions=report.actions + (action,), widened=dict(report.widened),
                             levels={p: (0 if p in lowered else lv) for p, lv in sorted(levels.items())})
