"""A plant file of one's own, from docs/plant_files.md to a balanced pendulum, without touching pendc.

The complete example of the reference (copied as a user copies it) is written into a folder
outside the repository and goes through the whole chain with the command line: `plant check`,
`build` (Verilog in that folder), the cocotb regression on Icarus and Verilator (bit-exact
against the golden vectors: every-step windows, reset, the step handshake; the bus on Icarus), `stimulus`
and `simulate` float and `--fixed` (agreeing within the build's error budget), `diagnose` and
`fit` on data the independent generator made with the file's damping hidden from the model
(named first, recovered within 10 %), and `hil` (the builtin swing-up and LQR at the file's
operating point on the bit-exact golden plant).
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest

from pendc.caching.build_cache import compile_cached
from pendc.cli import main
from pendc.ident.datagen import make_dataset
from pendc.model.modelfile import load_model
from pendc.sim.measurements import format_csv, read_measurements
from pendc.sim.read_options import ReadOptions
from pendc.sim.stimuli import Stimuli
from test_plantfile import example

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tb"))

import pendtb  # noqa: E402

CORE_TESTS = ("reset_state", "every_step/stim=chirp_low", "reset_mid_run", "step_handshake", "encoders_decode")
# the bus wrapper's registers under the file's names, on Icarus: on Verilator it would be a second
# build of the whole core for the one test (tests/test_sim.py: the RAPTOR suite on Icarus, the AXI4-Lite one on Verilator)
BUS_TESTS = {"icarus": ("reset_values",), "verilator": ()}
DAMPING = 2e-3                    # the example's pivot damping (its [effects.damping] b)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    home = tmp_path_factory.mktemp("my_lab")
    assert REPO not in home.parents
    (home / "my_cart.toml").write_text(example(), encoding="utf-8")
    return home


def pendc(capsys, *argv) -> str:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert code == 0, f"pendc {' '.join(map(str, argv))}: exit {code}: {err.strip()}"
    return out


@pytest.fixture(scope="module")
def built(folder):
    """`pendc build --model my_cart.toml -o hdl` (module-scoped: the build the other steps reuse)."""
    assert main(["build", "--model", str(folder / "my_cart.toml"), "-o", str(folder / "hdl"), "--json"]) == 0
    return folder / "hdl"


def test_check_and_build(folder, built, capsys):
    out = pendc(capsys, "plant", "check", folder / "my_cart.toml")
    assert "ddx" in out and "enc_theta" in out
    report = json.loads((built / "report.json").read_text())
    assert (built / "my_cart_core.v").is_file() and report["top"] == "my_cart_core" and (built / "my_cart_raptor.v").is_file()
    assert not (REPO / "models" / "my_cart.toml").exists()


@pytest.fixture(scope="module")
def prepared(folder, built, tmp_path_factory):
    prep = pendtb.prepare_hdl(tmp_path_factory.mktemp("my_cart_sim"), model_path=str(folder / "my_cart.toml"))
    return pendtb.add_vectors(prep, stimuli_names=("chirp_low", "random", "multisine_seed7_1MHz"), window=300,
                              long_chunks={"random": 200})


@pytest.mark.parametrize("sim", pendtb.SIMS)
def test_the_cocotb_regression_is_bit_exact(prepared, sim, tmp_path):
    why = pendtb.simulator_missing(sim)
    if why:
        pytest.skip(why)
    problems = []
    for suite, tests in [("core", CORE_TESTS), ("raptor", BUS_TESTS[sim])]:
        if not tests:
            continue
        r = pendtb.run_suite(prepared, sim, suite, tmp_path, profile="quick", testcase=",".join(tests))
        if r.tests != len(tests):
            problems.append(f"{sim}/{suite}: {r.tests} cocotb tests ran, {len(tests)} selected (log {r.log})")
        problems += [f"{sim}/{suite}: {f}" for f in r.failures]
        problems += [f"{sim}/{suite}: {t} skipped (this plant must reach every check)" for t in r.skipped]
    assert not problems, "cocotb failures:\n" + "\n".join(problems)


def test_simulate_float_and_fixed_agree(folder, built, capsys):
    model = folder / "my_cart.toml"
    stim = folder / "in.csv"
    pendc(capsys, "stimulus", "chirp_low", "--model", model, "-o", stim)
    cart = load_model(model)
    reading = ReadOptions(plant=cart)
    assert np.max(np.abs(read_measurements(stim, required=("t", "F"), options=reading).columns["F"])) <= 20.0
    pendc(capsys, "simulate", "--model", model, "--input", stim, "-o", folder / "float.csv")
    pendc(capsys, "simulate", "--fixed", "--model", model, "--input", stim, "-o", folder / "fixed.csv")
    a, b = (read_measurements(folder / name, required=("t", "F"), options=reading) for name in ("float.csv", "fixed.csv"))
    build = compile_cached(cart)                       # the build `pendc build` made (cached)
    budgets = build.options.budgets_for(build.model.interface)
    head = a.t <= build.error.seconds
    for state in ("x", "theta"):
        assert np.ptp(a.columns[state]) > 0.01, f"the chirp should move {state}"
        err = np.max(np.abs(a.columns[state][head] - b.columns[state][head]))
        assert err <= budgets[state], (state, err)


def test_diagnose_and_fit_find_the_hidden_damping(folder, capsys):
    """The data come from the file with its damping (the generator: 1 us Euler, DAC, noise,
    encoders); the model under test has no damping. diagnose names it; fit recovers b."""
    truth = load_model(folder / "my_cart.toml")
    # the pendulum's resonance pumped gently, so the cart (which has no friction) stays within a
    # bench's metre of its start, as the data check expects of a rig in metres
    t, u = Stimuli(truth.interface.input).swing_up(duration=20.0, amplitude=0.25)
    data = make_dataset(truth, t, u, seed=5)
    assert np.max(np.abs(data["x"])) < 1.0 and np.max(np.abs(data["theta"])) > 0.5
    (folder / "run.csv").write_text(format_csv(data, {"generator": "pendc.ident.datagen"}), encoding="utf-8")
    bare = re.sub(r"\[effects\.damping\]\nb = [^\n]*\n", "", example())
    assert "[effects.damping]" not in bare
    (folder / "bare.toml").write_text(bare, encoding="utf-8")
    out = pendc(capsys, "diagnose", folder / "run.csv", "--model", folder / "bare.toml", "--json")
    ranked = json.loads(out)["candidates"]
    assert ranked[0]["effect"] == "damping", [c["effect"] for c in ranked[:3]]
    pendc(capsys, "fit", folder / "run.csv", "--model", folder / "bare.toml", "--add", "damping",
          "-o", folder / "fitted.toml")
    fitted = load_model(folder / "fitted.toml")
    assert fitted.effects["damping"]["b"] == pytest.approx(DAMPING, rel=0.10)


def test_hil_swings_up_and_balances_on_the_golden_plant(folder, built, capsys):
    out = pendc(capsys, "hil", "--model", folder / "my_cart.toml", "--plant", "golden", "--seconds", "6",
                "--json")
    summary = json.loads(out)
    assert summary["upright_at_s"] is not None and summary["upright_at_s"] < 5.5, summary
