"""Error budget (pendc.passes.error_budget): bit-accurate vs float, widening, table growth."""

import json

import numpy as np
import pytest

import pendc
from pendc.errors import PendcError
from pendc.ir.graph import Graph
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat
from pendc.ir.verify import verify
from pendc.passes.error_budget import (MAX_WIDEN, WIDEN_STEP, check_stimuli, compare_fixed_float, complete_report,
                                       float_twin, interpolation_error, meet_error_budget)
from pendc.caching.build_cache import compile_cached
from pendc.passes.pipeline import BuildOptions, compile_model
from pendc.passes.segmented_error import Decisions, compare_segmented
from pendc.sim.stimuli import Stimuli
from pendc.passes.qformats import assign_qformats
from pendc.passes.ranges import analyze_ranges
from pendc.passes.tabulate import fill_lut_tables, tabulate_luts
from plants import DEFAULT

DT = 1e-6
OPTIONS = BuildOptions(training_scale=0.02)
STATES = ("x", "dx", "theta", "dtheta")


@pytest.fixture(scope="module")
def build():
    return compile_cached(pendc.load_model(), OPTIONS)     # one short build for the pass tests (the build cache)


def typed_default(build, widen):
    tab = tabulate_luts(build.untyped, build.ranges, margin=OPTIONS.lut_margin, addr_bits=OPTIONS.lut_addr_bits)
    g = fill_lut_tables(assign_qformats(tab, build.ranges, width=OPTIONS.width, margin_bits=OPTIONS.margin_bits,
                                        widen=widen))
    verify(g, typed=True)
    return g


# -- the report of a short build -----------------------------------------------------------------

def test_report_is_within_budget_when_met(build):
    rep = build.error
    assert rep is not None and rep.met
    assert rep.budgets == pendc.load_model().interface.budgets() == {"x": 2.5e-6 / 2, "theta": 3.14e-4 / 2}
    assert rep.seconds == pytest.approx(min(OPTIONS.check_seconds, 5.0 * OPTIONS.training_scale))
    assert set(rep.errors) == set(rep.plain) == set(rep.restarts) == {"chirp", "swing_up", "steps"}
    for stim, errs in rep.errors.items():
        assert set(errs) == set(STATES)
        for s, budget in rep.budgets.items():
            assert 0 <= errs[s] <= budget, (stim, s)
    # the check run really exercised the fixed-point model
    assert rep.errors["swing_up"]["theta"] > 0 and rep.errors["swing_up"]["x"] > 0
    assert set(rep.addr_bits) == {n.name for n in build.graph.of_kind(Kind.LUT)}
    assert json.loads(json.dumps(rep.to_json()))["met"] is True


def test_report_errors_are_reproducible(build):
    rep = build.error
    stimuli = check_stimuli(DEFAULT.interface.input, rep.seconds)
    errors, node_errors = compare_fixed_float(build.graph, stimuli, DT)
    assert errors == rep.plain
    assert node_errors == rep.node_errors
    runs = compare_segmented(build.graph, stimuli, DT)
    assert {k: r.segmented for k, r in runs.items()} == rep.errors
    assert {k: r.restarts for k, r in runs.items()} == rep.restarts
    assert {k: r.plain for k, r in runs.items()} == errors      # its plain run is the plain comparison
    for s in STATES:                   # the sampled node errors include the states
        assert node_errors[s] <= max(e[s] for e in errors.values()) + 1e-300
    assert not [n for n in node_errors if build.graph[n].kind is Kind.CONST]


def test_rounds_share_float_runs_without_changing_a_number(build):
    """A widening round's float twin is the first round's (the same kernel, tables and resets):
    with ``float_runs`` kept across the two calls it runs once per stimulus and sampling, and
    every error equals the one computed without it."""
    stimuli = check_stimuli(DEFAULT.interface.input, build.error.seconds)
    base = typed_default(build, {})
    wide = typed_default(build, {s: WIDEN_STEP for s in STATES})
    memo = {}
    shared = [compare_fixed_float(g, stimuli, DT, float_runs=memo) for g in (base, wide)]
    assert len(memo) == 2 * len(stimuli)            # per stimulus: every step, and every 1000th
    assert shared == [compare_fixed_float(g, stimuli, DT) for g in (base, wide)]


