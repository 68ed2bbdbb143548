"""pendc.hil.controllers.numeric_model: the scalar form gives NumPy's printer's values exactly."""

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from pendc.hil.controllers.numeric_model import NumericModel, scalar_function
from pendc.model.modelfile import load_model

MODELS = sorted((Path(__file__).resolve().parents[1] / "models").glob("*.toml"))


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_the_scalar_form_equals_numpys_on_every_shipped_model(path):
    """Bit for bit on states of every scale, zeros included (a Piecewise's edge, sign(0))."""
    model = load_model(path)
    numeric = NumericModel.of(model)
    eq = model.equations
    values = {p: sp.Float(v) for p, v in zip(eq.params, model.parameter_vector())}
    rhs = [eq.inline(d).xreplace(values) for d in eq.derivatives]
    reference = sp.lambdify(list(eq.states) + [eq.input], rhs, modules=["numpy"])
    rng = np.random.default_rng(1)
    n = len(eq.states)
    for k in range(400):
        x = rng.normal(size=n + 1) * rng.choice([1e-6, 1e-2, 1.0, 10.0], size=n + 1)
        x[rng.integers(n + 1)] = 0.0 if k % 3 == 0 else x[0]
        got = numeric.derivatives(x[:n], x[n])
        want = np.array(reference(*x), dtype=float)
        assert np.array_equal(got, want), (k, got, want)


def test_numpy_semantics_for_every_argument_kind():
    v, w = sp.symbols("v w")
    f = scalar_function([v, w], [v / w, sp.Piecewise((sp.sin(v), v > 0), (sp.cos(v), True)), sp.sign(v)])
    with np.errstate(divide="ignore"):
        q, p, s = f(np.float64(1.0), np.float64(0.0))
    assert math.isinf(q) and p == np.sin(1.0) and s == 1.0
    assert f(np.float64(-2.0), np.float64(1.0))[1:] == [np.cos(-2.0), -1.0]
    assert f(np.float64(0.0), np.float64(1.0))[2] == 0.0


def test_made_once_per_model():
    """The roles, the linearisations and the controllers of one run all ask for the same model's
    numeric equations: made once and kept with the model; a copy with other values makes its own."""
    model = load_model(MODELS[0])
    numeric = NumericModel.of(model)
    assert NumericModel.of(model) is numeric
    other = model.with_params({model.parameter_names()[0]: 2 * model.parameter_vector()[0]})
    assert NumericModel.of(other) is not numeric
    state = np.linspace(0.1, 0.4, len(numeric.names))
    assert not np.array_equal(NumericModel.of(other).derivatives(state, 1.0), numeric.derivatives(state, 1.0))
