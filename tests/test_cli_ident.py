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


def test_fit_writes_a_model_and_json(tmp_path, capsys):
    out = tmp_path / "new.toml"
    rc, text, err = run(capsys, "fit", DATA / "hidden_spring.csv", "--add", "cart_spring", "-o", out, "--json")
    assert rc == 0, err
    result = json.loads(text)
    assert set(result) == {"fit_before", "fit_after", "free_run_before", "free_run_after", "params", "model"}
    assert result["fit_before"]["label"] == "0.5 s horizon fit" and result["free_run_after"]["label"] == "free-run fit"
    assert result["fit_after"]["pooled"]["x"] > result["fit_before"]["pooled"]["x"]
    assert [f["file"] for f in result["fit_after"]["files"]] == [str(DATA / "hidden_spring.csv")]
    assert err == ""
    assert set(result["params"]) == {"k_c", "x_0"} and len(result["params"]["k_c"]["ci95"]) == 2
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
    (["fit", "DATA", "--add", "drive", "-o", "OUT"], "already"),
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
