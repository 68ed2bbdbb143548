"""Parameter fitting: bounds, the mu_s >= mu_c constraint, nothing to fit. Recovery of a hidden
spring with intervals that cover it: tests/test_cli_ident.py (``pendc fit`` of the shipped data)."""

from pathlib import Path

import pytest

from pendc import load_model
from pendc.errors import PendcError
from pendc.ident.fit import fit_parameters, parameter_bounds
from pendc.sim.measurements import read_measurements

DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.fixture(scope="module")
def spring_data():
    """data/hidden_spring.csv: the default model with a cart spring (k_c 300 N/m, x_0 0.05 m), as
    the independent generator makes it (tests/test_datagen.py). Its fit by ``pendc fit``, with the
    values and intervals checked against the truth, is tests/test_cli_ident.py's spring_fit."""
    return read_measurements(DATA / "hidden_spring.csv")


def test_static_friction_never_below_coulomb(spring_data):
    model = load_model()
    res = fit_parameters(model, [spring_data], ["mu_c", "mu_s"], max_evaluations=30)
    assert res.values["mu_s"] >= res.values["mu_c"]   # Table 14 itself has mu_c > mu_s


def test_bounds_come_from_the_catalogue():
    assert parameter_bounds(load_model().with_effect("cart_spring"), "k_c") == (0.0, 1e6)


def test_nothing_to_fit(spring_data):
    with pytest.raises(PendcError, match="nothing to fit"):
        fit_parameters(load_model(), [spring_data], [])
