"""pendc.robust.scenario_runner: one run, one row; a failure of any kind is a row, never a raise."""

import pytest

from pendc.errors import PendcError
from pendc.model.model_writer import dumps_model
from pendc.model.modelfile import load_model
from pendc.robust.scenario_runner import (FIGURES, SweepSpec, WorkerCache, check_spec, run_alone, run_row,
                                          worker_cache)


@pytest.fixture(scope="module")
def spec():
    text = dumps_model(load_model("models/sct_rig.toml"))
    return SweepSpec(model_text=text, design_text=text, model_source="rig", design_source="rig", seconds=6.0)


def test_the_nominal_plant_passes_and_a_weak_drive_fails(spec):
    cache = WorkerCache()
    row = run_row(spec, 3, {"alpha": 260.78841}, cache)
    assert row["index"] == 3 and row["alpha"] == 260.78841 and row["passed"] and row["error"] == ""
    assert set(FIGURES) <= set(row) and row["settle_s"] == row["upright_at_s"] < 3.0
    assert row["max_abs_x_m"] < 0.3 and row["worst_last_3s_rad"] < 0.05
    assert row["travel_ratio"] == pytest.approx(row["max_abs_x_m"] / 0.3) and row["max_abs_theta_rad"] > 3.0
    weak = run_row(spec, 4, {"alpha": 150.0}, cache)   # the swing-up cannot pump enough energy in 6 s
    assert not weak["passed"] and "in the last 3 s" in weak["failures"] and weak["error"] == ""


def test_the_controller_is_designed_on_the_design_model(spec):
    """Designed on Table 3 (a drive five times weaker), run on the rig: it throws the pendulum up
    sooner than the matched design (docs/hil.md's mismatch)."""
    design = dumps_model(load_model("models/sct_thesis_initial.toml"))
    mismatched = SweepSpec(**{**spec.__dict__, "design_text": design, "design_source": "table3"})
    matched = run_row(spec, 0, {"b_x": 877.31327}, WorkerCache())
    hot = run_row(mismatched, 0, {"b_x": 877.31327}, WorkerCache())
    assert hot["upright_at_s"] < matched["upright_at_s"]


def test_a_run_that_raises_is_a_row_with_its_message(spec):
    bad = SweepSpec(**{**spec.__dict__, "controller": "no_such_module:Controller"})
    row = run_row(bad, 1, {"alpha": 260.0}, WorkerCache())
    assert row["passed"] is False and row["upright_at_s"] is None
    assert row["error"] == "PendcError: --controller no_such_module:Controller: no module named 'no_such_module'"
    with pytest.raises(PendcError, match="no module named"):
        run_alone(bad, {"alpha": 260.0})


def test_a_user_controller_is_judged_by_the_same_criterion(spec):
    row = run_row(SweepSpec(**{**spec.__dict__, "controller": "hold"}), 0, {"alpha": 260.0}, WorkerCache())
    assert not row["passed"] and "|theta - pi| reached" in row["failures"]


def test_check_spec(spec):
    with pytest.raises(PendcError, match="unknown scenario"):
        check_spec(SweepSpec(**{**spec.__dict__, "scenario": "fly"}))
    with pytest.raises(PendcError, match="a sweep runs on float or golden"):
        check_spec(SweepSpec(**{**spec.__dict__, "plant": "icarus"}))
    with pytest.raises(PendcError, match="runs with --scenario swing_up_balance"):
        check_spec(SweepSpec(**{**spec.__dict__, "scenario": "balance_step", "controller": "lqr"}))


def test_check_spec_refuses_a_plant_without_a_pendulum():
    """Each scenario judges a pendulum by the builtin controllers' constants, whatever controller
    runs: a converter is refused once, naming pendc hil at its operating point instead."""
    from test_hardware_dt import RC
    from pendc.model.modelfile import parse_model

    text = dumps_model(parse_model(RC))
    spec = SweepSpec(model_text=text, design_text=text, model_source="rc.toml", design_source="rc.toml")
    for controller in ("builtin", "lqr", "hold", "my_pkg.ctrl:Mine"):
        with pytest.raises(PendcError, match="judge a pendulum, whatever --controller runs, and plant 'rc'") as exc:
            check_spec(SweepSpec(**{**spec.__dict__, "controller": controller}))
        assert "pendc hil --model rc.toml --controller lqr --start half" in str(exc.value)


def test_outside_a_worker_each_call_gets_a_fresh_cache():
    assert worker_cache() is not worker_cache()


def test_the_fingerprint_changes_with_what_a_run_depends_on(spec):
    assert spec.fingerprint == SweepSpec(**spec.__dict__).fingerprint
    assert spec.fingerprint != SweepSpec(**{**spec.__dict__, "seconds": 7.0}).fingerprint
