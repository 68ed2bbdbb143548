"""Acceptance of the identification workbench (issue 5) on the project's hidden-effect data:
the catalogue's cases, two hidden effects found in turn, physics outside the catalogue.

The nine single-effect cases (diagnose ranks the hidden effect first, fit recovers it) are
tests/test_diagnose_cases.py and tests/test_diagnose_more_cases.py, two files so that the
two xdist workers of ``make test`` run them side by side (tests/hidden_effect_cases.py).
Where a shipped data file is exactly what a test would generate (data/generate.py writes
them with the same generator and seeds), the file is read instead of simulating 20 s at
1 us again. The two effects found in turn are the exception: two diagnoses of every candidate
on 20 s cost more than simulating the standard experiment compressed to 14 s (every phase at
0.7 of its length; about 2 s), on which both effects still rank first by far and fit within
2 % (at 10 s x_0 comes within 9 %, too near the 10 % bound). The fit after a diagnosis starts
from the values the diagnosis fitted on half the data (its grid search has already found the
basin), as a user continuing from the diagnosis would.
"""

from pathlib import Path

import pytest

from hidden_effect_cases import BASE, CASES, as_measurement
from pendc.ident.datagen import identification_experiment, make_dataset
from pendc.ident.diagnose import EXPLAINED, candidate_effects, diagnose, free_parameters
from pendc.ident.fit import fit_parameters
from pendc.sim.measurements import format_csv, parse_measurements, read_measurements

DATA = Path(__file__).resolve().parents[1] / "data"


def test_there_are_at_least_eight_cases():
    assert len(CASES) >= 8
    for name, (true, tool) in CASES.items():
        assert name in true.effects and name not in tool.effects
        assert name in candidate_effects(tool)


# The rivals of the two hidden effects: what else pulls the cart towards a place (the end stops,
# an asymmetric friction) and what else brakes the swing by its speed (quadratic drag). Every
# other catalogue effect is ranked against each hidden one alone in tests/hidden_effect_cases.py;
# here the question is whether the second is found once the first is in the model.
RIVALS = ("cart_spring", "coulomb_pendulum", "quadratic_pendulum", "end_stops", "asymmetric_cart")


def test_two_hidden_effects_are_found_in_turn():
    true = BASE.with_effect("cart_spring", {"k_c": 300.0, "x_0": 0.05}).with_effect("coulomb_pendulum", {"tau_c": 0.004})
    t, u = identification_experiment(14.0)
    data = as_measurement(make_dataset(true, t, u), "two effects")
    model, found = BASE, []
    for _ in range(2):
        d = diagnose(model, [data], effects=[e for e in RIVALS if e not in model.effects])
        best = d.candidates[0]
        assert not d.unexplained, [(c.effect, c.score) for c in d.candidates]
        found.append(best.effect)
        model = fit_parameters(model.with_effect(best.effect), [data], free_parameters(best.effect),
                               start=best.params, search=False).model
    assert sorted(found) == ["cart_spring", "coulomb_pendulum"]
    truth = true.parameter_values()
    values = model.parameter_values()
    for p in ("k_c", "x_0", "tau_c"):
        assert values[p] == pytest.approx(truth[p], rel=0.10), p


def first_seconds(path, seconds):
    """The first ``seconds`` of a shipped file, as a measurement of its own."""
    full = read_measurements(path)
    n = int(round(seconds * 1000)) + 1          # the shipped files are sampled at 1 kHz
    return parse_measurements(format_csv({k: v[:n] for k, v in full.columns.items() if v is not None}),
                              source=f"{path.name}, first {seconds:g} s")


def test_physics_outside_the_catalogue_is_reported_unexplained():
    # make_ripple_dataset(BASE), as shipped: its first 12 s (the steps, the chirp and the start of
    # the resonant swing) leave every candidate as far from explaining the ripple as all 20 s do
    # (best score 0.03 and 0.002), for 0.6 of the diagnosis' cost
    data = first_seconds(DATA / "hidden_unexplained.csv", 12.0)
    d = diagnose(BASE, [data])
    assert d.unexplained
    assert d.candidates[0].score < EXPLAINED
    assert d.correlations and all({"signal", "target", "r"} <= set(r) for r in d.correlations)
    # the ripple depends on x: an x-periodic signal must be among what the residual follows
    assert any("x/0.06" in r["signal"] for r in d.correlations), d.correlations
    assert not d.at_noise_level and min(d.noise_ratio.values()) > 2


def test_complete_model_of_the_shipped_two_effect_data_is_at_the_noise_level():
    from pendc.ident.noise import NOISE_FACTOR, noise_ratio

    data = read_measurements(DATA / "hidden_two_effects.csv")
    spring = BASE.with_effect("cart_spring", {"k_c": 300.0, "x_0": 0.05})
    complete = noise_ratio(spring.with_effect("coulomb_pendulum", {"tau_c": 0.004}), [data])
    assert max(complete.values()) <= NOISE_FACTOR, complete
    assert noise_ratio(spring, [data])["theta"] > 5 * NOISE_FACTOR     # the pivot friction is still missing


def test_an_effect_on_the_input_is_a_candidate_and_one_asked_for_is_never_dropped_silently():
    """A state-form DC motor whose catalogue has a dead zone on its input: with nothing held the
    input moves every part, so the dead zone is a candidate (a state-form ladder's was left out,
    and `--effects input_dz` then scored nothing and said nothing: the private check); an effect
    the model has already is left out with its reason."""
    from pathlib import Path
    import numpy as np
    from pendc.ident.diagnose import candidate_effects, exclusions
    from pendc.model.modelfile import parse_model
    from pendc.sim.simulator import Simulator
    text = (Path(__file__).parent / "plant_dc_motor.toml").read_text(encoding="utf-8") + (
        '\n[catalogue.input_dz]\nkind = "dead_zone"\non = "v"\nwidth = "v_dz"\n'
        'params.v_dz = { unit = "V", default = 0.3, bounds = [0.0, 2.0], meaning = "driver dead zone" }\n')
    model = parse_model(text)
    t = np.arange(0, 0.5 + 1e-9, 1e-3)
    u = 0.5 * np.sin(2 * np.pi * 8 * t)
    run = Simulator(model, dt=1e-4, method="rk4")(t, u)
    from pendc.sim.readers import ReadOptions
    data = parse_measurements(format_csv({"t": t, "v": u, "phi": run["phi"]}), source="motor.csv",
                              options=ReadOptions(plant=model))
    assert "input_dz" in candidate_effects(model, [data])
    why = exclusions(model, [data])
    assert why["input_dz"] is None and why["bearing"] == "the model has it already"
