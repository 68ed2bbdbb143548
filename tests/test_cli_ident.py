"""compare / diagnose / fit on the command line: outputs and one-line errors, no partial files."""

import json
from pathlib import Path

import pytest

from pendc.cli import main
from pendc.model.modelfile import load_model

DATA = Path(__file__).resolve().parents[1] / "data"


def run(capsys, *argv):
    rc = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


SPRING_FIT = ("fit", DATA / "hidden_spring.csv", "--add", "cart_spring", "--json", "-o")


@pytest.fixture(scope="module")
def spring_fit(tmp_path_factory):
    """``pendc fit`` of the hidden spring, run once for the two tests that read what it wrote
    (its JSON, and the model file's comments and origin): (exit status, stdout, stderr, model file)."""
    import contextlib
    import io

    out = tmp_path_factory.mktemp("spring_fit") / "new.toml"
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        rc = main([str(a) for a in (*SPRING_FIT, out)])
    return rc, stdout.getvalue(), stderr.getvalue(), out


def test_fit_writes_a_model_and_json(spring_fit):
    rc, text, err, out = spring_fit
    assert rc == 0, err
    result = json.loads(text)
    assert set(result) == {"fit_before", "fit_after", "free_run_before", "free_run_after", "params", "model",
                           "objective", "horizons", "objective_reason"}
    assert result["objective"] in ("horizon", "free-run") and result["horizons"][0] == 0.5
    assert result["fit_before"]["label"] == "0.5 s horizon fit" and result["free_run_after"]["label"] == "free-run fit"
    assert result["fit_after"]["pooled"]["x"] > result["fit_before"]["pooled"]["x"]
    assert [f["file"] for f in result["fit_after"]["files"]] == [str(DATA / "hidden_spring.csv")]
    assert err == ""
    assert set(result["params"]) == {"k_c", "x_0"}
    for p, truth in (("k_c", 300.0), ("x_0", 0.05)):      # the spring data/generate.py hid
        value, (lo, hi) = result["params"][p]["value"], result["params"][p]["ci95"]
        assert value == pytest.approx(truth, rel=0.1) and lo < value < hi and hi - lo < 0.2 * truth, (p, value, lo, hi)
    fitted = load_model(out)
    assert fitted.effects["cart_spring"]["k_c"] == pytest.approx(result["params"]["k_c"]["value"])


def test_compare_json(capsys, tmp_path):
    rc, text, err = run(capsys, "compare", DATA / "hidden_spring.csv", "--json", "--html", tmp_path / "r.html")
    assert rc == 0, err
    c = json.loads(text)
    assert {"fit", "windows", "regimes", "whiteness", "fit_horizon"} <= set(c)
    assert (tmp_path / "r.html").read_text().count("data:image/png;base64") >= 1


@pytest.mark.parametrize("argv, message", [
    (["fit", "DATA", "--add", "flux_capacitor", "-o", "OUT"], "unknown effect 'flux_capacitor'"),
    (["fit", "DATA", "--free", "k_q", "-o", "OUT"], "unknown parameter"),
    (["fit", "DATA", "-o", "OUT"], "nothing to fit"),
    (["fit", "DATA", "--add", "cart_spring", "--max-evaluations", "1", "-o", "OUT"], "did not converge"),
    (["fit", "BAD", "--add", "cart_spring", "-o", "OUT"], "strictly increasing"),
    (["diagnose", "BAD"], "strictly increasing"),
    (["compare", "MISSING"], "not found"),
])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, argv, message):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,u,x,theta\n0,5,0,0\n0,5,0,0\n")
    out = tmp_path / "out.toml"
    subst = {"DATA": DATA / "hidden_spring.csv", "BAD": bad, "OUT": out, "MISSING": tmp_path / "none.csv"}
    rc, _, err = run(capsys, *[subst.get(a, a) for a in argv])
    assert rc == 2 and err.startswith("pendc: error: ") and err.count("\n") == 1, err
    assert message in err
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv"]


def _slice(tmp_path, start, seconds, name="slice.csv", meta=None):
    from pendc.sim.measurements import format_csv, read_measurements

    full = read_measurements(DATA / "hidden_spring.csv")
    a, n = int(start * 1000), int(seconds * 1000) + 1
    cols = {k: full.columns[k][a:a + n] for k in ("t", "u", "x", "theta")}
    cols["t"] = cols["t"] - cols["t"][0]
    path = tmp_path / name
    path.write_text(format_csv(cols, meta=meta))
    return path


def test_half_a_second_of_data_is_refused_unless_forced(tmp_path, capsys):
    data, out = _slice(tmp_path, 4.0, 0.5), tmp_path / "new.toml"
    rc, _, err = run(capsys, "fit", data, "--add", "cart_spring", "-o", out)
    assert rc == 2 and err.count("\n") == 1 and "do not identify k_c, x_0" in err and "no model written" in err, err
    assert not out.exists() and "Warning" not in err
    rc, text, err = run(capsys, "fit", data, "--add", "cart_spring", "-o", out, "--force")
    assert rc == 0 and out.exists() and "NOT IDENTIFIED" in text
    assert err.count("pendc: note: ") == err.count("\n") == 2        # one note per parameter, nothing else
    assert "\n[fit.intervals]" not in out.read_text()                 # no interval is claimed for them


