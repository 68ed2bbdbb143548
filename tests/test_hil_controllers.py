"""Controllers and their design: the linearisation against a hand derivation, the LQR against
an independent Riccati iteration, the DAC, angles, velocity filter, the loop's bookkeeping."""

import math

import numpy as np
import pytest

from pendc import load_model
from pendc.errors import PendcError
from pendc.hil.controllers.measurement import FilteredDifference, Measurement, wrap_upright
from pendc.hil.controllers.pendulum import EnergySwingUp, LqrBalance, PendulumConstants, Supervisor
from pendc.hil.controllers.linearize import design_lqr, linearise_upright
from pendc.hil.loop import dac, run_closed_loop, steps_per_period, upright_stretch
from pendc.hil.plants.core_ports import CorePorts
from pendc.hil.plants.plant import PlantState

FINAL = "models/sct_thesis_final.toml"
INITIAL = "models/sct_thesis_initial.toml"


def textbook_upright(p: dict, b_eff: float):
    """Cart-pole linearised by hand at theta = pi (phi = theta - pi): the mass matrix
    [[M+m, mL], [mL, J]] times (ddx, ddphi) equals (alpha u - b dx, m g L phi - b_theta dphi)."""
    m, L, g = p["m"], p["L"], p["g"]
    mass = np.array([[p["M"] + m, m * L], [m * L, m * L * L + p["I"]]])
    inv = np.linalg.inv(mass)
    # columns: x, dx, phi, dphi ; force vector rows: cart, pendulum
    forces = np.array([[0.0, -b_eff, 0.0, 0.0], [0.0, 0.0, m * g * L, -p["b_theta"]]])
    acc = inv @ forces
    A = np.array([[0, 1, 0, 0], acc[0], [0, 0, 0, 1], acc[1]], dtype=float)
    B = np.array([0.0, inv[0, 0] * p["alpha"], 0.0, inv[1, 0] * p["alpha"]])
    return A, B


@pytest.mark.parametrize("path", [INITIAL, FINAL])
def test_linearisation_matches_a_hand_derivation(path):
    model = load_model(path)
    p = model.parameter_values()
    lin = linearise_upright(model)
    # the Stribeck slope at slow motion adds (mu_s - mu_c) F_N / v_s of damping for gamma = 1
    # (gamma = 2: zero slope at rest)
    slope = (p["mu_s"] - p["mu_c"]) * (p["M"] + p["m"]) * p["g"] / p["v_s"] if p["gamma"] == 1.0 else 0.0
    A, B = textbook_upright(p, p["b_x"] - slope)
    assert np.allclose(lin.A, A, rtol=1e-4, atol=1e-6)
    assert np.allclose(lin.B.ravel(), B, rtol=1e-6)
    assert lin.u0 == pytest.approx(p["V_off"], abs=1e-9)
    # dry friction at the break-away, in volts of drive
    assert lin.u_coulomb == pytest.approx(p["mu_s"] * (p["M"] + p["m"]) * p["g"] / p["alpha"], rel=1e-3)
    # one unstable pole: the inverted pendulum, close to sqrt(m g L / J) for this heavy cart
    eig = np.linalg.eigvals(lin.A)
    assert sum(e.real > 1e-6 for e in eig) == 1
    assert max(eig.real) == pytest.approx(math.sqrt(p["m"] * p["g"] * p["L"] / (p["m"] * p["L"] ** 2 + p["I"])),
                                          rel=0.05)


def test_lqr_gain_equals_riccati_iteration_and_stabilises():
    lin = linearise_upright(load_model(FINAL))
    q = (1e4, 4.0, 2500.0, 4.0)
    lqr = design_lqr(lin, 1e-3, q, 1.0)
    Ad, Bd, Q, R = lqr.Ad, lqr.Bd, np.diag(q), np.eye(1)
    P = Q.copy()
    for _ in range(200000):   # the Riccati difference equation, iterated to its fixed point
        K = np.linalg.solve(R + Bd.T @ P @ Bd, Bd.T @ P @ Ad)
        P_next = Q + Ad.T @ P @ (Ad - Bd @ K)
        if np.max(np.abs(P_next - P)) < 1e-9 * np.max(np.abs(P)):
            break
        P = P_next
    assert np.allclose(lqr.K, K.ravel(), rtol=1e-5)
    assert np.max(np.abs(np.linalg.eigvals(Ad - Bd @ lqr.K[None, :]))) < 1.0
    # the exact zero-order-hold discretisation agrees with its Taylor series to O(h^4)
    h, A, B = 1e-3, lin.A, lin.B
    assert np.allclose(Ad, np.eye(4) + A * h + A @ A * h**2 / 2 + A @ A @ A * h**3 / 6, atol=1e-8)
    assert np.allclose(Bd, B * h + A @ B * h**2 / 2 + A @ A @ B * h**3 / 6, atol=1e-9)


def test_dac_clamps_and_quantises_to_12_bits():
    lsb = 10.0 / 4095
    assert dac(-3.0, (0.0, 10.0)) == 0.0 and dac(12.0, (0.0, 10.0)) == 10.0
    v = dac(5.2646, (0.0, 10.0))
    assert abs(v - 5.2646) <= lsb / 2 and round(v / lsb) * lsb == pytest.approx(v, abs=1e-12)
    with pytest.raises(PendcError, match="answered"):
        dac(float("nan"), (0.0, 10.0))


