"""The identification story on the second plant, the rotary (Furuta) pendulum, with no code path
of its own (issue 12, point 1).

The data come from outside pendc: ``tests/independent_furuta.py`` integrates hand-written
equations of motion (Cazzolato & Prime 2011) with scipy and quantises its own encoders. It
hides an effect that ``models/furuta_qube.toml`` lacks: dry friction on the arm (3 mN*m,
stick-slip resolved by events), the catalogue's ``coulomb_arm``. ``pendc compare``, ``pendc diagnose`` and
``pendc fit`` then run on the file exactly as on the cart-pendulum's: the columns, outputs,
units, periodic states and encoder counts all come from the model's plant interface.

The last tests are the grep of issue 12: the simulation and identification code (and its
command-line layer) names no state or input of either plant in a string literal.
"""

import ast
import io
import json
import tokenize
from pathlib import Path

import pytest

import pendc
from cli_capture import run_cli
from independent_furuta import simulate, stimulus
from pendc.sim.measurements import write_csv

FURUTA = Path(__file__).resolve().parents[1] / "models" / "furuta_qube.toml"
HIDDEN_FRICTION = 0.003    # N*m: dry friction torque of the arm
SECONDS = 3.0              # short: the generator integrates every 1 ms sample with scipy


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """A 3 s run of the independent generator (chirp, then steps), encoder columns only (the
    velocities are estimated from them, as from a lab's recording)."""
    t, u = stimulus(seconds=SECONDS, seed=1)
    run = simulate(t, u, params={"tau_r": HIDDEN_FRICTION})
    path = tmp_path_factory.mktemp("furuta") / "qube_arm_friction.csv"
    write_csv(path, {k: run[k] for k in ("t", "u", "phi_r", "alpha_p")},
              {"generator": "tests/independent_furuta.py", "hidden": f"tau_r={HIDDEN_FRICTION}"})
    return path


def test_compare_reads_the_plants_own_columns(recording, capsys):
    rc, out, err = run_cli(capsys, "compare", recording, "--model", FURUTA, "--json")
    assert rc == 0, err
    c = json.loads(out)
    assert c["outputs"] == ["phi_r", "alpha_p"]                   # the interface's positions, in order
    assert set(c["fit"]) == {"label", "phi_r", "alpha_p"} and "fit_alpha_p_wrapped" in c
    assert set(c["fit_horizon"]) >= {"phi_r", "alpha_p"}
    assert {r["partition"] for r in c["regimes"]} >= {"arm motion", "pendulum angle", "drive"}
    assert "track position" not in {r["partition"] for r in c["regimes"]}    # both positions are angles
    # the missing friction shows in both angles' horizon fit
    assert c["fit_horizon"]["phi_r"] < 90.0 and c["fit_horizon"]["alpha_p"] < 90.0
    assert set(c["rms_free_run"]) == {"phi_r", "alpha_p", "alpha_p_wrapped"}


def test_diagnose_ranks_the_hidden_effect_first(recording, capsys):
    rc, out, err = run_cli(capsys, "diagnose", recording, "--model", FURUTA, "--workers", "1", "--json")
    assert rc == 0, err
    d = json.loads(out)
    names = [c["effect"] for c in d["candidates"]]
    catalogue = set(pendc.load_model(FURUTA).catalogue) - set(pendc.load_model(FURUTA).effects)
    assert set(names) <= catalogue and "coulomb_arm" in names
    best, runner_up = d["candidates"][0], d["candidates"][1]
    assert best["effect"] == "coulomb_arm", names
    assert best["score"] > 0.9 and runner_up["score"] < best["score"] - 0.2 and not d["tie"]
    assert best["params"]["tau_r"] == pytest.approx(HIDDEN_FRICTION, rel=0.05)
    assert not d["unexplained"]


def test_fit_recovers_the_friction_and_the_error_falls(recording, tmp_path, capsys):
    new = tmp_path / "fitted.toml"
    rc, out, err = run_cli(capsys, "fit", recording, "--model", FURUTA, "--add", "coulomb_arm", "-o", new, "--json")
    assert rc == 0, err
    f = json.loads(out)
    value, (lo, hi) = f["params"]["tau_r"]["value"], f["params"]["tau_r"]["ci95"]
    assert value == pytest.approx(HIDDEN_FRICTION, rel=0.05) and lo < value < hi
    before, after = f["fit_before"]["pooled"], f["fit_after"]["pooled"]
    assert after["phi_r"] > before["phi_r"] + 10.0 and after["alpha_p"] > before["alpha_p"] + 10.0
    assert f["free_run_after"]["pooled"]["phi_r"] > f["free_run_before"]["pooled"]["phi_r"]
    fitted = pendc.load_model(new)
    assert fitted.body == "furuta" and fitted.effects["coulomb_arm"]["tau_r"] == pytest.approx(value)


# -- the grep of issue 12 ------------------------------------------------------------------------

ROOT = Path(pendc.__file__).resolve().parent
SCANNED = sorted([*ROOT.glob("sim/*.py"), *ROOT.glob("ident/*.py"),
                  *(ROOT / "cli" / n for n in ("ident.py", "compare.py", "data.py", "options.py"))])


# The cart-pendulum's states and input, as issue 12 lists them (its interface costs a symbolic
# derivation; the Furuta's, read below, is cheap)
CART_PENDULUM = {"x", "dx", "theta", "dtheta", "u"}


def plant_names() -> set:
    """The states and inputs of both shipped plants (the cart-pendulum's and the Furuta's)."""
    furuta = pendc.load_model(FURUTA).interface
    return CART_PENDULUM | {s.name for s in furuta.states} | {i.name for i in furuta.inputs}


def named_literals(path: Path, names: set) -> list:
    """(line, literal) of every string literal that is exactly a plant's name (docstrings, which
    may cite the pendulum as an example, excepted)."""
    text = path.read_text(encoding="utf-8")
    docstrings = {node.body[0].lineno for node in ast.walk(ast.parse(text))
                  if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
                  and node.body and isinstance(node.body[0], ast.Expr)
                  and isinstance(node.body[0].value, ast.Constant) and isinstance(node.body[0].value.value, str)}
    found = []
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type == tokenize.STRING and tok.start[0] not in docstrings:
            value = ast.literal_eval(tok.string) if not tok.string.lstrip("rbuRBU").startswith(("f", "F")) else None
            if isinstance(value, str) and value in names:
                found.append((tok.start[0], value))
    return found


def test_no_sim_or_ident_file_names_a_plants_state():
    names = plant_names()
    assert {"x", "dx", "theta", "dtheta", "u", "phi_r", "dphi_r", "alpha_p", "dalpha_p"} <= names
    assert len(SCANNED) > 30
    offenders = {p.relative_to(ROOT).as_posix(): named_literals(p, names) for p in SCANNED}
    assert {k: v for k, v in offenders.items() if v} == {}


def test_the_grep_is_not_blind(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text('"""A docstring may say "theta"."""\nA = "alpha_p"\nB = f"{A}"\nC = {"x": 1}\n')
    assert named_literals(probe, {"x", "theta", "alpha_p"}) == [(2, "alpha_p"), (4, "x")]