def test_a_met_answer_completed_is_the_full_report(build):
    """What the narrowing keeps of its last check (pendc.passes.narrow_products): the answer-only
    report of a met budget with the node and plain errors added equals the full report of the same
    typing, every number; an answer that missed its budget is not completed (its runs stopped)."""
    def typed(widen, addr):
        return typed_default(build, widen)

    # budgets the first typing meets (the build's own needed a widening), then ones it misses
    budgets, seconds = {s: 1e3 * b for s, b in build.error.budgets.items()}, build.error.seconds
    graph, full = meet_error_budget(typed, budgets, DT, seconds, max_rounds=1)
    answer = meet_error_budget(typed, budgets, DT, seconds, max_rounds=1, full_report=False)[1]
    assert full.met and answer.node_errors is None and answer.plain is None
    assert complete_report(graph, answer, DT) == full
    missed = meet_error_budget(typed, {s: b / 1e9 for s, b in budgets.items()}, DT, seconds, max_rounds=1,
                               full_report=False)[1]
    with pytest.raises(ValueError):
        complete_report(graph, missed, DT)


def test_widening_reduces_the_state_error(build):
    stimuli = check_stimuli(DEFAULT.interface.input, build.error.seconds)
    from pendc.passes.qformats import increment_guard_bits
    base = typed_default(build, {})
    wide = typed_default(build, {s: WIDEN_STEP for s in STATES})
    tab = tabulate_luts(build.untyped, build.ranges, margin=OPTIONS.lut_margin, addr_bits=OPTIONS.lut_addr_bits)
    guards = increment_guard_bits(tab, build.ranges, OPTIONS.width, OPTIONS.margin_bits)
    for s in STATES:            # widening counts from the rule; a state's guard bits are a floor under it
        floor = guards.get(s, 0)
        assert wide[s].qformat.frac == base[s].qformat.frac + max(WIDEN_STEP, floor) - floor
    e0, _ = compare_fixed_float(base, stimuli, DT)
    e1, _ = compare_fixed_float(wide, stimuli, DT)
    worst0 = {s: max(e[s] for e in e0.values()) for s in STATES}
    worst1 = {s: max(e[s] for e in e1.values()) for s in STATES}
    assert worst1["x"] < worst0["x"] / 2
    for s in STATES:               # never noticeably worse anywhere
        for stim in e0:
            assert e1[stim][s] <= e0[stim][s] * 1.25 + 1e-15, (stim, s)


def test_too_small_range_override_names_the_node():
    opts = BuildOptions(training_scale=OPTIONS.training_scale, ranges={"ddx": 1e-3})
    with pytest.raises(PendcError, match="'ddx'"):
        compile_model(pendc.load_model(), opts)


# -- interpolation error --------------------------------------------------------------------------

def _lut(addr_bits):
    nodes = [make("a", Kind.INPUT, port="u", qformat=QFormat.parse("FIX32_28")),
             make("y", Kind.LUT, ["a"], qformat=QFormat.parse("FIX32_30"), expr="sin(3*v)", lo=-2.0, hi=2.0,
                  periodic=False, addr_bits=addr_bits, interpolate=True, fmax=1.0)]
    return fill_lut_tables(Graph.build("t", nodes, [("y", "y")]))


def test_interpolation_error_quarters_per_address_bit():
    fin = QFormat.parse("FIX32_28")
    errs = [interpolation_error(_lut(a)["y"], fin) for a in (6, 7, 8)]
    h = (1 << _lut(6)["y"].param("shift")) * fin.lsb
    assert errs[0] == pytest.approx(h * h / 8 * 9, rel=0.05)     # h^2/8 * max|f''|, f'' = -9 sin(3v)
    assert errs[1] / errs[0] == pytest.approx(0.25, rel=0.05)
    assert errs[2] / errs[1] == pytest.approx(0.25, rel=0.05)


# -- the budget loop on a toy plant ---------------------------------------------------------------

def toy_graph():
    """Four integrators fed through a deliberately coarse table of the input voltage."""
    n = [make("u", Kind.INPUT, port="u", max_abs=10.0),
         make("y", Kind.LUT, ["u"], expr="sin(v)", lo=None, hi=None, periodic=False, addr_bits=4,
              interpolate=True)]
    for s, src, gain in (("dx", "y", 1e-3), ("x", "dx", 1e-3), ("dtheta", "y", 1e-2), ("theta", "dtheta", 1e-3)):
        n += [make(s, Kind.REGISTER, [f"{s}_sum"], reset=0.0), make(f"{s}_inc", Kind.GAIN, [src], value=gain),
              make(f"{s}_sum", Kind.ADD, [s, f"{s}_inc"])]
    return Graph.build("toy", n, [(s, s) for s in STATES])


