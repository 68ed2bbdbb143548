"""Selective multiplier sharing: a DSP budget met by the products that can afford an operand mux.

``schedule_graph`` with a DSP budget shares *every* product (units as wide as the widest
product, each behind a phase-selected operand mux), so every product pays the mux's LUT
level, those on the step's critical chain too. Here a schedule is first made with a
multiplier per product; then, while its DSP blocks exceed the budget, two products of
different cycles share a multiplier unit (or a product joins a unit, in a cycle the unit
is free), the pair saving the most blocks first, among those whose operand mux (one LUT
level for up to four uses, :func:`pendc.passes.schedule.operand_mux_delay`) leaves the
estimated step as it was. Only when no such pair is left does a pair lengthen the step,
the one that lengthens it least. The arithmetic never changes, so the golden model stays
bit-exact; the backend builds the units as it does for the default preset
(pendc.backend.timing), and a product without a unit keeps its own multiplier.
"""

from __future__ import annotations

from ..ir.graph import Graph
from .delays import model_for, operand_mux_delay
from .resources import dsp_for, product_widths


def products_of(graph: Graph) -> tuple:
    """Every node that needs a multiplier (GAIN, MUL, interpolating LUT), in graph order."""
    return tuple(n.name for n in graph.nodes if product_widths(graph, n) is not None)


def scheduled_blocks(graph: Graph, schedule, shape: tuple) -> int:
    """DSP blocks a schedule's core needs: its units', plus a multiplier for every product
    that has no unit."""
    served = {name for u in schedule.units for name, _ in u.uses}
    own = sum(dsp_for(*product_widths(graph, graph[p]), shape) for p in products_of(graph) if p not in served)
    return own + sum(dsp_for(*u.widths, shape) for u in schedule.units)


def share_to_budget(graph: Graph, schedule, dsp: int, shape: tuple, reschedule) -> tuple:
    """``(schedule, groups)``: ``schedule`` (a :class:`pendc.passes.schedule.Schedule` with a
    multiplier per product) scheduled again with the operand muxes of ``groups``, the products
    that share a unit (tuples of names), until the DSP blocks are at most ``dsp`` (see the
    module doc); if no grouping meets the budget, the one with the fewest blocks found.
    ``reschedule(muxed)`` schedules the graph at the same clock goal with ``muxed`` (product ->
    operand-mux delay)."""
    model = model_for(schedule.target)
    blocks = {p: dsp_for(*product_widths(graph, graph[p]), shape) for p in products_of(graph)}
    groups: list = []          # tuples of product names sharing one unit
    current, total = schedule, sum(blocks.values())

    def unit_blocks(group) -> int:
        return max(blocks[p] for p in group)

    def trial(new_groups):
        muxed = {p: operand_mux_delay(model, len(g)) for g in new_groups for p in g}
        s = reschedule(muxed)
        distinct = all(len({s.stage[p] for p in g}) == len(g) for g in new_groups)
        return s if distinct and s.ii >= 1 else None

    # how many LUT levels in front of each product alone keep the step: pairs of the products with the
    # most room are tried first (off the critical chain, where the model's error matters least)
    room = {p: _room(reschedule, schedule, p, model.lut_level) for p in blocks}
    while total > dsp:
        shared = {p for g in groups for p in g}
        options = []
        for i, g in enumerate(groups):            # a product joins a unit that is free in its cycle
            cycles = {current.stage[p] for p in g}
            for p in blocks:
                if p not in shared and current.stage[p] not in cycles and len(g) < current.ii:
                    options.append((min(blocks[p], unit_blocks(g)), groups[:i] + [g + (p,)] + groups[i + 1:], (p,)))
        alone = sorted(p for p in blocks if p not in shared)
        for a_i, a in enumerate(alone):
            for b in alone[a_i + 1:]:
                if current.stage[a] != current.stage[b]:
                    options.append((min(blocks[a], blocks[b]), groups + [(a, b)], (a, b)))
        if not options:
            break
        # the largest saving first; among equal savings, the group whose tightest product has the most room
        options.sort(key=lambda o: (-o[0], -min(room[p] for p in o[2]), _key(o[1])))
        chosen, fallback = None, None
        for saving, new_groups, _ in options:
            s = trial(new_groups)
            if s is None:
                continue
            if _keeps(s, schedule):
                chosen = (saving, new_groups, s)
                break
            if fallback is None or s.estimated_step_ns < fallback[2].estimated_step_ns:
                fallback = (saving, new_groups, s)
        chosen = chosen or fallback
        if chosen is None:
            break
        saving, groups, current = chosen
        total -= saving
    return current, tuple(groups)


def _room(reschedule, schedule, product: str, level: float, most: int = 4) -> int:
    """LUT levels (up to ``most``) that ``product``'s operands may pass through with the step
    as short as in ``schedule``."""
    for k in range(1, most + 1):
        if not _keeps(reschedule({product: k * level}), schedule):
            return k - 1
    return most


def _keeps(s, schedule) -> bool:
    """Whether ``s`` is as short as ``schedule`` on the estimate."""
    return s is not None and s.ii == schedule.ii and s.estimated_step_ns <= schedule.estimated_step_ns


def _key(groups) -> tuple:
    return tuple(sorted(tuple(sorted(g)) for g in groups))
