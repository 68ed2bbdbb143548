"""pendc compare (pendc.ident.compare, report_html): fit%, windows, regimes, whiteness, report.

Data are made here by simulating a known model on short stimuli, so every
expectation is exact: the same model fits 100 %, a model missing a cable spring
fits x worse, and the statistics obey their definitions.
"""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from pendc.errors import PendcError
from pendc.ident import compare as cmp
from pendc.ident import report_html
from pendc.ident.compare import (Comparison, allowed_outside, autocorrelation, compare, cross_correlation,
                                 fit_percent, regimes, worst_windows)
from pendc.ident.report_html import write_html_report
from pendc.ident.report_text import format_text as format_comparison
from pendc.model.modelfile import load_model
from pendc.sim import stimuli
from pendc.sim.encoders import THETA_COUNT, X_COUNT
from pendc.sim.measurements import Measurement, format_csv, parse_measurements
from pendc.sim.simulator import Simulator

SPRING = {"k_c": 200.0, "x_0": 0.0}


def measured(model, t, u, dt=1e-4, method="rk4", velocities=True) -> Measurement:
    """A Measurement holding ``model``'s response; with velocities the initial state is exact."""
    r = Simulator(model, dt=dt, method=method)(t, u)
    names = ("x", "theta", "dx", "dtheta") if velocities else ("x", "theta")
    return Measurement(t=t, u=u, columns={"t": t, "u": u, **{k: r[k] for k in names}}, meta={}, source="test")


@pytest.fixture(scope="module")
def model():
    return load_model()


@pytest.fixture(scope="module")
def same(model):
    t, u = stimuli.chirp(duration=3)
    return compare(model, measured(model, t, u))


@pytest.fixture(scope="module")
def spring(model):
    """Data from the model plus a cable spring, compared with the model without it."""
    t, u = stimuli.chirp(duration=3)
    return compare(model, measured(model.with_effect("cart_spring", SPRING), t, u))


def test_same_model_fits_100(same):
    assert same.fit["x"] == pytest.approx(100.0, abs=1e-9)
    assert same.fit["theta"] == pytest.approx(100.0, abs=1e-9)
    assert np.all(same.residual["x"] == 0.0) and np.all(same.residual["theta"] == 0.0)


def test_missing_effect_lowers_fit(spring):
    assert spring.fit["x"] < 90.0           # the spring pulls the cart back: x is visibly wrong
    assert spring.fit["theta"] < 100.0 - 1e-6
    assert spring.residual["x"].shape == spring.simulated.t.shape


def test_fit_formula_on_hand_example():
    # ||y - yhat|| = 1, ||y - mean|| = sqrt(2.25 + 0.25 + 0.25 + 2.25) = sqrt(5)
    assert fit_percent([1, 2, 3, 4], [1, 2, 3, 5]) == pytest.approx(100 * (1 - 1 / math.sqrt(5)))
    assert fit_percent([1, 2, 3, 4], [2.5, 2.5, 2.5, 2.5]) == pytest.approx(0.0)   # the mean scores 0
    assert fit_percent([1, 2, 3, 4], [1, 2, 3, 4]) == 100.0
    assert math.isnan(fit_percent([2, 2, 2], [2, 2, 3]))                           # undefined, not a crash


def test_default_step_close_to_reference(model):
    """The documented figure: 0.1 ms RK4 against the 1 us Euler reference on a chirp stays
    within a fraction of a theta count; x within a few counts (friction's zero crossings
    make the step error first order)."""
    t, u = stimuli.chirp(duration=3)
    ref = Simulator(model, 1e-6, "euler")(t, u)
    fast = Simulator(model, 1e-4, "rk4")(t, u)
    assert np.abs(fast["theta"] - ref["theta"]).max() < THETA_COUNT
    assert np.abs(fast["x"] - ref["x"]).max() < 10 * X_COUNT


def test_regime_shares_sum_to_one(spring):
    groups = {}
    for g in spring.regimes:
        groups.setdefault((g["partition"], g["output"]), []).append(g)
    assert {p for p, _ in groups} == {"cart motion", "pendulum angle", "drive", "track position", "input saturation"}
    for members in groups.values():
        assert sum(g["share"] for g in members) == pytest.approx(1.0)
        assert sum(g["fraction_of_time"] for g in members) == pytest.approx(1.0)
        assert sum(g["samples"] for g in members) == len(spring.simulated.t)
    names = {g["name"] for g in spring.regimes if g["partition"] == "cart motion"}
    assert names == {"standstill", "moving left", "moving right"}


