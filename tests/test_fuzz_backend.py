"""Differential fuzzing of the Verilog backend, quick profile (issue 11, point 1).

200 random typed graphs (tests/graphgen.py, a fixed hypothesis seed) are emitted as one
Icarus build and checked against the reference interpreter at every step (the first graphs
also against the compiled golden kernel), and a subset as one Verilator build with steps
back to back. The generator steers around nothing (the cases the backend once got wrong come
up again: see the coverage test). ``make fuzz`` (bench/fuzz.py) runs the long profile.
"""

from __future__ import annotations

import pytest

from fuzzharness import check_batch, every_adder_subtracts, simulator_available
from fuzzcases import draw_cases

QUICK_SEED = 20261123
QUICK_GRAPHS = 200
GOLDEN_GRAPHS = 16          # numba compiles ~1 s per graph on a cold cache (cached on disk after)
VERILATOR_GRAPHS = 25


@pytest.fixture(scope="module")
def cases():
    return draw_cases(QUICK_GRAPHS, QUICK_SEED)


def _report(result) -> str:
    return "\n".join(str(m) for m in result.mismatches[:20])


def test_the_quick_profile_covers_every_node_kind(cases):
    from pendc.ir.nodes import Kind
    kinds = {n.kind for c in cases for n in c.graph.nodes}
    assert kinds == set(Kind)
    assert len(cases) == QUICK_GRAPHS
    assert any(not n.qformat.signed for c in cases for n in c.graph.nodes if n.kind is not Kind.REGISTER)
    assert any(n.qformat.width > 32 for c in cases for n in c.graph.nodes)
    assert any(n.param("periodic") for c in cases for n in c.graph.of_kind(Kind.LUT))
    assert any(n.param("interpolate") for c in cases for n in c.graph.of_kind(Kind.LUT))


def test_the_quick_profile_generates_the_cases_the_backend_once_got_wrong(cases):
    """Nothing is steered around: every defect of tests/test_fuzz_regressions.py has its kind of
    case in the profile, several times."""
    from pendc.ir.fsm import threshold_int
    from pendc.ir.nodes import Kind

    def count(test):
        return sum(1 for c in cases for n in c.graph.nodes if test(c.graph, n))

    def fin(g, n, k=0):
        return g[n.inputs[k]].qformat

    arith = (Kind.ADD, Kind.SUB, Kind.NEG, Kind.MUL, Kind.GAIN, Kind.CAST)
    assert count(lambda g, n: n.kind in arith and not all(g[i].qformat.signed for i in n.inputs)) >= 20
    assert count(lambda g, n: n.kind is Kind.MUX and not all(g[i].qformat.signed for i in n.inputs[1:])) >= 3
    assert count(lambda g, n: n.kind is Kind.LUT and not fin(g, n).signed) >= 3
    assert count(lambda g, n: n.kind is Kind.SLICE and fin(g, n).width == 1) >= 3
    # a clamped table whose index (input bits + 1 - grid shift) is no wider than its address
    assert count(lambda g, n: n.kind is Kind.LUT and not n.param("periodic")
                 and n.param("addr_bits") >= fin(g, n).width + 1 - n.param("shift")) >= 3

    def beyond(g, n):
        f = fin(g, n)
        ts = [t[2] for t in n.param("transitions")] + [n.param("lo"), n.param("hi")]
        return any(not f.min_int <= threshold_int(t, f) <= f.max_int for t in ts)
    assert count(lambda g, n: n.kind is Kind.FSM and beyond(g, n)) >= 3
    assert count(lambda g, n: n.kind is Kind.MUX and len(n.inputs) - 1 < 1 << fin(g, n).width) >= 3
    # names extending one another, as the backend's helper wires extend a node's name
    assert sum(1 for c in cases if any(a != b and b.startswith(a + "_") and not a.startswith("p_") and b != a + "_next"
                                       for a in (n.name for n in c.graph.nodes)
                                       for b in (n.name for n in c.graph.nodes))) >= 20


@pytest.mark.skipif(not simulator_available("icarus"), reason="iverilog not installed")
def test_icarus_matches_interpreter_and_golden_kernel(cases, tmp_path):
    """Every graph of the profile, with an idle cycle after every step."""
    result = check_batch(cases, tmp_path / "icarus", "icarus", frame_extra=1, golden=GOLDEN_GRAPHS)
    assert result.golden_checked == GOLDEN_GRAPHS
    assert not result.mismatches, _report(result)


@pytest.mark.skipif(not simulator_available("verilator"), reason="verilator not installed")
def test_verilator_matches_interpreter(cases, tmp_path):
    """A subset (the C++ build costs 1-3 s per graph on busy cores), steps back to back."""
    result = check_batch(cases[:VERILATOR_GRAPHS], tmp_path / "verilator", "verilator", golden=0)
    assert not result.mismatches, _report(result)


@pytest.mark.skipif(not simulator_available("icarus"), reason="iverilog not installed")
def test_the_harness_catches_a_miscompiled_adder(cases, tmp_path):
    """A planted bug (every adder subtracts) must show up as mismatches, or a pass means nothing."""
    adders = [c for c in cases if any(n.kind.name == "ADD" for n in c.graph.nodes)][:10]
    result = check_batch(adders, tmp_path / "planted", "icarus", golden=0, mutate=every_adder_subtracts)
    assert {m.case for m in result.mismatches} and all(m.engine == "icarus" for m in result.mismatches)

