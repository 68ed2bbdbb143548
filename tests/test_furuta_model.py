"""The Furuta pendulum's model files, effect catalogue and experiments: what a file selects,
what it must hold, and the one-line errors when it does not."""

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import pendc
from pendc.errors import PendcError
from plants import CATALOGUE, plant_named
from pendc.model.modelfile import model_fingerprint, parse_model
from pendc.model.model_writer import dumps_fitted, dumps_model
from test_furuta import flow  # the model's equations as a plain function, one definition

QUBE = Path(__file__).resolve().parents[1] / "models" / "furuta_qube.toml"
PLANT = '[plant]\nbody = "furuta"\ng = 9.81\nJ_r = 5.72e-5\nL_r = 0.085\nm_p = 0.024\nL_p = 0.129\n'
MOTOR = "[effects.motor_drive]\nR_m = 8.4\nk_t = 0.042\nk_m = 0.042\n"


@pytest.fixture(scope="module")
def qube():
    return pendc.load_model(QUBE)


def test_the_shipped_model_has_the_published_figures(qube):
    v = qube.parameter_values()
    assert qube.body == "furuta" and qube.source.endswith("furuta_qube.toml")
    assert (v["R_m"], v["k_t"], v["k_m"]) == (8.4, 0.042, 0.042)
    assert (v["L_r"], v["m_p"], v["L_p"]) == (0.085, 0.024, 0.129)
    assert v["J_r"] == pytest.approx(0.095 * 0.085 ** 2 / 12, rel=1e-7)     # Quanser's m_r L_r^2 / 12
    assert (v["D_r"], v["D_p"]) == (0.0015, 0.0005)
    assert list(qube.effects) == ["motor_drive", "viscous_arm", "viscous_pivot"]
    assert list(qube.catalogue) == ["motor_drive", "voltage_limit", "viscous_arm", "coulomb_arm", "viscous_pivot",
                                    "coulomb_pivot", "alpha_offset"]
    assert set(qube.experiments) == {"free", "arm_held", "pendulum_removed"}


def test_a_file_of_values_alone_is_read_against_the_default_plant():
    default = pendc.load_model()
    assert default.body == "cart_pendulum" and default.catalogue == CATALOGUE
    assert 'body' not in tomllib.loads(dumps_model(default))['plant'] and 'name = "cart_pendulum"' in dumps_model(default)
    assert plant_named("furuta").body == "furuta"


def test_round_trip_keeps_the_body(qube, tmp_path):
    path = tmp_path / "q.toml"
    pendc.save_model(qube, path)
    again = pendc.load_model(path)
    assert again == qube and again.body == "furuta"
    assert model_fingerprint(again) == model_fingerprint(qube)
    fitted = dumps_fitted(qube.with_params({"D_r": 0.002}), QUBE.read_text(), {"note": "test"},
                          {"D_r": (0.0019, 0.0021)})
    back = parse_model(fitted)
    assert back.body == "furuta" and back.parameter_values()["D_r"] == 0.002


def test_naming_the_default_body_changes_nothing():
    cart_text = "[plant]\ng=9.8\nM=100.0\nm=0.5\nL=0.1\nI=0.006\n"
    same = parse_model(cart_text.replace("[plant]\n", '[plant]\nbody = "cart_pendulum"\n'))
    assert model_fingerprint(same) == model_fingerprint(parse_model(cart_text))


@pytest.mark.parametrize("text, message", [
    (PLANT.replace('"furuta"', '"double_pendulum"'), r"plant.body = 'double_pendulum' is not a shipped plant .*known: .*cart_pendulum, .*furuta"),
    (PLANT.replace('"furuta"', "3"), "plant.body must be a string"),
    (PLANT.replace("L_p = 0.129\n", ""), r"\[plant\] lacks L_p \(plant 'furuta': L_p, pendulum length"),
    (PLANT + "M = 100.0\n", r"unknown constant\(s\) M \(known for plant 'furuta': g J_r L_r m_p L_p; and the keys name, core"),
    ('[plant]\nbody = "furuta"\ng=9.8\nM=100.0\nm=0.5\nL=0.1\nI=0.006\n', "unknown constant"),
    (PLANT + "[effects.drive]\nalpha = 1.0\nV_off = 5.0\n", r"unknown effect 'drive' for plant 'furuta' \(known: motor_drive"),
    (PLANT + "[effects.motor_drive]\nR_m = 8.4\nk_t = 0.042\n", r"\[effects.motor_drive\] lacks parameter 'k_m'"),
    (PLANT + MOTOR.replace("R_m = 8.4", "R_m = -1.0"), r"motor_drive.R_m = -1.0 is outside its physical range"),
    (PLANT + "[effects.voltage_limit]\nV_max = 5.0\n", "effect 'voltage_limit' needs one of: motor_drive"),
    (PLANT.replace("J_r = 5.72e-5", "J_r = 0.0"), "plant.J_r must be positive"),
    (PLANT + "[fit]\nfree = ['b_x']\n", "free names unknown parameter 'b_x'"),
])
def test_bad_furuta_files_are_one_line_errors(text, message):
    with pytest.raises(PendcError, match=message) as err:
        parse_model(text, source="f.toml")
    assert "\n" not in str(err.value) and str(err.value).startswith("f.toml: ")


