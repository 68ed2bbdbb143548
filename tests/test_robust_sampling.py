"""pendc.robust.sampling: the sample plan, its designs and its default ranges."""

import numpy as np
import pytest

from pendc.errors import PendcError
from pendc.model.fit_uncertainty import FitUncertainty
from pendc.model.modelfile import load_model
from pendc.robust.sampling import (SamplePlan, default_ranges, parse_vary, plan_for, plan_from_dict,
                                   plan_to_dict)


@pytest.fixture(scope="module")
def rig():
    return load_model("models/sct_rig.toml")


def test_latin_hypercube_puts_one_run_in_each_stratum():
    plan = SamplePlan(nominal={"a": 1.0, "b": 2.0}, ranges=(("a", 0.0, 1.0), ("b", 10.0, 30.0)), count=50, seed=3)
    x = plan.design()
    assert x.shape == (50, 2)
    assert sorted(np.floor(x[:, 0] * 50).astype(int)) == list(range(50))
    assert sorted(np.floor((x[:, 1] - 10.0) / 20.0 * 50).astype(int)) == list(range(50))


def test_the_same_plan_gives_the_same_rows_and_another_seed_others():
    plan = SamplePlan(nominal={"a": 1.0}, ranges=(("a", 0.0, 1.0),), count=16, seed=1, method="sobol")
    assert np.array_equal(plan.design(), SamplePlan(**{**plan.__dict__}).design())
    assert plan.params_of(5) == {"a": float(plan.design()[5, 0])}
    other = SamplePlan(**{**plan.__dict__, "seed": 2})
    assert not np.array_equal(plan.design(), other.design())
    with pytest.raises(PendcError, match="run 16 is not in this sweep"):
        plan.params_of(16)


def test_a_fit_covariance_is_sampled_with_its_correlation(rig):
    cov = np.array([[4.0, 3.0], [3.0, 9.0]])
    fit = FitUncertainty(names=("alpha", "b_x"), mean=np.array([260.0, 880.0]), covariance=cov)
    plan = plan_for(rig, fit, [], "lhs", seed=0, count=4000)
    x = plan.design()
    assert np.allclose(x.mean(axis=0), [260.0, 880.0], atol=0.05)
    assert np.allclose(np.cov(x.T), cov, rtol=0.05)
    assert "the fit's covariance" in plan.origin
    # a --vary range replaces the fit's distribution of that parameter
    plan = plan_for(rig, fit, [("alpha", 250.0, 251.0)], "lhs", seed=0, count=10)
    assert plan.names == ("alpha", "b_x")
    assert plan.design()[:, 0].min() >= 250.0 and plan.design()[:, 0].max() <= 251.0


def test_draws_are_clipped_to_the_physical_bounds(rig):
    fit = FitUncertainty(names=("b_theta",), mean=np.array([0.001]), covariance=np.array([[0.01]]))
    x = plan_for(rig, fit, [], "lhs", seed=0, count=200).design()
    assert x.min() == 0.0 and x.max() > 0.001          # b_theta >= 0 (the catalogue's bound)


def test_the_default_ranges(rig):
    ranges = {n: (lo, hi) for n, lo, hi in default_ranges(rig)}
    assert ranges["g"] == (9.7, 9.9)                                   # +-5 % clipped to the declared bounds
    assert ranges["m"] == pytest.approx((0.581 * 0.95, 0.581 * 1.05))
    assert ranges["alpha"] == pytest.approx((260.78841 * 0.8, 260.78841 * 1.2))
    assert "v_stick" not in ranges                                     # 0: the exact zero test, held
    plan = plan_for(rig, None, [], "lhs", seed=0, count=5)
    assert plan.origin.startswith("default ranges") and "+-5%" in plan.origin


def test_bad_variations_are_one_line_errors(rig):
    with pytest.raises(PendcError, match="expected NAME=LO:HI"):
        parse_vary("alpha")
    with pytest.raises(PendcError, match="LO and HI must be numbers"):
        parse_vary("alpha=a:b")
    with pytest.raises(PendcError, match="needs finite LO < HI"):
        parse_vary("alpha=3:2")
    with pytest.raises(PendcError, match="--vary beta: not a parameter"):
        plan_for(rig, None, [("beta", 0.0, 1.0)], "lhs", 0, 5)
    with pytest.raises(PendcError, match="given twice"):
        plan_for(rig, None, [("alpha", 0.0, 1.0), ("alpha", 1.0, 2.0)], "lhs", 0, 5)
    with pytest.raises(PendcError, match="--samples must be at least 1"):
        plan_for(rig, None, [], "lhs", 0, 0)


def test_the_plan_survives_its_manifest(rig):
    fit = FitUncertainty(names=("b_x",), mean=np.array([880.0]), covariance=np.array([[25.0]]))
    plan = plan_for(rig, fit, [("alpha", 200.0, 300.0)], "sobol", seed=4, count=32)
    again = plan_from_dict(plan_to_dict(plan))
    assert again == plan and np.array_equal(again.design(), plan.design())
    held = plan.without({"alpha"}, "alpha held")
    assert held.names == ("b_x",) and held.origin.endswith("alpha held")


def test_nothing_to_vary_is_refused():
    from types import SimpleNamespace
    switches_only = SimpleNamespace(parameter_values=lambda: {"v_stick": 0.0},
                                    definition=SimpleNamespace(constants={}))
    with pytest.raises(PendcError, match="nothing to vary: .* give --vary NAME=LO:HI"):
        plan_for(switches_only, None, [], "lhs", 0, 5)
