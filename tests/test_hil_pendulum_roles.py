"""The balance and swing-up controllers on any pendulum plant: the coordinates by role, the held
pendulum's physics against textbook formulas, the Furuta's upright linearisation against a hand
derivation, and the LQR holding the Furuta upright in the bit-exact golden model.

The controllers (pendc.hil.controllers) name no state of either plant: they find the actuated
coordinate and the pendulum angle from the plant interface and the model's equations
(pendc.hil.controllers.pendulum_roles). The textbook formulas here are written from the model files'
constants, a path independent of pendc's derivation.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from pendc import load_model
from pendc.errors import PendcError
from pendc.hil.controllers.controller_spec import make_controller
from pendc.hil.controllers.pendulum import EnergySwingUp, LqrBalance, PendulumConstants, Supervisor
from pendc.hil.controllers.measurement import Measurement
from pendc.hil.loop import run_closed_loop
from pendc.hil.controllers.pendulum_roles import pendulum_roles
from pendc.hil.plants.plant import make_plant

ROOT = Path(__file__).resolve().parents[1]
FINAL = ROOT / "models" / "sct_thesis_final.toml"
FURUTA = ROOT / "models" / "furuta_qube.toml"
TILT = 0.05          # rad from the upright at the start of the Furuta balance run
BALANCE_SECONDS = 3.0


@pytest.fixture(scope="module")
def cart():
    return load_model(str(FINAL))


@pytest.fixture(scope="module")
def furuta():
    return load_model(str(FURUTA))


@pytest.fixture(scope="module")
def furuta_consts(furuta):
    return PendulumConstants.from_model(furuta)


def test_roles_of_both_plants(cart, furuta):
    r = pendulum_roles(cart)
    assert (r.actuated.position, r.actuated.rate, r.actuated.unit, r.actuated.period) == ("x", "dx", "m", None)
    assert (r.pendulum.position, r.pendulum.rate, r.pendulum.unit) == ("theta", "dtheta", "rad")
    assert r.upright == pytest.approx(math.pi) and r.order(5) == [0, 1, 2, 3, 4]
    f = pendulum_roles(furuta)
    # both Furuta angles are periodic: only the physics (gravity restores the pendulum) tells them apart
    assert (f.actuated.position, f.actuated.rate, f.actuated.period) == ("phi_r", "dphi_r", pytest.approx(2 * math.pi))
    assert (f.pendulum.position, f.pendulum.rate, f.pendulum.index, f.pendulum.rate_index) == ("alpha_p", "dalpha_p", 2, 3)


def test_held_pendulum_physics_matches_the_textbook(cart, furuta, furuta_consts):
    """omega0^2 = m g l / J_hinge of the pendulum with the cart or arm held, and the coupling
    |d(angular accel)/d(pivot accel)| = m l r / J_hinge (r: the pivot's lever, 1 for a cart)."""
    p = cart.parameter_values()
    c = PendulumConstants.from_model(cart)
    j = p["m"] * p["L"] ** 2 + p["I"]
    assert c.omega0_sq == pytest.approx(p["m"] * p["g"] * p["L"] / j, rel=1e-9)
    assert abs(c.coupling) == pytest.approx(p["m"] * p["L"] / j, rel=1e-9)
    # the swing-up's gains on the cart are the ones it was tuned with (5 m/s^2, 100 m/s^2 per J)
    swing = EnergySwingUp(c)
    assert swing.accel_max == pytest.approx(5.0, rel=1e-9)
    assert swing.gain == pytest.approx(100 * p["m"] * p["g"] * p["L"], rel=1e-9)
    q = furuta.parameter_values()
    l, j_hinge = q["L_p"] / 2, q["m_p"] * q["L_p"] ** 2 / 3          # a uniform thin rod
    assert furuta_consts.omega0_sq == pytest.approx(q["m_p"] * q["g"] * l / j_hinge, rel=1e-9)
    assert abs(furuta_consts.coupling) == pytest.approx(q["m_p"] * l * q["L_r"] / j_hinge, rel=1e-9)
    assert furuta_consts.input_range == (-10.0, 10.0) and c.input_range == (0.0, 10.0)


def test_furuta_upright_linearisation_matches_a_hand_derivation(furuta, furuta_consts):
    """The Furuta linearised by hand at the upright (alpha = pi + d): mass matrix
    [[J_r + m L_r^2, s m L_r l], [s m L_r l, m L_p^2 / 3]] (s = ±1: the sense of the angles)
    times (ddphi, ddd) equals (k_t u / R_m - (D_r + k_t k_m / R_m) dphi, m g l d - D_p dd)."""
    q = furuta.parameter_values()
    m, l = q["m_p"], q["L_p"] / 2
    b_arm = q["D_r"] + q["k_t"] * q["k_m"] / q["R_m"]
    lin = furuta_consts.lin
    matches = []
    for s in (1.0, -1.0):
        mass = np.array([[q["J_r"] + m * q["L_r"] ** 2, s * m * q["L_r"] * l], [s * m * q["L_r"] * l, m * q["L_p"] ** 2 / 3]])
        inv = np.linalg.inv(mass)
        acc = inv @ np.array([[0.0, -b_arm, 0.0, 0.0], [0.0, 0.0, m * q["g"] * l, -q["D_p"]]])
        A = np.array([[0, 1, 0, 0], acc[0], [0, 0, 0, 1], acc[1]], dtype=float)
        B = np.array([0.0, inv[0, 0], 0.0, inv[1, 0]]) * q["k_t"] / q["R_m"]
        matches.append(np.allclose(lin.A, A, rtol=1e-6, atol=1e-9) and np.allclose(lin.B.ravel(), B, rtol=1e-6))
    assert any(matches)
    assert lin.u0 == pytest.approx(0.0, abs=1e-9)
    assert sum(e.real > 1e-6 for e in np.linalg.eigvals(lin.A)) == 1


def test_builtin_controllers_are_designed_for_the_furuta(furuta, furuta_consts):
    sup = make_controller("builtin", furuta)
    assert isinstance(sup, Supervisor) and sup.input_range == (-10.0, 10.0)
    assert sup.balance.c.actuated == "phi_r" and sup.balance.c.angle == "alpha_p"
    # the discrete LQR stabilises the sampled Furuta
    lqr = LqrBalance(furuta_consts).lqr
    assert np.max(np.abs(np.linalg.eigvals(lqr.Ad - lqr.Bd @ lqr.K[None, :]))) < 1.0


def test_swing_up_pushes_the_furuta_arm_to_add_energy(furuta, furuta_consts):
    """The pendulum hanging, swinging: the arm is pushed the way that raises the pendulum's
    energy (coupling * rate * cos(angle) > 0), and the other way for the opposite swing."""
    swing = EnergySwingUp(furuta_consts)
    enc = [e for e in make_plant("float", furuta).ports.encoders]
    meas = Measurement(0.0, tuple((e.name, 0) for e in enc), tuple(enc))
    u0, sense = furuta_consts.lin.u0, math.copysign(1.0, furuta_consts.coupling)
    assert (swing.command(meas, 0.0, 2.0) - u0) * sense * furuta_consts.lin.B[1, 0] > 0
    assert (swing.command(meas, 0.0, -2.0) - u0) * sense * furuta_consts.lin.B[1, 0] < 0


def test_a_plant_without_a_pendulum_is_refused(furuta):
    removed = dataclasses.replace(furuta, experiment="pendulum_removed")
    with pytest.raises(PendcError, match="one pendulum") as err:
        make_controller("balance", removed)
    assert "\n" not in str(err.value)


class _StartedAt:
    """A controller whose encoders were zeroed at a known start: counts plus the start's counts
    (the golden plant's encoders count from its initial state, as at power-on)."""

    def __init__(self, inner, offsets: dict):
        self.inner, self.offsets, self.input_range = inner, offsets, inner.input_range
        self.mode = inner.mode

    def reset(self):
        self.inner.reset()

    def step(self, meas):
        counts = tuple((e, n + self.offsets.get(e, 0)) for e, n in meas.counts)
        return self.inner.step(Measurement(meas.t, counts, meas.encoders))


def test_the_lqr_holds_the_furuta_upright_in_the_golden_model(furuta, furuta_consts):
    """From TILT off the upright at rest, the LQR designed on the model's own linearisation
    holds the pendulum within a few encoder counts of the upright, the arm near its start."""
    c, iface = furuta_consts, furuta.interface
    start = {s: 0.0 for s in iface.outputs}
    start[c.angle] = c.roles.upright + TILT
    enc = iface.sensor_of(c.angle)
    offset = round(start[c.angle] / enc.resolution)
    plant = make_plant("golden", furuta, initial=tuple(start[s] for s in iface.outputs))
    run = run_closed_loop(plant, _StartedAt(LqrBalance(c), {enc.name: offset}), BALANCE_SECONDS)
    assert run.stopped is None, run.stopped
    angle = run.column(c.angle) + offset * enc.resolution
    phi = np.array([c.upright_error(a) for a in angle])
    assert abs(phi[0] - TILT) <= enc.resolution
    assert np.max(np.abs(phi)) < TILT + 0.02                    # it never falls further
    last = run.t >= BALANCE_SECONDS - 1.0
    assert np.max(np.abs(phi[last])) <= 5 * enc.resolution       # held within 5 counts (15 mrad)
    assert np.max(np.abs(run.column(c.actuated))) < 0.5          # the arm stays within 0.5 rad


def test_an_angle_the_input_drives_is_no_pendulum():
    """Two rotors, one input driving both, a spring restoring one: the sprung angle is driven, so
    no pendulum; builtin is the LQR about the operating point (it took the sprung angle for a
    pendulum and stopped: 'the pendulum ... is not at rest at 3.14159 rad')."""
    from pendc.hil.controllers.operating_point_lqr import OperatingPointLqr
    from pendc.hil.controllers.pendulum_roles import driven_positions
    model = load_model(str(Path(__file__).parent / "data" / "two_driven_rotors.toml"))
    assert driven_positions(model) == {"a", "b"}
    with pytest.raises(PendcError, match="0 of them is such an angle"):
        pendulum_roles(model)
    assert isinstance(make_controller("builtin", model), OperatingPointLqr)
    cart = load_model()
    assert driven_positions(cart) == {"x"} and pendulum_roles(cart).pendulum.position == "theta"


def test_the_summary_and_the_reports_follow_the_pendulum_not_the_declaration_order(tmp_path):
    """A reaction-wheel pendulum written pendulum first, wheel second (the private check): the run's
    upright was judged on the wheel (the last periodic encoder), so a balanced pendulum read 'not
    upright'; compare's swing regimes and wrapped fit took the wheel too."""
    from pendc.hil.loop import run_closed_loop, upright_angle
    from pendc.hil.plants.plant import FloatPlant
    from pendc.ident.compare import angle_of
    from pendc.ident.regimes import regime_partitions
    model = load_model(str(Path(__file__).parent / "data" / "reaction_wheel.toml"))
    plant = FloatPlant(model)
    assert upright_angle(plant.ports) == "phi"          # the old rule: the last periodic encoder
    assert upright_angle(plant.ports, model) == "theta"
    assert angle_of(model) == "theta"
    z = np.zeros(3)
    parts = {p: [m[1] for m in ms] for p, ms in regime_partitions(model, {"theta": z, "dtheta": z, "phi": z,
                                                                           "dphi": z}, z, 0.0)}
    assert parts["pendulum angle"][0] == "|theta| < 0.3 rad from hanging down"
    assert parts["wheel motion"][0] == "|dphi| < 0.05 rad/s"
    run = run_closed_loop(plant, make_controller("lqr", model), 0.05)
    assert run.angle == "theta"
    from pendc.hil.controllers.start_point import start_moved
    assert start_moved(model, plant.ports) == "theta"        # --start moved the wheel


def test_a_sensor_offset_left_out_of_the_hil_plant_is_said(tmp_path, capsys):
    """An encoder's offset is its homing's: the core and the HIL plants leave it out (a converter's is
    in the core: test_adc_sensor); the command says so."""
    from cli_capture import run_cli
    text = (Path(__file__).parent / "data" / "reaction_wheel.toml").read_text()
    model = tmp_path / "offset.toml"
    model.write_text(text + "\n[effects.theta_offset]\ntheta_off = 0.01\n")
    rc, _, err = run_cli(capsys, "hil", "--model", model, "--controller", "hold", "--seconds", "0.01")
    assert rc == 0 and "theta_offset (a sensor offset on an encoder) is left out of the float plant" in err


def test_a_reaction_wheel_is_balanced_as_a_momentum_store():
    """The private check's wheel pendulum was caught eleven times in 40 s and lost each time: the
    balance weighed the wheel's angle like a cart's centimetre. Where the actuated coordinate must
    turn more than ten times as far as the pendulum, its weights scale with that lever; the SCT's
    cart and the QUBE's arm keep the thesis' weights."""
    from pendc.hil.controllers.pendulum import LQR_Q, balance_weights
    wheel = PendulumConstants.from_model(load_model(Path(__file__).parent / "data" / "reaction_wheel.toml"))
    lever = 1 / abs(wheel.coupling)
    assert lever == pytest.approx(188.2, rel=1e-3)
    assert balance_weights(wheel) == pytest.approx((LQR_Q[0] / lever**2, LQR_Q[1] / lever**2) + LQR_Q[2:])
    for shipped in ("sct_thesis_final.toml", "furuta_qube.toml"):
        c = PendulumConstants.from_model(load_model(Path(__file__).parents[1] / "models" / shipped))
        assert balance_weights(c) == LQR_Q
    # the wheel at 20 rad/s, the pendulum 0.1 rad from the top: the balance asks 48 V of the
    # 12 V drive, where the cart's weights asked 2500 V
    err = np.array([0.0, 20.0, 0.1, 0.0])
    assert abs(float(LqrBalance(wheel).lqr.K @ err)) < 60.0
    assert abs(float(LqrBalance(wheel, q_diag=LQR_Q).lqr.K @ err)) > 2000.0


def test_the_builtin_controller_brings_a_reaction_wheel_pendulum_up():
    """The check's wheel pendulum (its stall torque 0.6 of the pendulum's gravity torque): the
    pivot's pump ran the wheel into its no-load speed at every swing's end and the pendulum came
    up by luck, if at all; the wheel's paced speed brings it up, and the balance holds it."""
    from pendc.hil.controllers.pendulum import PACE_SPEED, wheel_pace
    model = load_model(Path(__file__).parent / "data" / "reaction_wheel.toml")
    consts = PendulumConstants.from_model(model)
    speed, servo = wheel_pace(consts)
    assert speed == pytest.approx(PACE_SPEED * 276.0, rel=0.03)            # 0.9 of the motor's no-load speed
    qube = load_model(Path(__file__).parents[1] / "models" / "furuta_qube.toml")
    assert wheel_pace(PendulumConstants.from_model(qube)) is None
    run = run_closed_loop(make_plant("float", model), make_controller("builtin", model), 5.0)
    summary = run.summary()
    assert summary["upright_at_s"] is not None and summary["upright_at_s"] < 4.5, summary


def test_a_pendubot_is_not_a_pendulum_on_a_pivot():
    """Round G: the builtin controller took the Pendubot (a driven shoulder link, a passive elbow)
    for one pendulum on a driven pivot and its swing-up threw the upright arm down. Gravity holds
    its driven shoulder too: the builtin controller is the LQR at its operating point."""
    from pendc.hil.controllers.operating_point_lqr import OperatingPointLqr
    model = load_model(Path(__file__).parent / "data" / "pendubot.toml")
    with pytest.raises(PendcError, match="gravity holds the driven q1 too"):
        pendulum_roles(model)
    assert isinstance(make_controller("builtin", model), OperatingPointLqr)
