"""Error budget: run bit-accurate against float and buy precision where the error is too large.

The thesis assigned 32 bits everywhere by rule; whether that is enough only shows when
the fixed-point model runs against its real-number twin for seconds (numerics notes:
integrators at 1 us accumulate their rounding). This pass does exactly that on the
typed graph over check stimuli and, while a state's error exceeds its budget,

1. widens the state accumulators (register, sum and increment) by 8 fraction bits —
   the outputs keep their meaning, the registers just carry guard bits; then
2. gives the products fitted to one DSP block (see :mod:`qformats`) wider operands, the
   ones whose output is least accurate relative to its range first, one level a round
   (a level costs DSP blocks: this is where the budget, not a rule, sets the widths); then
3. enlarges the tables whose linear-interpolation error is largest (one address bit
   quarters that error).

The float twin is the same graph in real arithmetic with exact table functions, so the
measured error is the fixed-point implementation's alone. It is measured in the segmented form
(:mod:`.segmented_error`: restarted where a discontinuity's decision differs), and the check
stimuli include held input levels: a held input's rounding is an offset that integrates into a
drift, which a sweeping input averages away (issue 23: 24 um on held steps with the 18-bit input
operand that the chirp and swing-up passed).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..ir import lut as lut_sem
from ..ir.graph import Graph
from ..ir.nodes import Kind
from ..ir.shared_source import same_structure
from ..model.interface import require_interface
from ..sim.stimuli import Stimuli
from .segmented_error import FORM, compare_segmented
from .twin import BudgetError, budget_states, compare_fixed_float, float_twin  # noqa: F401  (their old home)

WIDEN_STEP = 8               # fraction bits added to the state accumulators per round
MAX_WIDEN = 24               # at most this many in all
MAX_GROWN_ADDR_BITS = 13     # the budget grows a table up to 2**13 segments (the IR allows more: limits.py)


@dataclass(frozen=True)
class ErrorReport:
    """``errors[stimulus][state]`` = max |fixed - float| over the check horizon in the segmented
    form (final graph; ``form`` says what that is), ``plain`` the same without restarts and
    ``restarts[stimulus]`` how often the segmented run restarted; ``node_errors[node]`` = max
    |fixed - float| of every node (sampled); ``actions`` lists what each round changed; ``met``
    tells whether every budget holds."""

    budgets: dict
    errors: dict
    node_errors: dict
    widened: dict
    addr_bits: dict
    actions: tuple
    met: bool
    seconds: float
    levels: dict = None               # product -> operand level (0: one DSP block); None: not fitted
    plain: dict = None
    restarts: dict = None
    form: str = FORM

    def to_json(self) -> dict:
        return dict(self.__dict__, actions=list(self.actions))


def check_stimuli(inp, seconds: float) -> dict:
    """The first ``seconds`` of the standard 20 s chirp and 5 s swing-up-like input, and the
    standard steps' five held levels in ``seconds``, on the input ``inp`` (an InputSpec; the
    signals and levels the ranges were trained on, so a short check never leaves the trained
    range). The steps hold the input: a sweep averages an input's rounding, a held level does not."""
    out = {}
    on = Stimuli(inp)
    for name, (t, u) in {"chirp": on.chirp(), "swing_up": on.swing_up(),
                         "steps": on.steps(duration=max(seconds, 0.01))}.items():
        n = int(np.searchsorted(t, max(seconds, 0.01) + 1e-9))
        out[name] = (t[:n], u[:n])
    return out


def interpolation_error(node, fin) -> float:
    """Largest |table(v) - f(v)| of a typed LUT (input format ``fin``) at its segment midpoints."""
    p = node.params
    xs = lut_sem.grid_points(p.lo, p.addr_bits, p.shift, fin, p.interpolate)
    ys = lut_sem.evaluate(p.expr, xs)
    mids = 0.5 * (xs[:-1] + xs[1:]) if p.interpolate else xs
    approx = 0.5 * (ys[:-1] + ys[1:]) if p.interpolate else ys
    return float(np.max(np.abs(approx - lut_sem.evaluate(p.expr, mids))))


