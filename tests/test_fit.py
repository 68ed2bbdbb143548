"""Parameter fitting: recovery, bounds, the mu_s >= mu_c constraint, honest intervals."""

import numpy as np
import pytest

from pendc import load_model
from pendc.errors import PendcError
from pendc.ident.datagen import make_dataset
from pendc.ident.fit import fit_parameters, parameter_bounds
from pendc.sim.measurements import format_csv, parse_measurements


@pytest.fixture(scope="module")
def spring_data():
    true = load_model().with_effect("cart_spring", {"k_c": 300.0, "x_0": 0.05})
    return true, parse_measurements(format_csv(make_dataset(true)))


def test_recovers_a_hidden_spring_with_intervals_that_cover_it(spring_data):
    true, data = spring_data
    res = fit_parameters(load_model().with_effect("cart_spring"), [data], ["k_c", "x_0"])
    assert res.converged and res.cost_after < res.cost_before
    for p, v in (("k_c", 300.0), ("x_0", 0.05)):
        assert res.values[p] == pytest.approx(v, rel=0.1)
        lo, hi = res.ci95[p]
        assert lo < res.values[p] < hi and hi - lo < 0.2 * abs(v)
    assert res.model.effects["cart_spring"]["k_c"] == res.values["k_c"]


def test_static_friction_never_below_coulomb(spring_data):
    _, data = spring_data
    model = load_model()
    res = fit_parameters(model, [data], ["mu_c", "mu_s"], max_evaluations=30)
    assert res.values["mu_s"] >= res.values["mu_c"]   # Table 14 itself has mu_c > mu_s


def test_bounds_come_from_the_catalogue():
    assert parameter_bounds(load_model().with_effect("cart_spring"), "k_c") == (0.0, 1e6)


def test_nothing_to_fit(spring_data):
    with pytest.raises(PendcError, match="nothing to fit"):
        fit_parameters(load_model(), [spring_data[1]], [])
