"""Uncertainty carried into predictions (issue 22): a fitted model file stores the covariance of
what was fitted, and ``compare`` draws the 95 % prediction band from it (free run and horizon)
and says how often the measurement leaves it.

The data: free swings made by pendc's own generator from the default model (the structure the
fitted model has), and by the independent generator (tests/independent_plant.py) with a pivot
Coulomb friction the model lacks (a structural error no parameter value explains)."""

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from pendc import load_model
from pendc.cli import main
from pendc.ident.datagen import free_swing
from pendc.model.fit_uncertainty import FitUncertainty
from pendc.model.model_writer import save_model
from pendc.model.modelfile import load_fit_uncertainty
from pendc.sim.measurements import format_csv


from cli_capture import run_cli
from independent_plant import free_swing as independent_swing


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """b_theta and I fitted on an 8 s swing from 1 rad of the default model (b_theta started at
    twice its value), and a validation swing from 0.7 rad."""
    folder = tmp_path_factory.mktemp("band")
    truth = load_model()
    (folder / "fit.csv").write_text(format_csv(free_swing(truth, 8.0, 1.0)))
    (folder / "val.csv").write_text(format_csv(free_swing(truth, 8.0, 0.7, seed=3)))
    (folder / "coulomb.csv").write_text(format_csv(independent_swing(8.0, theta0=0.7, tau_c=0.002)))
    start = folder / "start.toml"
    save_model(truth.with_params({"b_theta": 2 * truth.effects["viscous_pendulum"]["b_theta"]}), start)
    out = folder / "fitted.toml"
    assert main(["fit", str(folder / "fit.csv"), "--model", str(start), "--free", "b_theta,I", "-o", str(out),
                 "--objective", "horizon"]) == 0
    return folder, out, truth


def test_the_fitted_file_stores_a_covariance_that_matches_its_intervals(fitted):
    _, out, truth = fitted
    doc = tomllib.loads(out.read_text())
    cov = doc["fit"]["covariance"]
    assert cov["names"] == ["b_theta", "I"]
    m = np.array(cov["matrix"])
    assert np.allclose(m, m.T) and np.all(np.linalg.eigvalsh(m) > 0)
    for j, name in enumerate(cov["names"]):          # the interval is 1.96 standard deviations each side
        lo, hi = doc["fit"]["intervals"][name]
        assert (hi - lo) / 2 == pytest.approx(1.96 * np.sqrt(m[j, j]), rel=1e-6)
    u = load_fit_uncertainty(out)
    assert u.source == "covariance" and u.names == ("b_theta", "I")
    # the truth lies within a few standard deviations of what was fitted
    truth_values = np.array([truth.effects["viscous_pendulum"]["b_theta"], truth.plant["I"]])
    assert np.all(np.abs(truth_values - u.mean) < 3 * u.std)


def test_the_band_holds_the_models_own_data_and_not_a_missing_effect(fitted, capsys):
    folder, out, _ = fitted
    html = folder / "cmp.html"
    rc, text, err = run_cli(capsys, "compare", folder / "val.csv", "--model", out, "--json", "--html", html)
    assert rc == 0 and all(line.startswith("pendc: note: ") for line in err.splitlines()), err   # no warning
    own = json.loads(text)["prediction_band"]
    assert own["samples"] == 20 and own["from"] == "covariance" and own["diverged"] == 0
    assert own["outside_horizon"]["theta"] < 0.25 and own["outside_free_run"]["theta"] < 0.5
    page = html.read_text()
    assert "95 % prediction band of 20 parameter draws" in page and "outside the band, free run" in page
    rc, text, err = run_cli(capsys, "compare", folder / "coulomb.csv", "--model", out, "--json")
    assert rc == 0 and all(line.startswith("pendc: note: ") for line in err.splitlines()), err
    other = json.loads(text)["prediction_band"]
    assert other["outside_free_run"]["theta"] > max(0.8, 2 * own["outside_free_run"]["theta"])
    assert other["outside_horizon"]["theta"] > 2 * own["outside_horizon"]["theta"]


def test_the_text_report_says_where_the_band_comes_from_and_band_0_turns_it_off(fitted, capsys):
    folder, out, _ = fitted
    assert main(["compare", str(folder / "val.csv"), "--model", str(out), "--band", "4", "--seed", "2"]) == 0
    text = capsys.readouterr().out
    assert "prediction band (4 draws of b_theta" in text and "from the fit's covariance" in text
    assert "measurement outside the 95 % band" in text
    assert main(["compare", str(folder / "val.csv"), "--model", str(out), "--band", "0"]) == 0
    assert "prediction band" not in capsys.readouterr().out


def test_draws_are_reproducible_clipped_and_follow_the_covariance():
    u = FitUncertainty(names=("a", "b"), mean=np.array([1.0, 2.0]),
                       covariance=np.array([[0.04, 0.03], [0.03, 0.09]]))
    draws = u.sample(20000, seed=5)
    assert np.array_equal(draws, u.sample(20000, seed=5))
    assert np.allclose(np.cov(draws.T), u.covariance, atol=4e-3)
    clipped = u.sample(2000, seed=5, bounds={"a": (0.9, 1.1)})
    assert clipped[:, 0].min() >= 0.9 and clipped[:, 0].max() <= 1.1


@pytest.mark.parametrize("table, message", [
    ("[fit.covariance]\nnames = [\"b_theta\"]\nmatrix = [[-1.0]]\n", "not a covariance"),
    ("[fit.covariance]\nnames = [\"b_theta\", \"I\"]\nmatrix = [[1.0, 0.5], [0.4, 1.0]]\n", "not symmetric"),
    ("[fit.covariance]\nnames = [\"b_theta\", \"I\"]\nmatrix = [[1.0, 0.5]]\n", "2 rows of 2 finite numbers"),
    ("[fit.covariance]\nnames = [\"b_theta\"]\n", "exactly 'names"),
    ("[fit.covariance]\nnames = [\"nope\"]\nmatrix = [[1.0]]\n", "nope, not a parameter of this model"),
    ("[fit.intervals]\nb_theta = [2.0, 1.0]\n", "low <= high"),
])
def test_a_malformed_fit_table_is_one_line_and_exit_2(tmp_path, capsys, table, message):
    from pendc.model.modelfile import default_model_path

    path = tmp_path / "bad.toml"
    path.write_text(default_model_path().read_text(encoding="utf-8") + "\n[fit]\nfree = [\"b_theta\"]\n\n" + table)
    data = Path(__file__).resolve().parents[1] / "data" / "hidden_spring_validation.csv"
    rc = main(["compare", str(data), "--model", str(path), "--band", "2"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and message in err and str(path) in err
