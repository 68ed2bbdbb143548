"""pendc compare (pendc.ident.compare): fit% (free run, wrapped, horizon), headline, windows, regimes, whiteness.

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
from pendc.ident.compare import (Comparison, allowed_outside, autocorrelation, compare, cross_correlation,
                                 fit_percent, regime_partitions, regimes, worst_windows)
from pendc.ident.report_text import format_text as format_comparison
from pendc.model.modelfile import load_model
from plants import STIMULI as stimuli
from pendc.sim.encoders import encoder_resolution
from pendc.sim.measurements import Measurement, format_csv, parse_measurements
from pendc.sim.simulator import Simulator

SPRING = {"k_c": 200.0, "x_0": 0.0}
X_COUNT = encoder_resolution(None, "x")             # the default model's encoders: 2.5 um,
THETA_COUNT = encoder_resolution(None, "theta")     # 0.314 mrad


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
    assert names == {"standstill", "moving +x", "moving -x"}


def test_regimes_locate_the_error():
    """An error confined to standstill samples is 100 % standstill's, at its share of time."""
    n = 1000
    dx = np.where(np.arange(n) < 250, 0.0, 0.1)
    r = np.where(dx == 0.0, 1e-3, 0.0)
    model = load_model()
    out = regimes({"x": r}, regime_partitions(model, {"dx": dx, "theta": np.zeros(n), "x": np.zeros(n)},
                                              np.full(n, 5.0), 5.0))
    still = next(g for g in out if g["name"] == "standstill")
    assert still["share"] == pytest.approx(1.0) and still["fraction_of_time"] == pytest.approx(0.25)
    assert still["rms"] == pytest.approx(1e-3)
    sat = next(g for g in out if g["name"] == "saturated")
    assert sat["samples"] == 0 and sat["rms"] is None and sat["share"] == 0.0
    # theta 2 pi is hanging down again: small swing
    out = regimes({"x": np.ones(3)}, regime_partitions(model, {"dx": np.zeros(3), "theta": np.array(
        [0.0, 2 * np.pi + 0.1, 3.0]), "x": np.zeros(3)}, np.full(3, 5.0), 5.0))
    assert next(g for g in out if g["name"] == "small swing")["samples"] == 2


def test_windows_non_overlapping_and_sorted(spring):
    for k in ("x", "theta"):
        ws = [w for w in spring.windows if w["output"] == k]
        assert 1 <= len(ws) <= cmp.TOP_WINDOWS
        rms = [w["rms"] for w in ws]
        assert rms == sorted(rms, reverse=True)
        for w in ws:
            assert w["t1"] - w["t0"] == pytest.approx(cmp.WORST_WINDOW)
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


def test_held_axis_is_left_out_with_a_note(model):
    """A cart that never moves in a 'free' run: x is left out as diagnose and fit leave it out
    (with the note that suggests --experiment cart_held); a run where nothing moves is refused."""
    t = np.arange(2000) * 1e-3
    theta = 0.3 * np.cos(2 * np.pi * 0.9 * t)
    u = np.full_like(t, model.effects["drive"]["V_off"])
    d = Measurement(t=t, u=u, columns={"t": t, "u": u, "x": np.zeros_like(t), "theta": theta}, meta={},
                    source="held.csv")
    c = compare(model, d)
    assert c.outputs == ("theta",) and set(c.fit) == {"theta"}
    assert any("x does not move" in n and "cart_held" in n for n in c.notes)
    assert json.loads(json.dumps(c.to_json(), allow_nan=False))["notes"] == list(c.notes)
    assert compare(model, d, outputs=("theta",)).outputs == ("theta",)
    still = Measurement(t=t, u=u, columns={"t": t, "u": u, "x": np.zeros_like(t), "theta": np.zeros_like(t)},
                        meta={}, source="still.csv")
    with pytest.raises(PendcError, match="no output left to compare"):
        compare(model, still)


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
    assert "Savitzky-Golay" in c.motion_source


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


def test_comparison_is_frozen(same):
    assert isinstance(same, Comparison)
    with pytest.raises(Exception):
        same.fit = {}


# --- labelled figures: wrapped angle, turns, horizon fit, headline ---------------------------------

def test_wrap_difference_is_half_open():
    from pendc.ident.compare import wrap_difference
    got = wrap_difference([np.pi, -np.pi, 3 * np.pi, 2 * np.pi + 0.1, -0.1, 0.0, -2 * np.pi - 0.1])
    assert got == pytest.approx([np.pi, np.pi, np.pi, 0.1, -0.1, 0.0, -0.1], abs=1e-12)
    many = wrap_difference(np.linspace(-20, 20, 4001))
    assert np.all(many > -np.pi) and np.all(many <= np.pi)


