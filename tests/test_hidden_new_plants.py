"""The hidden-effect story on the plants added as files (issue 21), on data from outside pendc.

``tests/independent_new_plants.py`` integrates equations of motion written by hand (scipy,
one solve_ivp call per held input sample) under a stabilising feedback of its own, and reads
the sensors as the hardware does (x4 encoders counted from the start, the ball's 12-bit
converter read as the middle of its step). First, without a hidden effect, pendc's float
simulation of the recorded input follows that integration (so the plant files and the
hand-written equations say the same thing). Then each plant gets an effect of the file's
catalogue that the shipped model does not have:

* ball and beam: rolling resistance of the ball, ``ball_rolling`` (viscous on x), b_x = 0.08 N*s/m;
* two-mass drive: viscous friction of the arm's bearing, ``viscous_load`` (viscous on alpha),
  B_l = 4e-3 N*m*s/rad (Quanser takes it as negligible);
* double pendulum on a cart: an offset of the bottom link's encoder, ``alpha_offset``,
  0.1 rad (the links swing hanging under a cart that follows steps; gravity sees the offset);

and ``pendc diagnose`` (command line) must rank it first, ``pendc fit --add`` must recover it
within 10 % and the 0.5 s horizon error must fall. The ball and beam's catalogue has that one
effect only, so its ranking is also run on a copy of the file with generic rivals added to the
catalogue (dry friction and quadratic drag of the ball, an offset of its converter, dry friction
of the servo).
"""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

import pendc
from cli_capture import run_cli

sys.path.insert(0, str(Path(__file__).resolve().parent))
import independent_new_plants as gen  # noqa: E402

MODELS = Path(__file__).resolve().parents[1] / "models"

# plant -> (hidden effect, its parameter, the value hidden, seconds of data, the coordinate it acts on)
STORIES = {
    "ball_beam": ("ball_rolling", "b_x", 0.08, 8.0, "x"),
    "two_mass_drive": ("viscous_load", "B_l", 4e-3, 6.0, "alpha"),
    "double_pendulum_cart": ("alpha_offset", "alpha_off", 0.1, 2.0, "alpha"),
}
SEED = 1
# The double pendulum's simulation kernel is ~70x slower than the others' (pendc prints its
# fully expanded mass-matrix solution, ~50 kB of source per right-hand side), so its diagnose
# tests one rival (the hinge's dry friction) and its fit has a small budget; diagnosed with every
# candidate the model lacks on 6 s of data, the ranking is the same (alpha_offset 0.999, the
# others 0) but takes ~400 s.
DIAGNOSE_ONLY = {"double_pendulum_cart": "alpha_offset,coulomb_upper"}
FIT_BUDGET = {"double_pendulum_cart": 20}
SENSOR_EFFECTS = {"alpha_offset"}        # the motion is unchanged, the reading moves


def model_path(plant: str) -> Path:
    return MODELS / f"{plant}.toml"


def resolution(model, state: str) -> float:
    return model.interface.sensor_of(state).resolution


@pytest.fixture(scope="module")
def models():
    return {plant: pendc.load_model(model_path(plant)) for plant in STORIES}


@pytest.fixture(scope="module")
def clean_runs():
    """Exact (unquantised) closed-loop runs without a hidden effect."""
    return {plant: gen.run(plant, seconds=3.0, seed=SEED + 1, quantize=False) for plant in STORIES}


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """One data file per plant, the effect hidden: ``{plant: (path, run)}``."""
    folder = tmp_path_factory.mktemp("hidden_new_plants")
    out = {}
    for plant, (_, param, value, seconds, _) in STORIES.items():
        run = gen.run(plant, seconds=seconds, seed=SEED, hidden={param: value})
        path = folder / f"{plant}_{param}.csv"
        gen.write_csv(path, run)
        out[plant] = (path, run)
    return out


# -- the generator against pendc, nothing hidden -------------------------------------------------

@pytest.mark.parametrize("plant", sorted(STORIES))
def test_the_generator_uses_the_files_values(plant, models):
    """The generator reads the numbers with tomllib; pendc's model has the same ones."""
    values = models[plant].parameter_values()
    mine = gen.file_values(plant)
    assert mine and {k: values[k] for k in mine} == pytest.approx(mine, rel=1e-12)
    for state, spec in gen.file_sensors(plant).items():
        step = spec[1] if spec[0] == "encoder" else (spec[3] - spec[2]) / 2 ** spec[1]
        assert resolution(models[plant], state) == pytest.approx(step, rel=1e-9)


