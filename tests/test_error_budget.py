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
from pendc.passes.error_budget import (MAX_WIDEN, WIDEN_STEP, check_stimuli, compare_fixed_float, float_twin,
                                       interpolation_error, meet_error_budget)
from pendc.passes.pipeline import BuildOptions, compile_model
from pendc.passes.qformats import assign_qformats
from pendc.passes.ranges import analyze_ranges
from pendc.passes.tabulate import fill_lut_tables, tabulate_luts
from plants import DEFAULT

DT = 1e-6
OPTIONS = BuildOptions(training_scale=0.02)
STATES = ("x", "dx", "theta", "dtheta")


@pytest.fixture(scope="module")
def build():
    return compile_model(pendc.load_model(), OPTIONS)


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
    assert set(rep.errors) == {"chirp", "swing_up"}
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
    errors, node_errors = compare_fixed_float(build.graph, check_stimuli(DEFAULT.interface.input, rep.seconds), DT)
    assert errors == rep.errors
    assert node_errors == rep.node_errors
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


def test_widening_reduces_the_state_error(build):
    stimuli = check_stimuli(DEFAULT.interface.input, build.error.seconds)
    base = typed_default(build, {})
    wide = typed_default(build, {s: WIDEN_STEP for s in STATES})
    for s in STATES:
        assert wide[s].qformat.frac == base[s].qformat.frac + WIDEN_STEP
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


def test_float_twin_is_the_graph_without_casts_whatever_the_levels():
    """The float twin of rounds that differ in their operand CASTs is one kernel source, and it
    computes every node's value exactly as the graph with its CASTs does."""
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
              for widen, level in (({}, 0), ({s: MAX_WIDEN for s in STATES}, 0), ({s: MAX_WIDEN for s in STATES}, 2))]
    casts = [{n.name for n in x.of_kind(Kind.CAST)} for x in graphs]
    assert casts[0] != casts[1] or casts[1] != casts[2]          # the rounds really differ in their CASTs
    twins = [float_twin(x) for x in graphs]
    assert len({kernel_source(t, "float")[0] for t, _ in twins}) == 1
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
