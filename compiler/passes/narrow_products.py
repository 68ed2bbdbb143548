"""Products back to one DSP block where the error budget does not need them wider.

:func:`pendc.passes.error_budget.meet_error_budget` raises the operand level of a quarter of
the products a round (the ones its ranking suspects first) until the budget holds, so a
met budget usually carries products it never needed wide: on the default model's short chain
18 products end at level 1 (16 of them two DSP blocks) where one, the input's gain, is what x
needed (docs/hardware.md, "The thesis preset"). Narrowing them back is what a DSP budget
needs (41 blocks become 26) and shortens the step, since a one-block product is 2.4 ns faster.

:func:`narrow_products` lowers the raised two-block products back to level 0 by group
testing: all at once if the budget still holds, else each half in turn (the other half
kept wide), down to the single products the budget needs. Every check is the budget's own:
``meet_error_budget`` for one round on the graph with the levels fixed, so the check stimuli
and the error's form are whatever the budget uses. A final check on the narrowed graph makes
its report; if it misses (narrowing two halves that held apart), the budget's own graph stays.
"""

from __future__ import annotations

from dataclasses import replace

from .error_budget import meet_error_budget
from .resources import dsp_for, product_widths


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

    def check(lowered: frozenset):
        if lowered not in checks:
            fixed = {p: (0 if p in lowered else lv) for p, lv in levels.items()}

            def at(widen, addr, _levels=None):
                return typed({**report.widened, **widen}, {**grown, **addr}, fixed)

            checks[lowered] = meet_error_budget(at, budgets, dt, seconds, engine=engine, max_rounds=1,
                                                inp=None)
        return checks[lowered]

    def prune(candidates: list, low: frozenset) -> frozenset:
        """The candidates that can go to level 0 with ``low`` already there."""
        if not candidates:
            return frozenset()
        if check(low | frozenset(candidates))[1].met:
            return frozenset(candidates)
        if len(candidates) == 1:
            return frozenset()
        half = len(candidates) // 2
        first = prune(candidates[:half], low)
        return first | prune(candidates[half:], low | first)

    lowered = prune(wide, frozenset())
    if not lowered:
        return graph, report
    narrowed, checked = check(lowered)
    if not checked.met:
        return graph, report
    action = f"products back to one DSP block, the budget holding: {', '.join(sorted(lowered))}"
    return narrowed, replace(checked, actions=report.actions + (action,), widened=dict(report.widened),
                             levels={p: (0 if p in lowered else lv) for p, lv in sorted(levels.items())})
