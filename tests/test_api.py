"""pendc.compare / pendc.diagnose / pendc.fit: the identification commands from Python.

The data are a short clamped-cart swing of a pendulum with more pivot damping and a 5 %
larger I than the lab's model, which has no pivot damping at all.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

import pendc
from pendc import api
from pendc.errors import PendcError
from pendc.ident import report_html
from pendc.model.modelfile import load_model
from pendc.sim.encoders import encoder_reading
from pendc.sim.measurements import Measurement, format_csv

TRUE_I, TRUE_B = 6.21034e-3 * 1.05, 0.0025


@pytest.fixture(autouse=True)
def no_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        yield


@pytest.fixture(scope="module")
def lab():
    return load_model().without_effect("viscous_pendulum")


@pytest.fixture(scope="module")
def swing():
    truth = load_model().with_params({"I": TRUE_I, "b_theta": TRUE_B}).for_experiment("cart_held")
    t = np.arange(0, 6, 1e-3)
    u = np.full_like(t, 5.0)
    r = pendc.Simulator(truth, 1e-4, "rk4")(t, u, x0=(0.0, 0.0, 1.2, 0.0))
    return Measurement(t=t, u=u, columns={"t": t, "u": u, "x": np.zeros_like(t), "theta": encoder_reading(None, "theta", r["theta"])},
                       meta={}, experiment="cart_held", source="swing")


def test_exported_with_docstrings():
    for name in ("compare", "diagnose", "fit"):
        f = getattr(pendc, name)
        assert f is getattr(api, name) and len(f.__doc__) > 200


def test_compare_one_model(swing, lab, tmp_path, monkeypatch):
    report = pendc.compare(lab, swing)
    assert report.headline.startswith("headline: free-run fit theta ")
    assert str(report).splitlines()[0] == report.headline
    assert report.comparison.experiment == "cart_held" and report.comparison.outputs == ("theta",)
    out = json.loads(json.dumps(report.to_json(), allow_nan=False))
    assert out["fit"]["label"] == "free-run fit (%)" and "x" not in out["fit"]
    monkeypatch.setattr(report_html, "_png", lambda fig: "AAAA")
    report.write_html(tmp_path / "r.html")
    assert "free-run fit theta" in (tmp_path / "r.html").read_text()


def test_compare_reads_other_formats_and_models_side_by_side(swing, lab, tmp_path):
    """A path with the reading options as keywords, two models from a path and an object."""
    path = tmp_path / "swing.csv"
    path.write_text(format_csv({"Time": swing.t, "Theta1": np.degrees(swing.columns["theta"] - np.pi)},
                               meta={"experiment": "cart_held"}))
    fitted = lab.with_effect("viscous_pendulum", {"b_theta": TRUE_B}).with_params({"I": TRUE_I})
    report = pendc.compare([lab, fitted], path, labels=["lab", "fitted"], columns={"t": "Time", "theta": "Theta1"},
                           theta_unit="deg", theta_zero="upright")
    assert report.headline.endswith("(lab -> fitted: the error falls)")
    a, b = report.result.runs[0]
    assert b.fit["theta"] > 99.0 > a.fit["theta"]
    assert a.fit["theta"] == pytest.approx(pendc.compare(lab, swing).comparison.fit["theta"], abs=0.5)
    with pytest.raises(PendcError, match="model"):
        pendc.compare(42, swing)
    with pytest.raises(PendcError, match="data"):
        pendc.compare(lab, [])


def test_diagnose_ranks_the_missing_damping(swing, lab):
    """Two candidates only (the full catalogue takes a minute): pivot damping must beat an encoder offset."""
    d = pendc.diagnose(lab, swing, effects="viscous_pendulum,theta_offset")
    assert [c.effect for c in d.candidates] == ["viscous_pendulum", "theta_offset"]
    assert d.candidates[0].score > 0.5 and not d.unexplained


def test_fit_recovers_damping_and_writes_a_model(swing, lab, tmp_path):
    out = tmp_path / "fitted.toml"
    report = pendc.fit(lab, swing, add="viscous_pendulum", free=["I"], output=out)
    values = report.result.values
    assert values["b_theta"] == pytest.approx(TRUE_B, rel=0.05) and values["I"] == pytest.approx(TRUE_I, rel=0.02)
    assert report.after["pooled"]["theta"] > report.before["pooled"]["theta"]
    assert report.free_run_after["pooled"]["theta"] > 99.0
    written = load_model(out)
    assert written.effects["viscous_pendulum"]["b_theta"] == pytest.approx(values["b_theta"])
    text = str(report)
    assert "0.5 s horizon fit" in text and "free-run fit" in text and f"wrote {out}" in text


def test_fit_refuses_to_invent(swing, lab, tmp_path):
    """A cable spring on the cart cannot be seen in a clamped-cart swing: reported, and no file."""
    report = pendc.fit(lab, swing, add="cart_spring", max_evaluations=20)
    assert set(report.result.unidentifiable) == {"k_c", "x_0"} and report.path is None
    with pytest.raises(PendcError, match="do not identify"):
        pendc.fit(lab, swing, add="cart_spring", max_evaluations=20, output=tmp_path / "never.toml")
    assert list(tmp_path.iterdir()) == []


def test_fit_an_effect_the_model_has(swing, tmp_path):
    """As `pendc fit --add`: naming an effect the model has fits its parameters from their values."""
    report = pendc.fit(None, swing, add="viscous_pendulum", free="I")
    assert report.free == ("b_theta", "I")
    assert report.result.values["b_theta"] == pytest.approx(TRUE_B, rel=0.05)