@pytest.fixture(scope="module")
def toy():
    seconds = 0.01
    g = toy_graph()
    verify(g)
    ranges = analyze_ranges(g, check_stimuli(DEFAULT.interface.input, seconds), DT)
    tab = tabulate_luts(g, ranges)
    calls = []

    def typed(widen, addr):
        calls.append((widen, addr))
        t = tab.map_nodes(lambda nd: nd.with_params(addr_bits=addr[nd.name]) if nd.name in addr else nd)
        t = tabulate_luts(t, ranges) if addr else t
        t = fill_lut_tables(assign_qformats(t, ranges, widen=widen))
        verify(t, typed=True)
        return t

    return typed, calls, seconds


def test_budget_loop_widens_then_grows_tables(toy):
    typed, calls, seconds = toy
    calls.clear()
    graph, rep = meet_error_budget(typed, {"x": 0.0, "theta": 0.0}, DT, seconds, max_rounds=5,
                                   inp=DEFAULT.interface.input)
    rounds = MAX_WIDEN // WIDEN_STEP
    assert [c[0].get("x", 0) for c in calls] == [WIDEN_STEP * k for k in range(rounds + 1)] + [MAX_WIDEN]
    assert calls[-1][1] == {"y": 5}
    assert not rep.met
    assert rep.widened == {s: MAX_WIDEN for s in STATES}
    assert rep.addr_bits == {"y": 5} == {"y": graph["y"].param("addr_bits")}
    assert len(rep.actions) == 5
    assert all("fraction bits" in a for a in rep.actions[:rounds])
    assert all("address bit for y" in a for a in rep.actions[rounds:])
    assert graph["x"].qformat.width == 32 + MAX_WIDEN


def test_budget_loop_stops_when_met(toy):
    typed, calls, seconds = toy
    calls.clear()
    graph, rep = meet_error_budget(typed, {"x": 1e3, "theta": 1e3}, DT, seconds, inp=DEFAULT.interface.input)
    assert rep.met and rep.actions == () and rep.widened == {}
    assert calls == [({}, {})]
    for errs in rep.errors.values():
        assert all(np.isfinite(v) for v in errs.values())


def test_budget_loop_widens_products_after_accumulators():
    """Fitted to 18x18 blocks, an unmeetable budget first widens the accumulators, then raises
    product levels (the least accurate products first), never beyond the top level."""
    seconds = 0.01
    g = toy_graph()
    ranges = analyze_ranges(g, check_stimuli(DEFAULT.interface.input, seconds), DT)
    tab = tabulate_luts(g, ranges)
    products = ("dx_inc", "x_inc", "dtheta_inc", "theta_inc", "y")
    seen = []

    def typed(widen, addr, levels):
        seen.append(dict(levels))
        t = fill_lut_tables(assign_qformats(tab, ranges, widen=widen, shape=(18, 18), levels=levels))
        verify(t, typed=True)
        return t

    rounds = MAX_WIDEN // WIDEN_STEP
    graph, rep = meet_error_budget(typed, {"x": 0.0, "theta": 0.0}, DT, seconds, max_rounds=rounds + 3,
                                   products=products, max_level=2, inp=DEFAULT.interface.input)
    assert not rep.met
    assert all(all(v == 0 for v in s.values()) for s in seen[:rounds + 1])
    assert any("wider multiplier operands" in a for a in rep.actions[rounds:])
    assert set(rep.levels) == set(products) and max(rep.levels.values()) >= 1
    assert all(0 <= v <= 2 for v in rep.levels.values())
    assert sum(rep.levels.values()) == sum(seen[-1].values())