def test_turns_apart():
    from pendc.ident.compare import turns_apart
    t = np.arange(10) * 0.1
    assert turns_apart(t, np.zeros(10)) == (0, None)
    e = np.r_[np.zeros(4), np.full(3, 2 * np.pi + 0.01), np.full(3, -4.1 * np.pi)]
    assert turns_apart(t, e) == (2, pytest.approx(0.4))


def test_extra_turn_is_counted_and_wrapped(model):
    """Data that are the model's own run except that theta reads one turn more after 1 s: the
    free-run theta fit pays 2 pi per sample for it, the wrapped fit is perfect, and the report says so."""
    t, u = stimuli.chirp(duration=3)
    d = measured(model, t, u)
    theta = d.columns["theta"] + np.where(t >= 1.0, 2 * np.pi, 0.0)
    d = Measurement(t=d.t, u=d.u, columns={**d.columns, "theta": theta}, meta={}, source="turned.csv")
    c = compare(model, d)
    assert c.turns == 1 and c.turn_time == pytest.approx(1.0)
    assert c.fit["theta"] < 0.0
    assert c.fit_wrapped == pytest.approx(100.0, abs=1e-9)
    text = format_comparison(c)
    assert "1 whole turn away" in text and "2π of error" in text
    assert re.search(r"angle error wrapped to \(-π, π\]: free-run fit 100\.00 %", text)
    out = c.to_json()
    assert out["turns"]["max"] == 1 and out["fit_theta_wrapped"]["theta"] == pytest.approx(100.0)


def test_figures_agree_with_diagnose_and_fit(model):
    """Two implementations of the 0.5 s horizon fit and of the free-run fit (compare's, and the
    ones diagnose and fit print) give the same figures on quantised data with a missing spring."""
    from pendc.ident.shooting import horizon_fit
    t, u = stimuli.chirp(duration=3)
    r = Simulator(model.with_effect("cart_spring", SPRING), 1e-4, "rk4")(t, u, quantize=True)
    data = parse_measurements(format_csv({"t": t, "u": u, "x": r["x"], "theta": r["theta"]}))
    from pendc.ident.figures import free_run_figures
    c = compare(model, data)
    reference = horizon_fit(model, [data])
    free = free_run_figures(model, [data])["files"][0]["fit"]
    for k in ("x", "theta"):
        assert c.fit_horizon[k] == pytest.approx(float(reference[k]), abs=1e-6)
        assert c.fit[k] == pytest.approx(free[k], abs=1e-6)     # and the free run starts where fit's does
    assert c.fit_horizon["x"] > c.fit["x"]        # restarts keep the missing spring's error from growing


def test_horizon_segments_restart_from_the_data(spring):
    run = spring.horizon_run
    assert run.horizon == 0.5 and run.starts[:3] == (0, 500, 1000)
    for k in ("x", "theta"):
        assert run.restarts[k] == pytest.approx(spring.measured[k][list(run.starts)])
        tt, yy = run.plot_lines(k)
        assert tt.shape == yy.shape and np.isnan(tt).sum() == len(run.starts)
        # each plotted segment starts on the measured value
        first = np.r_[0, np.flatnonzero(np.isnan(tt))[:-1] + 1]
        assert yy[first] == pytest.approx(spring.measured[k][list(run.starts)])


def test_headline_is_free_run_where_a_free_run_is_reproducible(spring):
    h = spring.headline
    assert h.metric == "free_run" and min(h.twin_fit.values()) > 90.0
    first, why = format_comparison(spring).splitlines()[:2]
    assert first.startswith("headline: free-run fit ") and "meaningful" in why
    assert spring.residual_of == "free run"


@pytest.fixture(scope="module")
def sensitive():
    """The first 12 s of the shipped validation run (a swing-up that goes over the top), as
    measured, with the model that made it: a free run from one encoder count away diverges."""
    from pendc.sim.measurements import read_measurements
    from pathlib import Path
    d = read_measurements(Path(__file__).resolve().parents[1] / "data" / "hidden_spring_validation.csv")
    n = 12000
    cut = parse_measurements(format_csv({k: d.columns[k][:n] for k in ("t", "u", "x", "theta")}),
                             source="validation_12s.csv")
    return cut


def test_headline_is_horizon_where_the_free_run_diverges(model, sensitive):
    truth = model.with_effect("cart_spring", {"k_c": 300.0, "x_0": 0.05})   # data/generate.py's values
    c = compare(truth, sensitive)
    assert c.headline.metric == "horizon" and c.headline.twin_fit["theta"] < 90.0
    first, why = format_comparison(c).splitlines()[:2]
    assert first.startswith("headline: 0.5 s horizon fit x ") and "not meaningful" in why
    assert "one encoder count away" in why
    assert c.fit_horizon["theta"] > 99.0 and c.fit["theta"] < c.fit_horizon["theta"]
    assert c.residual_of == "0.5 s horizon simulation"
    assert c.to_json()["headline"]["metric"] == "horizon"