def test_regimes_locate_the_error():
    """An error confined to standstill samples is 100 % standstill's, at its share of time."""
    n = 1000
    dx = np.where(np.arange(n) < 250, 0.0, 0.1)
    r = np.where(dx == 0.0, 1e-3, 0.0)
    out = regimes({"x": r}, dx=dx, theta=np.zeros(n), x=np.zeros(n), u=np.full(n, 5.0), v_off=5.0)
    still = next(g for g in out if g["name"] == "standstill")
    assert still["share"] == pytest.approx(1.0) and still["fraction_of_time"] == pytest.approx(0.25)
    assert still["rms"] == pytest.approx(1e-3)
    sat = next(g for g in out if g["name"] == "saturated")
    assert sat["samples"] == 0 and sat["rms"] is None and sat["share"] == 0.0
    # theta 2 pi is hanging down again: small swing
    out = regimes({"x": np.ones(3)}, dx=np.zeros(3), theta=np.array([0.0, 2 * np.pi + 0.1, 3.0]), x=np.zeros(3),
                  u=np.full(3, 5.0), v_off=5.0)
    assert next(g for g in out if g["name"] == "small swing")["samples"] == 2


def test_windows_non_overlapping_and_sorted(spring):
    for k in ("x", "theta"):
        ws = [w for w in spring.windows if w["output"] == k]
        assert 1 <= len(ws) <= cmp.TOP_WINDOWS
        rms = [w["rms"] for w in ws]
        assert rms == sorted(rms, reverse=True)
        for w in ws:
            assert w["t1"] - w["t0"] == pytest.approx(cmp.WINDOW)
        spans = sorted((w["t0"], w["t1"]) for w in ws)
        assert all(a[1] <= b[0] + 1e-9 for a, b in zip(spans, spans[1:]))


def test_window_finds_a_burst():
    t = np.arange(5000) * 1e-3
    r = np.where((t >= 3.2) & (t < 3.4), 1.0, 0.0) + 1e-3
    ws = worst_windows(t, r, "x")
    assert ws[0]["t0"] <= 3.2 and ws[0]["t1"] >= 3.4 - 1e-9
    assert ws[0]["share"] > 0.9
    short = worst_windows(t[:100], r[:100], "x")           # shorter than a window: the whole run
    assert len(short) == 1 and short[0]["t0"] == 0.0


def test_whiteness_of_noise_and_sine():
    rng = np.random.default_rng(3)
    noise = rng.normal(size=2000)
    sine = np.sin(2 * np.pi * np.arange(2000) / 200)
    a = autocorrelation(noise)
    assert a["white"] and a["acf"][0] == pytest.approx(1.0) and len(a["lags"]) == 26
    assert a["band"] == pytest.approx(2.58 / math.sqrt(2000))
    assert not autocorrelation(sine)["white"]
    assert autocorrelation(np.zeros(100))["white"]          # nothing left to explain
    echo = noise + 0.6 * np.r_[np.zeros(3), noise[:-3]]    # one strong lag (3) and nothing else
    spike = autocorrelation(echo)
    assert abs(spike["acf"][3]) > spike["limit"] and not spike["white"]   # far beyond the band
    assert spike["limit"] > spike["band"]
    assert allowed_outside(25) == 1 and allowed_outside(51) == 2


def test_cross_correlation_finds_input_dependence():
    rng = np.random.default_rng(4)
    u = rng.normal(size=2000)
    indep = cross_correlation(rng.normal(size=2000), u)
    assert indep["independent"] and indep["lags"] == list(range(-25, 26))
    lagged = np.r_[np.zeros(5), u[:-5]] + 0.1 * rng.normal(size=2000)   # error = the input 5 samples earlier
    dep = cross_correlation(lagged, u)
    assert not dep["independent"]
    assert max(dep["outside"], key=lambda k: abs(dep["ccf"][k + 25])) == 5


def test_whiteness_is_decimated(spring):
    w = spring.whiteness
    assert set(w) == {"x", "theta", "xcorr"} and set(w["xcorr"]) == {"x", "theta"}
    assert w["x"]["decimation"] == 10 and w["x"]["lag_seconds"] == pytest.approx(0.01)
    assert w["x"]["samples"] == len(spring.simulated.t) // 10
    assert not w["x"]["white"]                              # a missing spring is not noise