def test_rounds_that_stop_at_the_first_state_over_change_nothing_they_decide(monkeypatch):
    """A round that a remedy follows stops once a state is over its budget: run to their ends
    instead, the same rounds give the same graph, levels and remedies (the actions may then name
    more states over than the ones found before the runs stopped)."""
    import pendc.passes.error_budget as eb

    seconds, g, products = 0.01, toy_graph(), ("dx_inc", "x_inc", "dtheta_inc", "theta_inc", "y")
    ranges = analyze_ranges(g, check_stimuli(DEFAULT.interface.input, seconds), DT)
    tab = tabulate_luts(g, ranges)
    budgets = {"x": 0.0, "theta": 1.0}           # x unmeetable: every round but the last has a remedy to follow
    rounds = MAX_WIDEN // WIDEN_STEP + 3
    compare, calls = eb.compare_segmented, []

    def typed(widen, addr, levels):
        return fill_lut_tables(assign_qformats(tab, ranges, widen=widen, shape=(18, 18), levels=levels))

    def recorded(to_the_end):
        def comparison(graph, stimuli, dt, **kw):
            limits = kw.pop("stop_above", None)
            runs = compare(graph, stimuli, dt, **kw, stop_above=None if to_the_end else limits)
            calls.append((to_the_end, limits, any(r.stopped_at for r in runs.values())))
            return runs
        return comparison

    loops = {}
    for to_the_end in (False, True):
        monkeypatch.setattr(eb, "compare_segmented", recorded(to_the_end))
        loops[to_the_end] = meet_error_budget(typed, budgets, DT, seconds, max_rounds=rounds, products=products,
                                              max_level=2, inp=DEFAULT.interface.input)
    assert [limits for _, limits, _ in calls] == 2 * ([budgets] * (rounds - 1) + [None])
    assert all(stopped for to_the_end, limits, stopped in calls if limits and not to_the_end)
    (stopped_graph, stopped), (whole_graph, whole) = loops[False], loops[True]
    assert stopped_graph == whole_graph and (stopped.levels, stopped.widened) == (whole.levels, whole.widened)
    assert [a.split(" over budget: ")[1] for a in stopped.actions] == [a.split(" over budget: ")[1] for a in whole.actions]
    assert stopped.errors == whole.errors        # the last round runs to its end in both


def test_float_twin_is_the_graph_without_casts_whatever_the_levels():
    """The float twin of rounds that differ in their operand CASTs is one kernel source while the
    same inputs are narrowed (a narrowed input brings its error feedback: a level that stops
    narrowing it drops exactly those nodes), and it computes every node's value exactly as the
    graph with its CASTs does (the fed-back residue is zero in real numbers)."""
    from pendc.ir.compiled import CompiledGraph
    from pendc.ir.kernel_module import kernel_source
    from pendc.passes.ranges import per_step
    seconds = 0.01
    g = toy_graph()
    ranges = analyze_ranges(g, check_stimuli(DEFAULT.interface.input, seconds), DT)
    tab = tabulate_luts(g, ranges)
    products = ("dx_inc", "x_inc", "dtheta_inc", "theta_inc", "y")
    graphs = [fill_lut_tables(assign_qformats(tab, ranges, widen=widen, shape=(18, 18),
                                              levels={p: level for p in products}))
              for widen, level in (({}, 0), ({s: MAX_WIDEN for s in STATES}, 0), ({s: MAX_WIDEN for s in STATES}, 1),
                                   ({s: MAX_WIDEN for s in STATES}, 2))]
    casts = [{n.name for n in x.of_kind(Kind.CAST)} for x in graphs]
    assert casts[0] != casts[1] or casts[1] != casts[2]          # the rounds really differ in their CASTs
    twins = [float_twin(x) for x in graphs]
    assert len({kernel_source(t, "float")[0] for t, _ in twins[:3]}) == 1
    feedback = {n.name for n in twins[2][0].nodes} - {n.name for n in twins[3][0].nodes}
    assert {n.name for n in twins[3][0].nodes} < {n.name for n in twins[2][0].nodes}
    assert len(feedback) == 3 and all(f.startswith("u_m") for f in feedback)      # fed, res, res_next
    t, u = check_stimuli(DEFAULT.interface.input, seconds)["swing_up"]
    steps = {"u": per_step(np.asarray(u, float), np.asarray(t, float), DT)}
    for graph, (twin, alias) in zip(graphs, twins):
        assert set(alias) == {n.name for n in graph.of_kind(Kind.CAST)}
        names = tuple(n.name for n in graph.nodes)
        full = CompiledGraph(graph, "float").run(steps, every=7, record=names)
        kept = tuple(dict.fromkeys(alias.get(n, n) for n in names))
        short = CompiledGraph(twin, "float").run(steps, every=7, record=kept)
        for n in names:
            np.testing.assert_array_equal(short.outputs[alias.get(n, n)], full.outputs[n], err_msg=n)


# -- the segmented form and the held-out check (issue 23 item 3) ----------------------------------

def test_decisions_are_the_discontinuities_the_states_read(build):
    """The friction's branches are decisions; an absolute value, the velocity clamp and the turn
    counter's wrap are not (continuous, or bookkeeping that no state reads)."""
    d = Decisions(build.graph)
    assert "F_fric" in d.decisions and "F_fric_then_sgn_dx_sgn_signed" in d.decisions
    for continuous in ("abs_dx", "abs_F_in", "dx_upper", "dx_next", "theta_turn_step"):
        assert build.graph[continuous].kind is Kind.MUX and continuous not in d.decisions, continuous
    assert sorted(d.registers) == sorted(STATES + ("u_m18_res",))      # a restart loads the states and the residue
    assert d.guards["F_fric"] == frozenset({()})           # read by the states whatever is selected