def test_angles_and_measurements():
    assert wrap_upright(math.pi) == pytest.approx(0.0)
    assert wrap_upright(-math.pi) == pytest.approx(0.0)
    assert wrap_upright(3 * math.pi + 0.1) == pytest.approx(0.1)
    assert wrap_upright(0.0) == pytest.approx(math.pi)
    meas = _meas(0.5, 400, 10000)
    assert meas.x == pytest.approx(1e-3) and meas.theta == pytest.approx(math.pi)
    assert meas.enc_x == 400 and meas.position("theta") == meas.theta and meas.count("enc_theta") == 10000
    with pytest.raises(AttributeError):
        meas.phi_r


def test_filtered_difference_follows_a_ramp():
    f = FilteredDifference(1e-3, tau=0.004)
    v = [f.update(0.3 * k * 1e-3) for k in range(200)]
    assert v[0] == 0.0 and v[-1] == pytest.approx(0.3, rel=1e-6)


def test_swing_up_pushes_to_add_energy():
    consts = PendulumConstants.from_model(load_model(FINAL))
    ctl = EnergySwingUp(consts)
    # hanging (cos > 0), swinging clockwise: energy grows if the cart accelerates to +x, u > V_off
    assert ctl.command(_meas(0.0, 0, 0), 0.0, 2.0) > consts.lin.u0
    assert ctl.command(_meas(0.0, 0, 0), 0.0, -2.0) < consts.lin.u0


PORTS = CorePorts.of_interface(load_model(FINAL).interface)


def _meas(t, enc_x, enc_theta):
    """A cart-pendulum measurement from its two counts."""
    return Measurement(t, (("enc_x", enc_x), ("enc_theta", enc_theta)), PORTS.encoders)


class ScriptedPlant:
    """A plant that fails after a few steps, to see the loop stop and keep its rows."""

    dt = 1e-6
    ports = PORTS

    def __init__(self, fail_after):
        self.fail_after = fail_after

    def reset(self):
        self.calls = 0
        return PlantState.at_rest(self.ports)

    def step(self, u, n):
        self.calls += 1
        if self.calls > self.fail_after:
            raise PendcError("theta_turns left its range")
        return PlantState(self.calls * n * self.dt, tuple((s, 0.0) for s in self.ports.states),
                          (("enc_x", self.calls), ("enc_theta", 2 * self.calls)))


def test_loop_stops_on_a_plant_error_and_keeps_the_rows():
    consts = PendulumConstants.from_model(load_model(FINAL))
    run = run_closed_loop(ScriptedPlant(fail_after=5), LqrBalance(consts), 1.0)
    assert run.stopped is not None and "theta_turns" in run.stopped and "t = 0.005 s" in run.stopped
    assert run.t.size == 6 and list(run.x / 2.5e-6) == pytest.approx([0, 1, 2, 3, 4, 5])
    assert run.summary()["completed"] is False


def test_loop_rejects_bad_periods():
    with pytest.raises(PendcError, match="whole number"):
        steps_per_period(1e-6, 1.5e-6)
    with pytest.raises(PendcError, match="positive"):
        steps_per_period(1e-6, -1.0)


def test_upright_stretch():
    t = np.arange(6.0)
    assert upright_stretch(t, np.array([3.0, 0.01, 0.2, 0.01, -0.02, 0.0]))[0] == 3.0
    assert upright_stretch(t, np.array([0.0, 0, 0, 0, 0, 0.3])) == (None, None)


def test_supervisor_switches_with_hysteresis():
    sup = Supervisor(PendulumConstants.from_model(load_model(FINAL)))
    sup.reset()
    up = round(math.pi / (2 * math.pi / 20000))
    sup.step(_meas(0.0, 0, up))
    assert sup.mode == "balance"
    sup.step(_meas(1e-3, 0, up + 2000))      # 0.63 rad: still inside the drop window
    assert sup.mode == "balance"
    sup.step(_meas(2e-3, 0, up + 3000))      # 0.94 rad: fallen
    assert sup.mode == "swing"


def test_linearisation_through_a_dead_zone_and_a_motor_lag():
    from pendc.hil.controllers.linearize import U_SPAN

    base = load_model(FINAL)
    plain = linearise_upright(base)
    dz = linearise_upright(base.with_effect("drive_deadzone", {"u_dz": 0.1}))
    # zero slope at V_off: the gain is the mean slope over V_off +- U_SPAN, the hold input the zone's centre
    assert dz.u0 == pytest.approx(plain.u0, abs=1e-9)
    assert np.allclose(dz.B, plain.B * (1 - 0.1 / U_SPAN), rtol=1e-9)
    assert np.allclose(dz.A, plain.A)
    # a fast motor lag is residualised away: the same four-state model
    lag = linearise_upright(base.with_effect("motor_lag", {"tau_m": 0.005}))
    assert np.allclose(lag.A, plain.A, rtol=1e-6, atol=1e-9) and np.allclose(lag.B, plain.B, rtol=1e-6)