def test_to_json_round_trips(spring):
    out = spring.to_json()
    text = json.dumps(out, allow_nan=False)
    assert json.loads(text) == out
    assert set(out) >= {"fit", "windows", "regimes", "whiteness", "model", "data", "dt"}
    assert out["fit"]["x"] == pytest.approx(spring.fit["x"]) and out["data"] == "test"


def test_undefined_fit_is_null_in_json(model):
    t = np.arange(300) * 1e-3
    u = np.full_like(t, model.effects["drive"]["V_off"])   # no force: the cart never moves
    c = compare(model, measured(model, t, u))
    assert math.isnan(c.fit["x"])
    assert json.loads(json.dumps(c.to_json(), allow_nan=False))["fit"]["x"] is None
    assert "undefined" in format_comparison(c)


def test_format_comparison_in_words(spring):
    text = format_comparison(spring)
    first = text.splitlines()[0]
    assert re.match(r"headline: free-run fit x \d+\.\d+ %, theta \d+\.\d+ %", first), first
    assert re.search(r"^0\.5 s horizon fit .*: x \d+\.\d+ %, theta \d+\.\d+ %$", text, re.M)
    assert "Worst 0.5 s windows (residual of the free run)" in text and "of the time" in text
    assert "not white" in text


def test_quantized_data_without_velocities(model):
    """Encoder-quantised positions, velocities estimated: still a near-perfect fit."""
    t, u = stimuli.chirp(duration=3)
    r = Simulator(model, 1e-4, "rk4")(t, u, quantize=True)
    data = parse_measurements(format_csv({"t": t, "u": u, "x": r["x"], "theta": r["theta"]}))
    c = compare(model, data)
    assert c.fit["x"] > 99.0 and c.fit["theta"] > 99.0
    assert "Savitzky-Golay" in c.dx_source


@pytest.mark.parametrize("drop", ["x", "theta"])
def test_missing_output_is_one_line_error(drop):
    text = "t,u,x,theta\n" + "".join(f"{k * 1e-3},5.2,0.0,0.0\n" for k in range(10))
    data = parse_measurements(text, required=())
    data = Measurement(t=data.t, u=data.u, columns={k: v for k, v in data.columns.items() if k != drop},
                       meta={}, source="run.csv")
    with pytest.raises(PendcError) as info:
        compare(load_model(), data)
    msg = str(info.value)
    assert "\n" not in msg and drop in msg and "run.csv" in msg


def test_html_report_is_self_contained(spring, tmp_path):
    path = tmp_path / "report.html"
    write_html_report(spring, path)
    text = path.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>") and "data:image/png;base64," in text
    # horizon segments (whole run and zoom), free run, residual clouds, correlations
    assert len(re.findall(r"data:image/png;base64,", text)) == 5
    refs = re.findall(r"""(?:src|href)\s*=\s*["']?([^"'\s>]*)""", text, re.IGNORECASE)
    assert refs and all(r.startswith("data:image/png;base64,") for r in refs)
    assert "<link" not in text and "@import" not in text and "url(" not in text
    assert "cart motion" in text and "worst windows (residual of the free run)" in text
    assert [p.name for p in tmp_path.iterdir()] == ["report.html"]     # no temporary left behind


def test_html_report_written_atomically(spring, tmp_path, monkeypatch):
    path = tmp_path / "report.html"
    path.write_text("old report")
    calls = []
    real = report_html.write_atomic
    monkeypatch.setattr(report_html, "write_atomic", lambda p, text: (calls.append(p), real(p, text)))
    write_html_report(spring, path, title="run <7>")
    assert calls == [path] and "run &lt;7&gt;" in path.read_text()

    def broken(fig):
        raise RuntimeError("renderer died")
    path.write_text("old report")
    monkeypatch.setattr(report_html, "_png", broken)
    with pytest.raises(RuntimeError):
        write_html_report(spring, path)
    assert path.read_text() == "old report"                      # a failed render leaves the old file
    assert [p.name for p in tmp_path.iterdir()] == ["report.html"]


def test_html_report_into_missing_folder(same, tmp_path):
    with pytest.raises(PendcError) as info:
        write_html_report(same, tmp_path / "missing" / "r.html")
    assert "does not exist" in str(info.value)


def test_comparison_is_frozen(same):
    assert isinstance(same, Comparison)
    with pytest.raises(Exception):
        same.fit = {}