@pytest.mark.parametrize("plant", sorted(STORIES))
def test_pendcs_simulator_follows_the_independent_integration(plant, models, clean_runs):
    """The float simulation (RK4, 0.1 ms) of the recorded input stays on the hand-written
    equations' trajectory within a hundredth of a sensor step over the whole record."""
    run = clean_runs[plant]
    model = models[plant]
    res = pendc.Simulator(model, dt=1e-4, method="rk4")(run["t"], run["u"])
    for state in gen.PLANTS[plant]["positions"]:
        q = resolution(model, state)
        assert np.ptp(run[f"true_{state}"]) > 100 * q, f"{state} hardly moved"
        err = float(np.max(np.abs(res[state] - run[f"true_{state}"])))
        assert err < 0.01 * q, (state, err, q)
    for rate in gen.PLANTS[plant]["rates"]:
        scale = float(np.max(np.abs(run[f"true_{rate}"])))
        assert float(np.max(np.abs(res[rate] - run[f"true_{rate}"]))) < 1e-4 * scale, rate
    assert np.max(np.abs(run["u"])) < 10.0                         # the feedback never saturates


@pytest.mark.parametrize("plant", sorted(STORIES))
def test_the_sensors_read_as_pendcs(plant, models, clean_runs):
    """The generator's encoders (whole counts from the start) and converter (the middle of the
    code's step, absolute) read the true states as pendc's quantised simulation does."""
    run = clean_runs[plant]
    read = gen.read_sensors(plant, {k[5:]: v for k, v in run.items() if k.startswith("true_")})
    res = pendc.Simulator(models[plant], dt=1e-4, method="rk4")(run["t"], run["u"], quantize=True)
    for state in gen.PLANTS[plant]["positions"]:
        q = resolution(models[plant], state)
        steps = (read[state] - res.measured(state)) / q
        assert np.max(np.abs(steps)) < 1.0 + 1e-6, state
        assert np.count_nonzero(np.abs(steps) > 1e-6) <= 2, state        # only a state on a step edge
        lag = run[f"true_{state}"] - read[state]
        if gen.file_sensors(plant)[state][0] == "encoder":
            assert np.all(lag > -1e-9) and np.all(lag < q * (1 + 1e-9))
        else:
            assert np.all(np.abs(lag) <= q / 2 * (1 + 1e-9))


@pytest.mark.parametrize("plant", sorted(STORIES))
def test_the_hidden_effect_shows_and_the_catalogue_effect_reproduces_it(plant, models, recordings):
    """On the recording's true states: the catalogue effect with the hidden value follows them,
    the shipped model without it is off by several sensor steps."""
    effect, param, value, _, state = STORIES[plant]
    run = recordings[plant][1]
    model = models[plant]
    assert effect in model.catalogue and effect not in model.effects
    with_it = pendc.Simulator(model.with_effect(effect, {param: value}), dt=1e-4, method="rk4")(run["t"], run["u"])
    without = pendc.Simulator(model, dt=1e-4, method="rk4")(run["t"], run["u"])
    q = resolution(model, state)
    reading = run[f"true_{state}"] + (value if effect in SENSOR_EFFECTS else 0.0)     # exact
    assert np.max(np.abs(with_it.measured(state) - reading)) < 0.01 * q
    assert np.max(np.abs(without.measured(state) - reading)) > 5 * q


# -- diagnose and fit, through the command line ----------------------------------------------------

def diagnose(capsys, data: Path, model: Path, only: str | None = None) -> dict:
    rc, out, err = run_cli(capsys, "diagnose", data, "--model", model, "--workers", "1", "--json",
                           *(("--effects", only) if only else ()))
    assert rc == 0, err
    return json.loads(out)


@pytest.mark.parametrize("plant", sorted(STORIES))
def test_diagnose_ranks_the_hidden_effect_first(plant, recordings, models, capsys):
    effect, param, value, _, _ = STORIES[plant]
    d = diagnose(capsys, recordings[plant][0], model_path(plant), DIAGNOSE_ONLY.get(plant))
    names = [c["effect"] for c in d["candidates"]]
    if plant in DIAGNOSE_ONLY:
        assert names and set(names) == set(DIAGNOSE_ONLY[plant].split(",")), names
    assert set(names) <= set(models[plant].catalogue) - set(models[plant].effects)
    assert names[0] == effect, names
    best = d["candidates"][0]
    assert best["score"] > 0.8 and not d["unexplained"] and not d["tie"], best
    assert best["params"][param] == pytest.approx(value, rel=0.10)
    if len(names) > 1:
        assert d["candidates"][1]["score"] < best["score"] - 0.2, [(c["effect"], c["score"]) for c in d["candidates"]]