def test_twin_fit_measures_the_divergence_of_the_model_itself():
    from pendc.ident.headline import choose, twin_fit
    y = {"x": np.linspace(0, 1, 100)}
    steady = twin_fit(lambda s: {"x": np.full(100, s[0])}, np.zeros(4), y)   # moves by exactly one count
    assert steady["x"] == pytest.approx(100 * (1 - 10 * X_COUNT / np.linalg.norm(y["x"] - 0.5)))
    blown = twin_fit(lambda s: {"x": np.full(100, 1e6 * s[0])}, np.zeros(4), y)
    assert choose(steady, 0.5).metric == "free_run" and choose(blown, 0.5).metric == "horizon"
    assert choose({"x": float("nan")}, 0.5).metric == "free_run"       # nothing varies: nothing to lose


def test_held_cart_compares_theta_only(model):
    """A free swing with the cart clamped: the model is simulated as held and only theta is compared."""
    held = model.for_experiment("cart_held")
    t = np.arange(0, 4, 1e-3)
    u = np.full_like(t, model.effects["drive"]["V_off"])
    r = Simulator(held, 1e-4, "rk4")(t, u, x0=(0.0, 0.0, 0.6, 0.0), quantize=True)
    text = format_csv({"t": t, "theta": r["theta"]}, meta={"experiment": "cart_held"})   # no x, no u logged
    data = parse_measurements(text, source="held.csv")
    assert set(data.missing) == {"x", "u"}
    c = compare(model, data)
    assert c.experiment == "cart_held" and c.outputs == ("theta",)
    assert {g["partition"] for g in c.regimes} == {"pendulum angle"}    # no regimes of axes the run lacked
    # free run: the initial velocity is a 10 ms slope of a swing released from rest, a little off
    assert set(c.fit) == {"theta"} and c.fit["theta"] > 95.0 and c.fit_horizon["theta"] > 99.0
    assert "experiment cart_held" in format_comparison(c)


def test_sensor_offset_is_part_of_the_output_map(model):
    """A model whose encoder reads theta + 0.05 rad: the same model fits its own data exactly in
    free run and horizon (the initial state is the true one, the outputs what the sensor reads)."""
    m = model.with_effect("theta_offset", {"theta_off": 0.05})
    t, u = stimuli.chirp(duration=2)
    r = Simulator(m, 1e-4, "rk4")(t, u, x0=(0.0, 0.0, 0.3, 0.0))
    d = Measurement(t=t, u=u, columns={"t": t, "u": u, "x": r.measured("x"), "theta": r.measured("theta"),
                                       "dx": r["dx"], "dtheta": r["dtheta"]}, meta={}, source="offset")
    c = compare(m, d)
    for k in ("x", "theta"):
        assert c.fit[k] == pytest.approx(100.0, abs=1e-6) and c.fit_horizon[k] == pytest.approx(100.0, abs=1e-6)
    assert compare(model, d).fit_horizon["theta"] < 90.0       # without the offset the model is visibly off


def test_missing_or_constant_input_is_not_called_independent(model, monkeypatch):
    """A free swing whose file had no u column (filled with V_off) or whose u never changes:
    the residual cannot be tested against the input, and no report may say it is independent."""
    from pendc.ident import report_html
    from pendc.ident.whiteness import INPUT_UNTESTED

    monkeypatch.setattr(report_html, "_png", lambda fig: "AAAA")   # the text matters here, not the pixels
    swing = model.with_effect("coulomb_pendulum", {"tau_c": 0.004}).for_experiment("cart_held")
    t = np.arange(2001) * 1e-3
    u = np.full_like(t, 5.264616)
    r = Simulator(swing, dt=1e-4, method="rk4")(t, u, x0=(0.0, 0.0, 0.8, 0.0))
    cols = {"t": t, "u": u, "x": np.zeros_like(t), "theta": r["theta"]}
    for missing, status in ((("u",), "missing"), ((), "constant")):
        data = Measurement(t=t, u=u, columns=cols, meta={}, source="swing", experiment="cart_held", missing=missing)
        c = compare(model, data)
        x = c.whiteness["xcorr"]["theta"]
        assert x["tested"] is False and x["independent"] is None and x["input"] == status
        text = format_comparison(c)
        assert f"theta residual against the input: not tested: {INPUT_UNTESTED[status]}" in text
        assert "no significant correlation with the input" not in text
        assert json.loads(json.dumps(c.to_json()))["whiteness"]["xcorr"]["theta"]["independent"] is None
    page = report_html.render_html(c)
    assert "independent of u" not in page and "not tested: " + INPUT_UNTESTED["constant"] in page
    # a varying, measured input is still tested
    t2, u2 = stimuli.chirp(duration=2)
    assert compare(model, measured(model, t2, u2)).whiteness["xcorr"]["x"]["tested"] is True