def test_experiments_belong_to_the_body(qube):
    with pytest.raises(PendcError, match=r"unknown experiment 'cart_held' \(known: free, arm_held, pendulum_removed\)"):
        qube.for_experiment("cart_held")
    with pytest.raises(PendcError, match="unknown experiment 'arm_held'"):
        pendc.load_model().for_experiment("arm_held")
    assert qube.equations.outputs() == ("phi_r", "alpha_p")
    assert qube.for_experiment("arm_held").equations.outputs() == ("alpha_p",)
    assert qube.for_experiment("pendulum_removed").equations.outputs() == ("phi_r",)


def _accelerations(model, y, u):
    return flow(model)(y, u)


def test_a_held_arm_leaves_a_compound_pendulum(qube):
    """Arm clamped: the pendulum alone, a thin rod about its end: alpha'' = -(3 g / 2 L_p) sin alpha
    - D_p alpha' / (m_p L_p^2 / 3); the arm does not move whatever the voltage."""
    v = qube.parameter_values()
    held = qube.for_experiment("arm_held")
    for alpha, dalpha, u in ((0.4, 1.0, 10.0), (-2.0, -3.0, -7.0)):
        d = _accelerations(held, (0.0, 0.0, alpha, dalpha), u)
        J = v["m_p"] * v["L_p"] ** 2 / 3
        assert d[0] == 0 and d[1] == 0
        assert d[3] == pytest.approx(-1.5 * v["g"] / v["L_p"] * math.sin(alpha) - v["D_p"] * dalpha / J, rel=1e-12)


def test_without_the_pendulum_the_motor_turns_the_arm(qube):
    v = qube.parameter_values()
    removed = qube.for_experiment("pendulum_removed")
    d = _accelerations(removed, (1.0, 5.0, 0.0, 0.0), 6.0)
    tau = v["k_t"] * (6.0 - v["k_m"] * 5.0) / v["R_m"] - v["D_r"] * 5.0
    assert d[1] == pytest.approx(tau / v["J_r"], rel=1e-12) and d[3] == 0


def test_each_effect_adds_what_it_says(qube):
    base = pendc.load_model(QUBE)
    y = (0.2, 3.0, 0.5, -2.0)
    d0 = _accelerations(base, y, 4.0)
    dry = base.with_effect("coulomb_arm", {"tau_r": 0.004})
    assert dry.equations.assignment("tau_arm").has(sp.sign)
    d1 = _accelerations(dry, y, 4.0)
    d2 = _accelerations(base, y, 4.0 - 0.004 * 8.4 / 0.042)       # the same torque less, by voltage
    assert np.allclose(d1, d2, rtol=1e-12)
    assert not np.allclose(d0, d1)
    limited = base.with_effect("voltage_limit", {"V_max": 3.0})
    assert np.allclose(_accelerations(limited, y, 9.0), _accelerations(base, y, 3.0), rtol=1e-12)
    offset = base.with_effect("alpha_offset", {"alpha_p_off": 0.1})
    assert [(n, str(o)) for n, o in offset.equations.sensor_offsets] == [("alpha_p", "alpha_p_off")]
    assert np.allclose(_accelerations(offset, y, 4.0), d0, rtol=0)


def test_catalogue_entries_describe_themselves():
    furuta = plant_named("furuta").catalogue
    for name, cls in furuta.items():
        assert cls.name == name and cls.summary and cls.params
        assert cls.acts_on in ("arm", "pendulum", "alpha_p")
        for p in cls.params:
            assert p.lo <= p.default <= p.hi and p.unit and p.description
    assert not set(furuta) & set(CATALOGUE)
    params = {p.name for cls in furuta.values() for p in cls.params}
    assert not params & {p.name for cls in CATALOGUE.values() for p in cls.params}