# generic rivals for the ball and beam's one catalogue effect (a copy of the file, in tmp)
BALL_RIVALS = '''
[catalogue.ball_dry]
kind = "coulomb"
on = "x"
level = "F_c"
summary = "dry rolling friction of the ball, -F_c sgn(dx)"
evidence = "the residual force on the ball opposes the sign of its velocity: dry friction"
separated_by = "the beam tilted in small steps: dry friction holds the ball below a threshold tilt"
params.F_c = { unit = "N", default = 0.0, bounds = [0.0, 0.05], meaning = "dry rolling friction force" }

[catalogue.ball_drag]
kind = "quadratic_drag"
on = "x"
coefficient = "c_x"
summary = "quadratic drag on the ball, -c_x dx |dx|"
evidence = "the residual force on the ball grows with the square of its velocity: drag"
separated_by = "runs at several speeds: drag grows with the square of the speed"
params.c_x = { unit = "N*s^2/m^2", default = 0.0, bounds = [0.0, 20.0], meaning = "quadratic drag coefficient" }

[catalogue.x_offset]
kind = "offset"
on = "x"
offset = "x_off"
summary = "the ball's converter reads x + x_off"
evidence = "the ball balances where the converter does not read the beam's middle: an offset"
separated_by = "the beam level, the ball at rest in the middle: the reading is the offset"
params.x_off = { unit = "m", default = 0.0, bounds = [-0.02, 0.02], meaning = "offset of the ball's converter" }

[catalogue.servo_coulomb]
kind = "coulomb"
on = "theta"
level = "tau_c"
summary = "dry friction of the servo, -tau_c sgn(dtheta)"
evidence = "the residual torque on the servo opposes the sign of its rate: dry friction"
separated_by = "steady speeds at several voltages: dry friction offsets the speed against voltage line"
params.tau_c = { unit = "N*m", default = 0.0, bounds = [0.0, 0.1], meaning = "dry friction torque of the servo" }
'''


def test_diagnose_picks_the_rolling_resistance_among_generic_rivals(recordings, tmp_path, capsys):
    rich = tmp_path / "ball_beam_rivals.toml"
    rich.write_text(model_path("ball_beam").read_text(encoding="utf-8") + BALL_RIVALS, encoding="utf-8")
    d = diagnose(capsys, recordings["ball_beam"][0], rich)
    ranked = [(c["effect"], round(c["score"], 3)) for c in d["candidates"]]
    assert {"ball_rolling", "ball_dry", "ball_drag", "servo_coulomb"} <= {e for e, _ in ranked}, ranked
    assert ranked[0][0] == "ball_rolling" and not d["tie"], (ranked, d["tie"])
    assert d["candidates"][0]["params"]["b_x"] == pytest.approx(STORIES["ball_beam"][2], rel=0.10)


@pytest.mark.parametrize("plant", sorted(STORIES))
def test_fit_recovers_the_hidden_effect_and_the_error_falls(plant, recordings, tmp_path, capsys):
    effect, param, value, _, state = STORIES[plant]
    new = tmp_path / "fitted.toml"
    rc, out, err = run_cli(capsys, "fit", recordings[plant][0], "--model", model_path(plant), "--add", effect,
                           "-o", new, "--json",
                           *(("--max-evaluations", FIT_BUDGET[plant]) if plant in FIT_BUDGET else ()))
    assert rc == 0, err
    f = json.loads(out)
    got, (lo, hi) = f["params"][param]["value"], f["params"][param]["ci95"]
    assert got == pytest.approx(value, rel=0.10) and lo < got < hi, (got, lo, hi)
    before, after = f["fit_before"]["pooled"], f["fit_after"]["pooled"]
    assert after[state] > before[state] + 3.0, (before, after)
    assert all(after[k] >= before[k] - 0.05 for k in before), (before, after)
    fitted = pendc.load_model(new)
    assert fitted.effects[effect][param] == pytest.approx(got)