def meet_error_budget(typed, budgets: dict, dt: float, seconds: float, engine: str = "compiled",
                      max_rounds: int = 16, products: tuple = (), max_level: int = 2, inp=None,
                      full_report: bool = True):
    """Call ``typed(widen, addr_bits, levels)`` -> typed graph until every state in ``budgets`` is
    within its budget on the check stimuli; ``products`` are the nodes whose operand level may
    rise (up to ``max_level``); the check stimuli drive the input ``inp`` (an InputSpec; default:
    the input of the plant the graphs were lowered from). Returns (graph, ErrorReport).

    ``full_report`` False answers only whether the budget holds: the report's node errors and
    plain errors (two more runs of every check stimulus) are None, the last round computes no
    remedy it would not try and stops its runs once a state is over its budget (its errors are
    then lower bounds: what deciding on many candidate typings needs,
    :func:`pendc.passes.narrow_products.narrow_products`)."""
    stimuli = None if inp is None else check_stimuli(inp, seconds)
    widen: dict = {}
    addr: dict = {}
    levels: dict = {p: 0 for p in products}
    actions = []
    anchor, since = None, 0          # the first round of the current structure, rounds since
    float_runs: dict = {}
    for round_ in range(max_rounds):
        used = dict(levels)
        graph = typed(dict(widen), dict(addr), dict(levels)) if products else typed(dict(widen), dict(addr))
        if stimuli is None:           # on the input of the plant the graphs come from
            stimuli = check_stimuli(require_interface(graph).input, seconds)
        anchor, since = (anchor, since + 1) if anchor is not None and same_structure(graph, anchor) else (graph, 0)
        # from the third round of one structure on, the rounds differ from its first in the same
        # nodes (the widened accumulators and their readers): they share one kernel. The first two
        # stay baked, so a budget met by then leaves the kernel later golden runs of it load.
        like = anchor if since >= 2 else None

        def node_errors_now():      # a second run of every stimulus: only when a decision or the report reads it
            return compare_fixed_float(graph, stimuli, dt, engine, like=like, float_runs=float_runs, states=False)[1]

        # a last round that only answers whether the budget holds, and a round that a remedy will
        # follow, stop once a state is over its budget: which remedy comes next does not depend on
        # which states are over, nor by how much (the products' choice runs its own comparison).
        # Its action then names the states found over before the runs stopped. (Running such a
        # round to its end to name every state over was two thirds of a default build's budget.)
        last_answer = not full_report and round_ == max_rounds - 1
        remedy = _next_remedy(graph, widen, levels, max_level)
        followed = round_ < max_rounds - 1 and remedy is not None
        runs = compare_segmented(graph, stimuli, dt, like=like, plain=False,
                                 stop_above=budgets if last_answer or followed else None)
        errors = {k: r.segmented for k, r in runs.items()}
        node_errors = None
        worst = {s: max(errors[k][s] for k in errors) for s in budgets}
        over = [s for s in budgets if worst[s] > budgets[s]]
        if not over or last_answer:
            break
        if remedy is None:
            actions.append(f"{', '.join(over)} over budget and no remedy left")
            break
        if remedy == "widen":
            current = max(widen.values(), default=0)       # every state accumulator is widened alike
            for s in budget_states(graph):
                widen[s] = current + WIDEN_STEP
            actions.append(f"{', '.join(over)} over budget: state accumulators +{WIDEN_STEP} fraction bits")
        elif remedy == "products":
            node_errors = node_errors_now()
            raise_ = _products_to_widen(graph, node_errors, levels, max_level)
            for n in raise_:
                levels[n] += 1
            actions.append(f"{', '.join(over)} over budget: wider multiplier operands for "
                           + ", ".join(f"{n} (level {levels[n]})" for n in raise_))
        else:
            luts = [n for n in graph.of_kind(Kind.LUT) if n.params.addr_bits < MAX_GROWN_ADDR_BITS]
            errs = {n.name: _relative_interp_error(graph, n) for n in luts}
            worst_lut = max(errs.values())
            grown = sorted(n for n, e in errs.items() if e >= worst_lut / 4)
            for n in grown:
                addr[n] = graph[n].params.addr_bits + 1
            actions.append(f"{', '.join(over)} over budget: +1 address bit for {', '.join(grown)}")
    if node_errors is None and full_report:
        node_errors = node_errors_now()
    met = all(max(errors[k][s] for k in errors) <= budgets[s] for s in budgets)
    plain = compare_fixed_float(graph, stimuli, dt, engine, like=like, float_runs=float_runs, nodes=False)[0] \
        if full_report else None
    report = ErrorReport(budgets=dict(budgets), errors=errors, node_errors=node_errors, widened=dict(widen),
                         addr_bits={n.name: n.params.addr_bits for n in graph.of_kind(Kind.LUT)},
                         actions=tuple(actions), met=met, seconds=seconds,
                         levels=dict(sorted(used.items())) if products else None, plain=plain,
                         restarts={k: r.restarts for k, r in runs.items()})
    return graph, report