def test_fitted_model_keeps_comments_and_records_its_origin(spring_fit, capsys):
    import hashlib
    import tomllib

    rc, _, err, out = spring_fit
    assert rc == 0 and err == ""
    text = out.read_text()
    source = (Path(__file__).resolve().parents[1] / "models" / "sct_thesis_final.toml").read_text()
    assert all(line in text for line in source.splitlines() if line.startswith("#"))
    doc = tomllib.loads(text)
    digest = hashlib.sha256((DATA / "hidden_spring.csv").read_bytes()).hexdigest()[:16]
    assert digest in doc["meta"]["data"] and doc["meta"]["source_model"].endswith("sct_thesis_final.toml")
    assert "--add cart_spring" in doc["meta"]["command"]
    lo, hi = doc["fit"]["intervals"]["k_c"]
    model = load_model(out)
    assert lo < model.effects["cart_spring"]["k_c"] < hi
    # reproducible: the same command writes the same bytes
    out2 = out.with_name("again.toml")        # beside it: the command recorded names the output's path
    rc, _, err = run(capsys, *SPRING_FIT, out2)
    assert rc == 0 and err == ""
    assert out2.read_text().replace("again.toml", "new.toml") == text


def test_held_cart_file_fits_on_theta_only_with_a_note(tmp_path, capsys):
    from independent_plant import free_swing
    from pendc.sim.measurements import format_csv

    path = tmp_path / "swing.csv"
    path.write_text(format_csv(free_swing(4.0, b_theta=0.003)))      # x = 0 throughout, no experiment line
    out = tmp_path / "new.toml"
    rc, text, err = run(capsys, "fit", path, "--model", MODEL_NO_DAMPING(tmp_path), "--add", "viscous_pendulum",
                        "-o", out, "--json")
    assert rc == 0, err
    assert err.startswith("pendc: note: ") and "x does not move" in err and err.count("\n") == 1
    result = json.loads(text)
    assert set(result["fit_after"]["pooled"]) == {"theta"}
    assert result["params"]["b_theta"]["value"] == pytest.approx(0.003, rel=0.1)
    rc, text2, err = run(capsys, "fit", path, "--model", MODEL_NO_DAMPING(tmp_path), "--add", "viscous_pendulum",
                         "-o", out, "--json", "--outputs", "theta")
    # the file is read as the clamped cart's experiment whatever is compared: the same one note
    assert rc == 0 and err.count("\n") == 1 and "read as experiment cart_held" in err
    assert json.loads(text2)["params"] == result["params"]


def MODEL_NO_DAMPING(tmp_path):
    path = tmp_path / "no_damping.toml"
    if not path.exists():
        from pendc.model.model_writer import save_model
        save_model(load_model().without_effect("viscous_pendulum"), path)
    return path


def test_diagnose_says_nothing_systematic_is_left_on_a_complete_model(tmp_path, capsys):
    from independent_plant import free_swing
    from pendc.sim.measurements import format_csv

    path = tmp_path / "swing.csv"
    path.write_text(format_csv(free_swing(4.0, tau_c=0.004), meta={"experiment": "cart_held"}))
    model = tmp_path / "complete.toml"
    from pendc.model.model_writer import save_model
    save_model(load_model().with_effect("coulomb_pendulum", {"tau_c": 0.004}), model)
    rc, text, err = run(capsys, "diagnose", path, "--model", model)
    assert rc == 0 and err == "", err
    assert "Nothing systematic left" in text and "0.5 s horizon fit" in text
    assert "No catalogue effect explains" not in text
    rc, text, err = run(capsys, "diagnose", path, "--model", model, "--json")
    out = json.loads(text)
    assert rc == 0 and err == "" and out["at_noise_level"] and not out["unexplained"]
    assert out["fit_now"]["label"] == "0.5 s horizon fit" and out["fit_now"]["files"][0]["file"] == str(path)
    assert all(c["fit_after"]["label"] == "0.5 s horizon fit" for c in out["candidates"])
    # and the verdict is about the pivot friction: without it the same data are far from noise
    from pendc.ident.noise import noise_ratio
    from pendc.sim.measurements import read_measurements
    assert noise_ratio(load_model(), [read_measurements(path)])["theta"] > 2.0


def test_diagnose_of_another_pendulum_points_at_its_constants_and_tests_them(tmp_path, capsys):
    """The model is written as a fit that freed I would write it ([meta] fitted): the period hint
    then names what else sets the period (L), never I again, and each name is tested."""
    from pendc.model.model_writer import dumps_fitted
    from pendc.model.modelfile import default_model_path

    source = default_model_path().read_text(encoding="utf-8")
    model = tmp_path / "fitted_i.toml"
    model.write_text(dumps_fitted(load_model(), source, {"generator": "pendc fit", "fitted": "I"}, {}))
    rc, text, err = run(capsys, "diagnose", DATA / "unknown_pendulum_swing.csv", "--model", model, "--json")
    assert rc == 0 and err == "", err
    hint = json.loads(text)["parameter_hint"]
    assert hint["free"] == ["L", "b_theta"] and "freed I already: what else sets it is L" in hint["reason"]
    tested = {row["parameter"]: row for row in hint["tested"]}
    assert set(tested) == {"L", "b_theta"}
    # the other pendulum's L is 5 % shorter: freeing L moves it that way and removes much of the error
    assert tested["L"]["value"] < tested["L"]["start"] and tested["L"]["cost_reduction"] > 0.3
