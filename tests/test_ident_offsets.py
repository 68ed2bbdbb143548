"""Sensor offsets and ties (issue 8 points 4 and 7), on data from the independent generator
(tests/independent_plant.py: hand-typed equations, RK4 at 20 us, its own encoders and noise).

A constant offset of the position sensor is invisible to a shooting residual that starts
every segment from the measured state, unless something in the physics depends on where
the cart really is. A rig engineer checks the sensor's zero against the track: runs of the
cart alone into the end stops, which are fixed to the track. On those, diagnose must rank
x_offset first and fit must recover it; where nothing depends on the absolute position,
diagnose must say the offset is not identifiable rather than guess; and where two effects
explain the data equally well (a centring spring makes an offset look like a constant
force, as direction-dependent friction does while the cart moves), it must say that the
data cannot separate them and which experiment would.
"""

import warnings

import pytest

from independent_plant import cart_alone, cart_driven, end_stop_runs
from pendc import load_model
from pendc.ident.diagnose import EXPLAINED, candidate_effects, diagnose, offset_blindness
from pendc.ident.fit import fit_parameters
from pendc.sim.measurements import format_csv, parse_measurements

BASE = load_model()
STOPS = dict(x_end=0.375, k_end=1e5, b_end=1e3)   # the rig's rubber buffers, known from its drawings
X_OFF = 0.02


def measured(columns, name):
    return parse_measurements(format_csv(columns, meta={"experiment": "pendulum_removed"}), source=name)


@pytest.fixture(scope="module")
def into_the_stops():
    t, e = end_stop_runs(1.5)
    return measured(cart_driven(t, e, x_off=X_OFF, **STOPS), "into the stops")


def test_runs_into_the_end_stops_find_the_position_offset(into_the_stops):
    tool = BASE.with_effect("end_stops", STOPS)
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # no numpy warning may escape
        d = diagnose(tool, [into_the_stops])
    ranking = [(c.effect, round(c.score, 3)) for c in d.candidates]
    assert d.candidates[0].effect == "x_offset", ranking
    assert d.candidates[0].score >= EXPLAINED and not d.unexplained
    assert d.tie is None, d.tie
    assert len(d.candidates) >= 5       # every cart effect the model lacks was a rival
    fitted = fit_parameters(tool.with_effect("x_offset"), [into_the_stops], ["x_off"],
                            start={"x_off": d.candidates[0].params["x_off"]})
    assert fitted.converged and not fitted.unidentifiable
    assert fitted.values["x_off"] == pytest.approx(X_OFF, rel=0.10)


def test_without_absolute_position_physics_the_offset_is_not_guessed():
    data = measured(cart_alone([0.6, 1.2], x_off=X_OFF), "mid-track runs")
    # the thesis' model: nothing depends on where the cart is
    assert "x_offset" not in candidate_effects(BASE, [data])
    d = diagnose(BASE, [data], effects=["x_offset"])
    assert not d.candidates
    assert any(n.startswith("x_offset is not tested") and "not identifiable" in n and "end stops" in n
               for n in d.notes), d.notes
    # asked to fit it anyway, the fit refuses to give it a value
    fitted = fit_parameters(BASE.with_effect("x_offset"), [data], ["x_off"], search=False, max_evaluations=5)
    assert "x_off" in fitted.unidentifiable
    # stops in the model but never reached: still nothing to see
    why = offset_blindness(BASE.with_effect("end_stops", STOPS), [data], "x", reach=0.2)
    assert "never comes near the end stops" in why


SPRING = dict(k_c=300.0, x_0=0.0)


@pytest.fixture(scope="module")
def spring_tie():
    # with a spring centred on the track, an offset of the sensor is a constant force on the
    # cart, and so, while the cart moves, is friction that differs by direction
    columns = cart_alone([0.6, 1.0, 1.5], x_off=0.03, **SPRING)
    d = diagnose(BASE.with_effect("cart_spring", SPRING), [measured(columns, "spring runs")],
                 effects=["x_offset", "asymmetric_cart"])
    return columns, d


def test_a_centring_spring_cannot_separate_offset_from_asymmetric_friction(spring_tie):
    _, d = spring_tie
    assert d.candidates[0].score >= EXPLAINED
    assert d.tie is not None, [(c.effect, c.score) for c in d.candidates]
    assert set(d.tie["effects"]) == {"x_offset", "asymmetric_cart"}
    assert "cannot separate" in d.tie["message"] and "into the end stops" in d.tie["separate_by"]
    assert d.to_json()["tie"] == d.tie


def test_diagnose_prints_the_tie_in_text_and_json(spring_tie, tmp_path, capsys, monkeypatch):
    """The command line shows a tie in place of "Most likely missing" (the diagnosis is the
    fixture's, handed to the command instead of being computed again)."""
    import json

    from pendc.cli import main
    from pendc.ident import diagnose as diagnose_module
    from pendc.model.model_writer import save_model

    columns, d = spring_tie
    path = tmp_path / "spring_runs.csv"
    path.write_text(format_csv(columns, meta={"experiment": "pendulum_removed"}))
    save_model(BASE.with_effect("cart_spring", SPRING), tmp_path / "spring.toml")
    asked = []
    monkeypatch.setattr(diagnose_module, "diagnose", lambda *a, **k: (asked.append(k["effects"]), d)[1])
    argv = ["diagnose", str(path), "--model", str(tmp_path / "spring.toml"), "--effects", "x_offset,asymmetric_cart"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "Most likely missing" not in out and asked == [["x_offset", "asymmetric_cart"]]
    ambiguous = next(line for line in out.splitlines() if line.startswith("Ambiguous: "))
    assert "x_offset and asymmetric_cart explain the error equally well" in ambiguous and "end stops" in ambiguous
    assert main(argv + ["--json"]) == 0
    tie = json.loads(capsys.readouterr().out)["tie"]
    assert tie["effects"] == d.tie["effects"] and tie["message"] == d.tie["message"]
