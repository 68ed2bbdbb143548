"""Closed-loop recordings are data: ``pendc hil`` against a plant with a hidden effect, then
``diagnose`` and ``fit`` with the plain model on its run.csv (text column ``mode`` and the
``# key: value`` header included), as a user records under feedback.

Each plant is the default model plus one catalogue effect at a clearly visible value; the
builtin supervisor swings the pendulum up and balances it (upright from 2.34-2.69 s of the
4 s run), so the record holds both a large swing and a stretch under the LQR. For viscous
pivot damping the plain model is the default without its ``viscous_pendulum`` (the default
has one, and diagnose ranks only effects a model lacks); the hidden plant has 3.9 times the
default's b_theta.

Feedback makes the input depend on the measured outputs (the controller sees the encoder
quantisation), and the upright pendulum is unstable without its controller. Measured on these
4 s records with the 0.5 s horizon fit, the bias is small: every hidden value is recovered
within 4 % (b_theta -1.0 %, tau_c +0.1 %, k_c -1.0 %, x_0 -3.7 %, u_dz +2.7 %); the asserted
bound is the issue's 10 %. Two cases do bias the estimates (docs/identification.md, "Closed-loop
recordings"): a balance-only record (the spring and the damping are then not ranked first),
and the free-run objective, which replays the recorded input with no controller: the true
plants score theta free-run fits of -3 to -43 % on their own records, and fitting that figure
gave k_c +38 %, x_0 +46 %, tau_c -9.6 % and an unidentified u_dz. So a record whose metadata
name a controller has the horizon fit as compare's headline, and ``fit``'s default objective
(auto) keeps the horizon on it; the tests below require both.
"""

import json
import time

import pytest

from pendc.cli import main
from pendc.model.modelfile import load_model

# the default model's effects as models/sct_thesis_final.toml lists them (an extending file
# lists the effects it has: none are inherited)
DEFAULT_EFFECTS = """
[effects.drive]
alpha = 260.78841
V_off = 5.264616

[effects.viscous_cart]
b_x = 877.31327

[effects.stribeck_cart]
mu_c = 0.1331798
mu_s = 0.1035951
v_s = 0.9539722
gamma = 1.0

[effects.velocity_limit]
v_max = 0.55
"""
PIVOT_DAMPING = "\n[effects.viscous_pendulum]\nb_theta = 0.0012889\n"

# effect -> (its table in the hidden plant, whether the plain model keeps the default's pivot
# damping, the hidden parameter values)
CASES = {
    "viscous_pendulum": ("b_theta = 0.005", False, {"b_theta": 0.005}),
    "coulomb_pendulum": ("tau_c = 0.01", True, {"tau_c": 0.01}),
    "cart_spring": ("k_c = 300.0\nx_0 = 0.05", True, {"k_c": 300.0, "x_0": 0.05}),
    "drive_deadzone": ("u_dz = 0.15", True, {"u_dz": 0.15}),
}
SECONDS = "4"
BOUND = 0.10  # relative error of a fitted parameter the test accepts (issue 22)


def model_file(path, extra: str = "", damping: bool = True):
    path.write_text('extends = "sct_thesis_final.toml"\n\n[plant]\n' + DEFAULT_EFFECTS
                    + (PIVOT_DAMPING if damping else "") + extra)
    return str(path)


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 0, err
    return out, err


@pytest.mark.parametrize("effect", list(CASES))
def test_hidden_effect_found_and_fitted_from_a_hil_record(effect, tmp_path, capsys):
    body, damping, hidden = CASES[effect]
    started = time.perf_counter()
    plant = model_file(tmp_path / "hidden.toml", f"\n[effects.{effect}]\n{body}\n", damping)
    # the plain model: the default itself, except for the pivot damping case (see the docstring)
    plain = ["--model", model_file(tmp_path / "plain.toml", damping=False)] if not damping else []
    run(["hil", "--model", plant, "--plant", "float", "--seconds", SECONDS, "--out", str(tmp_path / "run")], capsys)
    record = tmp_path / "run" / "run.csv"
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["completed"] and summary["upright_at_s"] is not None  # swung up and held

    out, err = run(["diagnose", str(record), "--json", *plain], capsys)
    notes = [ln for ln in err.splitlines() if "text column" in ln]
    assert notes == [f"pendc: note: {record}: ignoring text column(s) mode"]
    ranked = [c["effect"] for c in json.loads(out)["candidates"]]
    assert ranked[0] == effect, ranked[:3]

    fitted = tmp_path / "fitted.toml"
    run(["fit", str(record), "--add", effect, "-o", str(fitted), *plain], capsys)
    assert 'objective = "horizon"' in fitted.read_text()   # auto: not the free run of a closed loop
    values = load_model(str(fitted)).effects[effect]
    for name, truth in hidden.items():
        assert abs(values[name] - truth) <= BOUND * abs(truth), (name, values[name], truth)
    print(f"{effect}: {time.perf_counter() - started:.1f} s, fitted "
          + ", ".join(f"{n}={values[n]:.6g} (hidden {v:g})" for n, v in hidden.items()))


def test_compare_reads_a_hil_record_with_or_without_a_column_map(tmp_path, capsys):
    run(["hil", "--seconds", "1", "--out", str(tmp_path)], capsys)
    record = str(tmp_path / "run.csv")
    for mapping in ([], ["--columns", "t=t,u=u,x=x,theta=theta"]):
        out, err = run(["compare", record, *mapping], capsys)
        head, why = out.splitlines()[:2]
        assert head.startswith("headline: 0.5 s horizon fit x ") and "Traceback" not in err
        assert why == ("  why: a free run is not meaningful on these data: they were recorded under feedback "
                       "(controller: builtin), and a free run replays their input without the controller")
        assert [ln for ln in err.splitlines() if "text column" in ln] == [
            f"pendc: note: {record}: ignoring text column(s) mode"]
