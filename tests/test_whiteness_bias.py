"""A biased residual is not noise (the blind check's buck converter: a hidden duty dead zone left
the inductor current 16 converter codes low, 76 % fit, and compare said "i_L residual looks
white: only noise is left to explain", since the autocorrelation test removes the mean). Now a
mean beyond five of its standard errors and beyond a sensor step is reported as a bias."""

from __future__ import annotations

import numpy as np

from cli_capture import run_cli
from pendc.ident.report_text import whiteness_words
from pendc.ident.whiteness import autocorrelation, biased
from pendc.model.modelfile import load_model
from test_horizon_fast import write_buck_run

STEP = 20.0 / 4096          # V: the v_C converter's code


def _residual(mean_codes: float, noise_codes: float = 2.0, n: int = 2000):
    return (mean_codes + noise_codes * np.random.default_rng(5).normal(size=n)) * STEP


def test_a_large_steady_mean_is_a_bias_and_noise_is_not():
    assert not biased(autocorrelation(_residual(0.0)), STEP)
    # significant (0.3 codes is 7 standard errors) but within a reading's rounding
    assert not biased(autocorrelation(_residual(0.3)), STEP)
    big = autocorrelation(_residual(15.0))
    assert big["white"] and biased(big, STEP)              # white around the bias, still not noise
    assert biased(autocorrelation(np.full(100, 3 * STEP)), STEP)     # a constant offset
    # no sensor step known: the mean must be half the residual's rms
    assert biased(big, None) and not biased(autocorrelation(_residual(0.3)), None)


def test_the_verdict_names_the_bias_in_sensor_steps(tmp_path):
    model, _ = write_buck_run(tmp_path)
    a = {**autocorrelation(_residual(-15.0)), "lag_seconds": 1e-3}
    xc = {"tested": True, "independent": True}
    lines = whiteness_words("v_C", a, xc, float(np.sqrt(np.mean(_residual(-15.0) ** 2))), load_model(model))
    assert "only noise is left" not in "\n".join(lines)
    assert lines[0].startswith("  v_C   residual has a bias of -7") and "(15.0 converter codes" in lines[0]
    assert "the data sit below the model" in lines[0] and lines[1].strip() == "around that bias the residual looks white"


def test_compare_reports_a_hidden_sensor_offset_as_a_bias(tmp_path, capsys):
    model, data = write_buck_run(tmp_path, offset=0.05)
    html = tmp_path / "compare.html"
    rc, out, err = run_cli(capsys, "compare", data, "--model", model, "--html", html)
    assert rc == 0, err
    assert "<td class=l>biased by +0.0499 (noise cannot explain it);" in html.read_text()   # the HTML too
    line = next(x for x in out.splitlines() if x.startswith("  v_C   residual"))
    assert line.startswith("  v_C   residual has a bias of 49.9 mV (10.2 converter codes"), line
    assert "the data sit above the model" in line
    assert "v_C   residual looks white: only noise" not in out
    assert "rms about that bias" in out and "i_L   residual has a bias" not in out
