"""pendc compare on the command line: two models side by side, the stories the demo and the docs
tell (the error falls in the first line), labelled JSON, several files, no warnings."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from pendc.model.modelfile import load_model
from plants import STIMULI as stimuli
from pendc.sim.measurements import format_csv, parse_measurements, read_measurements
from pendc.sim.simulator import Simulator
from cli_capture import run_cli

SPRING = {"k_c": 200.0, "x_0": 0.0}


@pytest.fixture(scope="module")
def model():
    return load_model()


@pytest.fixture(scope="module")
def sensitive():
    """The first 12 s of the shipped validation run (a swing-up that goes over the top)."""
    d = read_measurements(Path(__file__).resolve().parents[1] / "data" / "hidden_spring_validation.csv")
    n = 12000
    return parse_measurements(format_csv({k: d.columns[k][:n] for k in ("t", "u", "x", "theta")}),
                              source="validation_12s.csv")


_cli = run_cli


def test_demo_story_error_falls_in_the_first_lines(capsys, tmp_path, model, sensitive, monkeypatch):
    """make demo ends with `pendc compare VALIDATION --model thesis --model with_spring`: the
    first line must show the error falling. The fitted model is stood in for by the spring that
    made the data (fit recovers it within a few %), the run cut to 12 s to keep the test fast."""
    from pendc.model.model_writer import save_model
    data = tmp_path / "validation.csv"
    data.write_text(format_csv({k: sensitive.columns[k] for k in ("t", "u", "x", "theta")}))
    with_spring = tmp_path / "with_spring.toml"
    save_model(model.with_effect("cart_spring", {"k_c": 300.0, "x_0": 0.05}), with_spring)
    html = tmp_path / "compare.html"
    from pendc.ident import report_html
    monkeypatch.setattr(report_html, "_png", lambda fig: "AAAA")    # the plots are tested in test_report_html
    rc, out, err = _cli(capsys, "compare", data, "--model", "models/sct_thesis_final.toml", "--model", with_spring,
                        "--html", html)
    assert rc == 0 and err == "", err
    first, why = out.splitlines()[:2]
    assert first.startswith("headline: 0.5 s horizon fit on ") and "A: sct_thesis_final -> B: with_spring" in first
    assert first.endswith("(A -> B: the error falls)"), first
    assert "not meaningful" in why
    values = re.findall(r"(-?\d+\.\d+) % -> (-?\d+\.\d+) %", first)
    assert len(values) == 2 and all(float(b) > float(a) for a, b in values)
    assert html.read_text().count("A -&gt; B: the error falls") >= 1


def test_cli_json_single_and_side_by_side(capsys, tmp_path, model):
    t, u = stimuli.chirp(duration=2)
    path = tmp_path / "run.csv"
    r = Simulator(model.with_effect("cart_spring", SPRING), 1e-4, "rk4")(t, u, quantize=True)
    path.write_text(format_csv({"t": t, "u": u, "x": r["x"], "theta": r["theta"]}))
    rc, out, err = _cli(capsys, "compare", path, "--json")
    assert rc == 0 and err == ""
    one = json.loads(out)
    assert one["fit"]["label"] == "free-run fit (%)" and one["fit_horizon"]["label"] == "0.5 s horizon fit (%)"
    assert one["headline"]["metric"] == "free_run" and set(one["headline"]["fit"]) == {"x", "theta"}
    rc, out, err = _cli(capsys, "compare", path, path, "--model", "models/sct_thesis_final.toml",
                        "--model", "models/sct_thesis_initial.toml", "--json", "--horizon", "0.25")
    assert rc == 0 and err == ""
    many = json.loads(out)
    assert len(many["runs"]) == 2 and len(many["models"]) == 2
    assert many["runs"][0]["models"][1]["fit_horizon"]["label"] == "0.25 s horizon fit (%)"


def test_cli_bad_horizon_is_one_line(capsys, tmp_path):
    rc, out, err = _cli(capsys, "compare", "data/hidden_spring.csv", "--horizon", "0")
    assert rc == 2 and err.startswith("pendc: error: ") and err.count("\n") == 1 and "--horizon" in err


def test_no_warning_on_hostile_files(capsys, tmp_path):
    """Constant columns, three rows, a held cart: one answer or one error line, never a warning."""
    rows = "".join(f"{k * 1e-3},5.0,0.0,0.0\n" for k in range(3))
    (tmp_path / "three.csv").write_text("t,u,x,theta\n" + rows)
    (tmp_path / "flat.csv").write_text("t,u,x,theta\n" + "".join(f"{k * 1e-3},5.265,0.0,0.0\n" for k in range(400)))
    for name in ("three.csv", "flat.csv"):
        rc, out, err = _cli(capsys, "compare", tmp_path / name, "--html", tmp_path / f"{name}.html")
        assert "Warning" not in err and "Traceback" not in err
        assert (rc == 0 and err == "" and out.startswith("headline: ")) or \
            (rc == 2 and err.startswith("pendc: error: ") and err.count("\n") == 1), err


def test_docs_clamped_cart_story_error_falls(capsys, tmp_path, model, monkeypatch):
    """docs/identification.md's second story, small: a clamped-cart free swing of another pendulum
    (m, L, I 5 % off, stronger pivot damping) saved by Simulink's To Workspace block at 10 kHz in
    degrees from upright; the lab's model has no pivot damping, the fitted one has it and a new I.
    `pendc compare swing.mat --model lab --model fitted` must show the error falling first."""
    import scipy.io as sio
    from pendc.model.model_writer import save_model
    from pendc.sim.encoders import encoder_reading
    from pendc.ident import report_html
    truth = model.with_params({"m": 0.581 * 1.05, "L": 0.138867 * 1.05, "I": 6.21034e-3 * 1.05,
                               "b_theta": 0.0025}).for_experiment("cart_held")
    t = np.arange(0, 4, 1e-4)
    run = Simulator(truth, 1e-4, "rk4")(t, np.full_like(t, 5.0), x0=(0.0, 0.0, 1.2, 0.0))
    values = np.degrees(encoder_reading(truth, "theta", run["theta"]) - np.pi)[:, None]
    sio.savemat(tmp_path / "swing.mat", {"pend": {"time": t[:, None], "signals": {
        "values": values, "dimensions": 1.0, "label": "Theta1", "blockName": "rig/Theta1"}}})
    lab = model.without_effect("viscous_pendulum")
    save_model(lab, tmp_path / "lab.toml")
    save_model(lab.with_effect("viscous_pendulum", {"b_theta": 0.0023}).with_params({"I": 6.474e-3}),
               tmp_path / "lab_fitted.toml")
    monkeypatch.setattr(report_html, "_png", lambda fig: "AAAA")
    rc, out, err = _cli(capsys, "compare", tmp_path / "swing.mat", "--experiment", "cart_held", "--columns",
                        "theta=pend", "--theta-unit", "deg", "--theta-zero", "upright",
                        "--model", tmp_path / "lab.toml", "--model", tmp_path / "lab_fitted.toml",
                        "--html", tmp_path / "compare.html")
    assert rc == 0, err
    assert all(line.startswith("pendc: note: ") for line in err.strip().splitlines()), err
    first = out.splitlines()[0]
    assert first.startswith("headline: ") and "A: lab -> B: lab_fitted: theta " in first
    assert first.endswith("(A -> B: the error falls)"), first


@pytest.mark.parametrize("name", sorted(p.name for p in (Path(__file__).resolve().parents[1] / "data").glob("*.csv")))
def test_shipped_data_compare_without_warnings(capsys, name):
    """Every shipped run: the headline first, nothing on stderr (warnings are errors here)."""
    rc, out, err = _cli(capsys, "compare", Path(__file__).resolve().parents[1] / "data" / name)
    assert rc == 0 and err == "", err
    first, why = out.splitlines()[:2]
    held = name == "unknown_pendulum_swing.csv"     # the cart is clamped: theta alone
    x = "" if held else r"x -?\d+\.\d+ %, "
    assert re.match(r"headline: (free-run fit|0\.5 s horizon fit) " + x + r"theta -?\d+\.\d+ %", first), first
    assert why.startswith("  why: a free run is ")