def complete_report(graph: Graph, report: ErrorReport, dt: float, engine: str = "compiled") -> ErrorReport:
    """``report``, made by :func:`meet_error_budget` with ``full_report=False`` for ``graph`` on
    the graph's own input, with what a full report adds (the node errors and the plain errors):
    the same report as a full one, without running the segmented comparison again. A budget it
    did not meet may have stopped its runs early, so only a met one is completed."""
    if not report.met:
        raise ValueError("only a met budget's report is complete in its errors")
    stimuli = check_stimuli(require_interface(graph).input, report.seconds)
    float_runs: dict = {}
    node_errors = compare_fixed_float(graph, stimuli, dt, engine, float_runs=float_runs, states=False)[1]
    plain = compare_fixed_float(graph, stimuli, dt, engine, float_runs=float_runs, nodes=False)[0]
    return replace(report, node_errors=node_errors, plain=plain)


def _next_remedy(graph: Graph, widen: dict, levels: dict, max_level: int) -> str | None:
    """The remedy a round of ``graph`` that misses the budget applies, the first that is left in
    the order they are tried: "widen" (the state accumulators, up to MAX_WIDEN), "products" (a
    product below ``max_level``), "tables" (a table below the largest the budget grows); None
    when none is left. Known before the round runs, so the round knows whether one follows it."""
    if max(widen.values(), default=0) < MAX_WIDEN:
        return "widen"
    if any(lv < max_level and name in graph for name, lv in levels.items()):
        return "products"
    if any(n.params.addr_bits < MAX_GROWN_ADDR_BITS for n in graph.of_kind(Kind.LUT)):
        return "tables"
    return None


def _products_to_widen(graph: Graph, node_errors: dict, levels: dict, max_level: int) -> list:
    """The quarter (at least one) of the products below ``max_level`` whose own rounding
    injects the largest relative error (:func:`injected_error`); ties by the measured
    output error relative to the node's range."""
    score = {}
    for name, level in levels.items():
        if level >= max_level or name not in graph:
            continue
        fmt = graph[name].qformat
        score[name] = (injected_error(graph, graph[name]),
                       node_errors.get(name, 0.0) / max(abs(fmt.max_value), fmt.lsb))
    ranked = sorted(score, key=lambda n: (-score[n][0], -score[n][1], n))
    return ranked[:max(1, len(ranked) // 4)]


def injected_error(graph: Graph, node) -> float:
    """Relative error a product's narrow formats add by themselves: a coefficient's (or a
    table's) rounding is systematic and counts fully; rounding a narrowed operand is noise
    that integrators average, so it counts half (a held input's too: its narrowing feeds its
    residue back, :func:`pendc.passes.qformats.assign_qformats`)."""
    total = 0.0
    if node.kind is Kind.GAIN:
        c, cf = node.params.value, node.params.cfmt
        total += abs(cf.to_float(node.params.constant) - c) / max(abs(c), 1e-300)
    if node.kind is Kind.LUT:
        total += node.qformat.lsb / 2 / max(node.params.fmax or 0.0, node.qformat.lsb)
    for i in node.inputs:
        src = graph[i]
        if src.kind is Kind.CAST:          # a narrowed operand (or a narrowed table address)
            total += 0.5 * src.qformat.lsb / 2 / max(abs(src.qformat.max_value), src.qformat.lsb)
    return total


def _relative_interp_error(graph: Graph, node) -> float:
    scale = max(node.params.fmax or 0.0, 1e-300)
    return interpolation_error(node, graph[node.inputs[0]].qformat) / scale
