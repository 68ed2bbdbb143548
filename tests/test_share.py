"""Selective multiplier sharing (pendc.passes.share, ``--preset thesis``) and narrowing products
back to one DSP block where the error budget allows (pendc.passes.narrow_products)."""

import shutil

import numpy as np
import pytest

from pendc.ir.compiled import CompiledGraph
from pendc.passes import narrow_products as narrow_mod
from pendc.passes.delays import ECP5_SPEED6, operand_mux_delay
from pendc.passes.error_budget import ErrorReport
from pendc.passes.resources import dsp_for, product_widths
from pendc.passes.schedule import PRESETS, schedule_for, schedule_graph
from pendc.passes.share import products_of, scheduled_blocks, share_to_budget
from quick_training import quick_copy
from test_schedule import SHAPE, STEPS, run_icarus, toy_plant


@pytest.fixture(scope="module")
def plant():
    return toy_plant({})


def _blocks(graph):
    return sum(dsp_for(*product_widths(graph, graph[p]), SHAPE) for p in products_of(graph))


def test_thesis_preset_shares_only_what_the_budget_needs(plant):
    """A budget two blocks short of a multiplier per product: two units of two products each (or
    one of three), every unit's products in different cycles, the others on their own blocks."""
    own = _blocks(plant)
    s = schedule_for(plant, SHAPE, preset="thesis", dsp=own - 2)
    assert s.preset == "thesis" and s.dsp_budget == own - 2
    assert scheduled_blocks(plant, s, SHAPE) <= own - 2
    served = [p for u in s.units for p, _ in u.uses]
    assert len(served) == len(set(served)) and 2 <= len(served) < len(products_of(plant))
    for u in s.units:
        assert len({c for _, c in u.uses}) == len(u.uses)
        assert all(c == s.stage[p] for p, c in u.uses)
        ws = [product_widths(plant, plant[p]) for p, _ in u.uses]
        assert u.widths == (max(w[0] for w in ws), max(w[1] for w in ws))
    # the shared schedule is never shorter than the unshared one at its goal (a mux only adds)
    plain = schedule_graph(plant, s.clock_ns, None, SHAPE, "thesis")
    assert s.estimated_step_ns >= plain.estimated_step_ns
    # a budget a multiplier per product already meets shares nothing
    assert not schedule_for(plant, SHAPE, preset="thesis", dsp=own).units
    assert PRESETS["thesis"][1] == 24


def test_share_prefers_groups_that_keep_the_step(plant):
    """With a goal that leaves room, the first units cost no estimated time; each product of a
    unit is charged its mux (the rescheduled step with the muxes is what is returned)."""
    goal = 25.0
    base = schedule_graph(plant, goal, None, SHAPE, "thesis")
    calls = []

    def again(muxed=None):
        calls.append(dict(muxed or {}))
        return schedule_graph(plant, goal, None, SHAPE, "thesis", muxed=muxed)

    shared, groups = share_to_budget(plant, base, _blocks(plant) - 1, SHAPE, again)
    assert len(groups) == 1 and len(groups[0]) == 2
    assert shared.estimated_step_ns == base.estimated_step_ns
    mux = operand_mux_delay(ECP5_SPEED6, 2)
    assert any(m == {p: mux for p in groups[0]} for m in calls)


@pytest.mark.skipif(shutil.which("iverilog") is None, reason="Icarus Verilog not installed")
def test_selectively_shared_schedule_is_bit_exact_in_icarus(plant, tmp_path):
    s = schedule_for(plant, SHAPE, preset="thesis", dsp=_blocks(plant) - 2)
    assert s.units
    view, ints, hw = run_icarus(plant, s, tmp_path / "hdl")
    gold = CompiledGraph(plant, "fixed").run({"u": ints})
    expect = np.stack([gold.outputs[p][1:] for p in ("x", "dx", "theta", "dtheta")], axis=1)
    assert hw.shape == (STEPS, 5) and np.abs(expect).max() > 1000
    np.testing.assert_array_equal(hw[:-1, :4], expect)


