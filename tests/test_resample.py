"""Resampling onto a uniform grid, checked against independent computations (numpy
convolution, scipy quadrature) and at the edges of its rules."""

import numpy as np
import pytest
from scipy.integrate import quad

from pendc.errors import PendcError
from pendc.sim.resample import MAX_GAP_S, regrid


def where(k):
    return f"row {k}"


def test_block_means_equal_a_boxcar_convolution():
    rng = np.random.default_rng(2)
    t = np.arange(10_000) * 1e-4
    v = np.cumsum(rng.normal(0, 1, len(t)))
    new_t, cols, note = regrid(t, {"v": v}, "f", where)
    boxcar = np.convolve(v, np.ones(10) / 10, mode="valid")[::10]
    assert np.allclose(cols["v"], boxcar[: len(cols["v"])], rtol=0, atol=1e-9)
    assert np.allclose(new_t, np.convolve(t, np.ones(10) / 10, mode="valid")[::10][: len(new_t)])
    assert "decimated from 10 kHz" in note and "blocks of 10" in note


def test_interval_means_equal_quadrature_of_the_interpolated_signal():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(2e-4, 6e-4, 3000))     # non-uniform, ~2.5 kHz
    v = np.sin(7 * t) + rng.normal(0, 0.01, len(t))
    new_t, cols, note = regrid(t, {"v": v}, "f", where)
    assert np.allclose(np.diff(new_t), 1e-3)
    for k in (0, 1, 17, len(new_t) // 2, len(new_t) - 1):
        a, b = new_t[k] - 5e-4, new_t[k] + 5e-4
        exact = quad(lambda s: np.interp(s, t, v), a, b, limit=200, points=t[(t > a) & (t < b)])[0] / 1e-3
        assert cols["v"][k] == pytest.approx(exact, abs=1e-9)
    assert "non-uniform sampling" in note and "over each output interval" in note


def test_gap_rule_edges():
    t = np.arange(1000) * 1e-3
    v = np.sin(t)
    ok = np.delete(np.arange(1000), np.arange(500, 519))  # a 20 ms gap: at the limit, accepted
    new_t, cols, note = regrid(t[ok], {"v": v[ok]}, "f", where)
    assert np.allclose(np.diff(new_t), 1e-3) and "non-uniform" in note
    assert np.max(np.abs(cols["v"] - np.sin(new_t))) < 1e-4
    bad = np.delete(np.arange(1000), np.arange(500, 521))  # 22 ms: refused, the row named
    with pytest.raises(PendcError, match=rf"row 500: a gap of 0.022 s .*limit {MAX_GAP_S:g} s"):
        regrid(t[bad], {"v": v[bad]}, "f", where)


def test_uniform_file_below_1khz_is_untouched_and_rate_is_honoured():
    t = np.arange(500) * 2e-3
    v = np.cos(t)
    new_t, cols, note = regrid(t, {"v": v}, "f", where)
    assert new_t is t and cols["v"] is v and note is None
    new_t, cols, note = regrid(t, {"v": v}, "f", where, rate=250.0)
    assert np.allclose(np.diff(new_t), 4e-3) and np.allclose(cols["v"], (v[:-1:2] + v[1::2]) / 2)
