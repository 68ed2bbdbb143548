"""pendc.ir.lut: evaluating a table's expression."""

import warnings

import numpy as np
import pytest

from pendc.ir.lut import evaluate


def test_a_table_expression_that_is_not_finite_somewhere_warns_nothing():
    """Round J: a CSTR's Arrhenius rate 1.2e9*exp(-8750/T), evaluated at T = 0 while tabulating,
    printed numpy's 'divide by zero' RuntimeWarning among pendc build's lines."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = evaluate("1.2e9*exp(-8750/v)", [-1.0, 0.0, 350.0])
    assert out[2] == pytest.approx(1.2e9 * np.exp(-8750 / 350.0))
    assert out[0] == np.inf and out[1] == 0.0          # numpy's values, given without a word