def _report(met, levels=None):
    return ErrorReport(budgets={"x": 1.0}, errors={}, node_errors={}, widened={"x": 8}, addr_bits={},
                       actions=("budget",), met=met, seconds=0.1, levels=levels)


def test_narrowing_finds_the_products_the_budget_needs(plant, monkeypatch):
    """Group testing: every two-block product the budget raised goes back to level 0 except the
    ones whose narrowing misses the budget, found with far fewer checks than one per product."""
    wide = toy_plant({"y": 1, "p": 1, "dx_inc": 1, "x_inc": 1, "theta_inc": 1})
    raised = sorted(p for p in products_of(wide) if dsp_for(*product_widths(wide, wide[p]), SHAPE) > 1)
    assert len(raised) >= 4
    needed = {raised[1]}
    validated = {raised[-1]}        # held on the check stimuli, misses on the validation inputs
    checks, asked, valid_checks = [], [], []

    def typed(widen, addr, levels):
        assert widen == {"x": 8}
        asked.append(levels)
        return toy_plant({p: lv for p, lv in levels.items() if lv})

    def fake_budget(at, budgets, dt, seconds, **kw):
        g = at({}, {})
        lowered = {p for p, lv in asked[-1].items() if lv == 0}
        checks.append(lowered)
        return g, _report(not (lowered & needed))

    def fake_validation(graph, budgets, dt, seconds):
        lowered = {p for p, lv in asked[-1].items() if lv == 0}
        valid_checks.append(lowered)
        return {"x": 2.0 if lowered & validated else 0.5}

    completed = []

    def fake_complete(graph, answer, dt, engine="compiled"):
        completed.append((graph, answer))
        return answer

    monkeypatch.setattr(narrow_mod, "meet_error_budget", fake_budget)
    monkeypatch.setattr(narrow_mod, "validation_errors", fake_validation)
    monkeypatch.setattr(narrow_mod, "complete_report", fake_complete)
    report = _report(True, {p: 1 for p in raised})
    graph, out = narrow_mod.narrow_products(typed, wide, report, {"x": 1.0}, 1e-6, 0.1, SHAPE)
    # the kept set's own check is the report, completed once: no budget run after the search
    assert len(completed) == 1 and completed[0][0] is graph and completed[0][1].met
    assert out.levels == {p: (1 if p in needed | validated else 0) for p in raised}
    assert out.actions[0] == "budget" and "one DSP block" in out.actions[-1] and out.widened == {"x": 8}
    assert "validation inputs (worst x 0.5)" in out.actions[-1]
    assert _blocks(graph) < _blocks(wide)
    assert len(checks) < 2 * len(raised)
    # the validation inputs run only where the check stimuli held
    assert valid_checks and all(not (c & needed) for c in valid_checks)
    # a budget that needs every wide product: nothing changes
    needed = set(raised)
    same, kept = narrow_mod.narrow_products(typed, wide, report, {"x": 1.0}, 1e-6, 0.1, SHAPE)
    assert same is wide and kept is report


def test_thesis_build_meets_its_dsp_budget(tmp_path):
    """``pendc build --preset thesis`` on the default model (shortened training): the short chain,
    the error budget met, its DSP blocks within the thesis' 24, counted with the products that
    keep their own multiplier, and units of products in different cycles."""
    import json

    from pendc.cli import main
    from pendc.model.modelfile import default_model_path
    model = tmp_path / "quick.toml"
    quick_copy(default_model_path(), model)
    assert main(["build", "--model", str(model), "-o", str(tmp_path / "t"), "--preset", "thesis"]) == 0
    report = json.loads((tmp_path / "t" / "report.json").read_text())
    s = report["schedule"]
    assert s["preset"] == "thesis" and s["clock_goal_ns"] <= PRESETS["thesis"][0]
    r = report["resources"]
    assert (r["dsp_scheduled"] if s["units"] else r["dsp"]) <= 24
    assert not s["units"] or r["dsp"] > 24              # units only where one multiplier per product is over
    assert "ddx" not in report["qformats"]          # the short chain: dt folded into the tables
    for u in s["units"]:
        assert len({c for _, c in u["uses"]}) == len(u["uses"])