def test_decisions_differ_where_every_choice_read_in_full_says(build):
    """The comparison reads only the decisions whose selects differ, and only the MUXes their
    verdicts read: the same steps as every choice of every MUX worked out (selects of both runs'
    types, beyond their inputs too)."""
    d = Decisions(build.graph)
    rng = np.random.default_rng(4)
    n = 400

    def in_full(fixed, flt):
        def choices(sel):
            return {m: np.minimum(sel[build.graph[m].inputs[0]].astype(np.int64), len(build.graph[m].inputs) - 2)
                    for m in d.muxes}
        a, b, out = choices(fixed), choices(flt), np.zeros(n, bool)
        for m in d.decisions:
            out |= (a[m] != b[m]) & (d._live(a, m, n) | d._live(b, m, n))
        return out

    found = 0
    for trial in range(40):
        fixed = {s: rng.integers(0, 4, n) for s in d.selects}
        flt = {s: v.astype(float) for s, v in fixed.items()}
        for s in rng.choice(d.selects, size=trial % 4, replace=False):   # a few selects part, at a few steps
            steps = rng.integers(0, n, 3)
            flt[s][steps] = rng.integers(0, 4, 3)
        got = d.differ(fixed, flt, n)
        assert np.array_equal(got, in_full(fixed, flt)), trial
        found += int(got.any())
    assert found >= 10


def test_segmented_run_is_the_plain_one_until_a_decision_differs(build):
    """Held levels that reverse the cart: the fixed run restarts where a friction decision first
    differs, and up to that step the segmented error is the plain one."""
    on = Stimuli(DEFAULT.interface.input)
    t, u = on.steps(duration=0.1, levels=(1.2, -1.2, 0.9, -0.9))
    run = compare_segmented(build.graph, {"s": (t, u)}, DT)["s"]
    assert run.restarts >= 1 and run.restart_steps[0] > 0
    cut = run.restart_steps[0] // 1000                          # whole input samples (1 ms) before it
    early = compare_segmented(build.graph, {"s": (t[:cut + 1], u[:cut + 1])}, DT)["s"]
    assert early.restarts == 0 and early.segmented == early.plain


def test_a_run_stops_once_a_state_is_over_the_limit_it_is_given(build):
    """``stop_above``: a limit no run reaches changes nothing; one a run passes ends the runs
    there, the worst error over the limit and none larger than the whole run's."""
    stimuli = check_stimuli(DEFAULT.interface.input, build.error.seconds)
    whole = compare_segmented(build.graph, stimuli, DT, plain=False)
    assert compare_segmented(build.graph, stimuli, DT, plain=False, stop_above={"x": 1.0, "theta": 1.0}) == whole
    limit = {"theta": whole["swing_up"].segmented["theta"] / 4}
    stopped = compare_segmented(build.graph, stimuli, DT, plain=False, stop_above=limit)
    assert all(r.stopped_at is None for r in whole.values())
    # the others stop with the first, unless they ended before it passed (the runs are threads)
    assert any(r.stopped_at for r in stopped.values())
    assert all(r.stopped_at is None or 0 < r.stopped_at < r.steps for r in stopped.values())
    assert limit["theta"] < max(r.segmented["theta"] for r in stopped.values()) <= whole["swing_up"].segmented["theta"]
    for name, r in stopped.items():
        assert all(r.segmented[s] <= whole[name].segmented[s] for s in STATES), name


def test_a_held_input_feeds_its_rounding_back(build):
    """The 18-bit input operand of the drive force rounds a held input differently step by step,
    so that its values average to the input (a single rounding is off by up to 2**-13 V)."""
    from pendc.ir.compiled import CompiledGraph, quantize
    g = build.graph
    cast = next(n for n in g.of_kind(Kind.CAST) if g[n.inputs[0]].kind is Kind.ADD
                and g[g[n.inputs[0]].inputs[0]].kind is Kind.INPUT)
    assert g[f"{cast.name}_res"].kind is Kind.REGISTER
    volts = 6.0646
    ins = quantize(np.full(4096, volts), g["u"].qformat)
    seen = CompiledGraph(g).run({"u": ins}, record=(cast.name,)).outputs[cast.name] * cast.qformat.lsb
    assert abs(np.round(volts / cast.qformat.lsb) * cast.qformat.lsb - volts) > cast.qformat.lsb / 4
    assert abs(seen.mean() - volts) < cast.qformat.lsb / 1000
