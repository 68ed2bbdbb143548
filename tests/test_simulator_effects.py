"""The float simulator (pendc.sim.simulator) against the effect catalogue of spec §8: every
effect changes the SCT model's response the way physics predicts (a terminal speed from the
force balance, a breakaway force, a decay envelope, a delay, a lag's time constant, a spring's
period), each against a closed-form figure, never against pendc's own output."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from pendc.sim.simulator import Simulator
from plants import sct_model
from reference_spec2 import TABLE14
from test_simulator import grid, step_input

P = TABLE14
G, M, m, L, I = P["g"], P["M"], P["m"], P["L"], P["I"]
ALPHA, V_OFF, B_X = P["alpha"], P["V_off"], P["b_x"]
F_N = (M + m) * G
PLANT = {"g": G, "M": M, "m": m, "L": L, "I": I}


# --------------------------------------------------------------------------- effect catalogue

DRIVE = {"alpha": ALPHA, "V_off": V_OFF}
PEND_DAMP = {"b_theta": 0.05}  # damps the pendulum's start transient in cart tests


def build(**effects):
    return sct_model(plant=dict(PLANT), effects=effects)


def base_cart(**extra):
    return build(drive=DRIVE, viscous_cart={"b_x": B_X}, viscous_pendulum=PEND_DAMP, **extra)


def sim(model, t, u, x0=None, dt=1e-5):
    return Simulator(model, dt=dt, method="rk4")(t, u, x0=x0)


def terminal_speed(res, t, window=0.5):
    return float(np.mean(res["dx"][t >= t[-1] - window]))


def peaks(t, y):
    """Times and values of the local maxima of |y| (one per half swing)."""
    a = np.abs(y)
    i = np.nonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:]))[0] + 1
    return t[i], a[i]


def check_drive(t=grid(2.0)):
    u = step_input(t, 0.0, 1.0)
    without = sim(build(viscous_cart={"b_x": B_X}, viscous_pendulum=PEND_DAMP), t, u)
    assert np.all(without["x"] == 0.0)  # no drive: the voltage does nothing
    with_ = sim(base_cart(), t, u)
    assert terminal_speed(with_, t) == pytest.approx(ALPHA * 1.0 / B_X, rel=1e-2)


def check_viscous_cart(t=grid(2.0)):
    F = ALPHA * 0.5
    u = step_input(t, 0.0, 0.5)
    free = sim(build(drive=DRIVE, viscous_pendulum=PEND_DAMP), t, u)
    # no cart friction: horizontal momentum grows exactly as F t
    p = (M + m) * free["dx"] - m * L * free["dtheta"] * np.cos(free["theta"])
    np.testing.assert_allclose(p, F * t, rtol=1e-9, atol=1e-9)
    damped = sim(base_cart(), t, u)
    assert terminal_speed(damped, t) == pytest.approx(F / B_X, rel=1e-2)


def check_coulomb_cart(t=grid(2.0)):
    mu_c = 0.05
    model = base_cart(coulomb_cart={"mu_c": mu_c})
    for s in (1, -1):
        u = step_input(t, 0.0, s * 1.0)
        v = terminal_speed(sim(model, t, u), t)
        assert v == pytest.approx(s * (ALPHA - mu_c * F_N) / B_X, rel=1e-2)
        assert abs(v) < abs(terminal_speed(sim(base_cart(), t, u), t))


def check_static_cart(t=grid(2.0)):
    coulomb = {"mu_c": 0.03}
    F = 40.0  # between mu_c F_N = 30.5 N and mu_s F_N = 50.9 N
    u = step_input(t, 0.0, F / ALPHA)
    sliding = sim(base_cart(coulomb_cart=coulomb), t, u)
    assert terminal_speed(sliding, t) == pytest.approx((F - 0.03 * F_N) / B_X, rel=1e-2)
    stuck = sim(base_cart(coulomb_cart=coulomb, static_cart={"mu_s": 0.05}), t, u)
    assert np.all(stuck["x"] == 0.0) and np.all(stuck["theta"] == 0.0)
    # above break-away the moving branch is plain Coulomb again
    u = step_input(t, 0.0, 60.0 / ALPHA)
    moving = sim(base_cart(coulomb_cart=coulomb, static_cart={"mu_s": 0.05}), t, u)
    assert terminal_speed(moving, t) == pytest.approx((60.0 - 0.03 * F_N) / B_X, rel=1e-2)


def check_stribeck_cart(t=grid(2.0)):
    mu_c, mu_s, v_s, gamma = 0.03, 0.06, 0.05, 2.0
    model = base_cart(stribeck_cart={"mu_c": mu_c, "mu_s": mu_s, "v_s": v_s, "gamma": gamma})
    below = sim(model, t, step_input(t, 0.0, 50.0 / ALPHA))  # mu_s F_N = 61.1 N
    assert np.all(below["x"] == 0.0)
    assert sim(base_cart(), t, step_input(t, 0.0, 50.0 / ALPHA))["x"][-1] > 0.05
    F = 100.0
    v_pred = brentq(lambda v: B_X * v + (mu_c + (mu_s - mu_c) * math.exp(-((v / v_s) ** gamma))) * F_N - F, 0, 1)
    v = terminal_speed(sim(model, t, step_input(t, 0.0, F / ALPHA)), t)
    assert v == pytest.approx(v_pred, rel=1e-2)
    # the Stribeck dip: steady speed lies between the pure mu_s and pure mu_c laws
    assert (F - mu_s * F_N) / B_X < v < (F - mu_c * F_N) / B_X


def check_asymmetric_cart(t=grid(2.0)):
    mu_c, d_mu = 0.05, 0.5
    sym = base_cart(coulomb_cart={"mu_c": mu_c})
    asym = base_cart(coulomb_cart={"mu_c": mu_c}, asymmetric_cart={"d_mu": d_mu})
    up, down = step_input(t, 0.0, 1.0), step_input(t, 0.0, -1.0)
    s_up, s_down = sim(sym, t, up), sim(sym, t, down)
    assert s_up["x"][-1] == pytest.approx(-s_down["x"][-1], rel=1e-9)
    a_up, a_down = sim(asym, t, up), sim(asym, t, down)
    assert terminal_speed(a_up, t) == pytest.approx((ALPHA - (1 + d_mu) * mu_c * F_N) / B_X, rel=1e-2)
    assert terminal_speed(a_down, t) == pytest.approx(-(ALPHA - (1 - d_mu) * mu_c * F_N) / B_X, rel=1e-2)
    assert a_up["x"][-1] < -a_down["x"][-1]  # more friction to the left, less travel


PEND_X0 = (0.0, 0.0, 0.2, 0.0)


def check_viscous_pendulum(t=grid(4.0)):
    u = np.full_like(t, V_OFF)
    b_theta = 0.01
    free = sim(build(drive=DRIVE, viscous_cart={"b_x": B_X}), t, u, x0=PEND_X0)
    damped = sim(build(drive=DRIVE, viscous_cart={"b_x": B_X}, viscous_pendulum={"b_theta": b_theta}),
                 t, u, x0=PEND_X0)
    sigma = b_theta / (2 * (m * L**2 + I))  # envelope decay rate of a lightly damped pendulum
    tp, ap = peaks(t, free["theta"])
    assert abs(np.polyfit(tp, np.log(ap), 1)[0]) < 0.05 * sigma
    tp, ap = peaks(t, damped["theta"])
    assert len(tp) >= 6
    assert -np.polyfit(tp, np.log(ap), 1)[0] == pytest.approx(sigma, rel=0.05)


def check_coulomb_pendulum(t=grid(6.0)):
    u = np.full_like(t, V_OFF)
    tau_c = 0.01
    base = build(drive=DRIVE, viscous_cart={"b_x": B_X})
    free = sim(base, t, u, x0=PEND_X0)
    dry = sim(build(drive=DRIVE, viscous_cart={"b_x": B_X}, coulomb_pendulum={"tau_c": tau_c}), t, u, x0=PEND_X0)
    band = tau_c / (m * G * L)  # the pendulum can rest anywhere with |theta| <= band
    # dry friction: the amplitude falls linearly, 2 band per half swing ...
    tp, ap = peaks(t[t < 2.5], dry["theta"][t < 2.5])
    np.testing.assert_allclose(-np.diff(ap), 2 * band, rtol=0.1)
    # ... and the swing stops in finite time, inside the band
    last = t >= 5.0
    assert np.max(np.abs(dry["dtheta"][last])) < 1e-3
    assert np.ptp(dry["theta"][last]) < 1e-5
    assert abs(dry["theta"][-1]) <= 1.05 * band
    assert np.max(np.abs(free["theta"][last])) > 0.19  # still swinging without it


def check_velocity_limit(t=grid(2.0)):
    u = step_input(t, 0.0, 3.0)  # terminal speed 0.89 m/s without the limit
    free = sim(base_cart(), t, u)
    assert terminal_speed(free, t) == pytest.approx(3.0 * ALPHA / B_X, rel=1e-2)
    lim = sim(base_cart(velocity_limit={"v_max": 0.55}), t, u)
    assert np.max(np.abs(lim["dx"])) == 0.55
    assert lim["dx"][-1] == 0.55
    lim_down = sim(base_cart(velocity_limit={"v_max": 0.55}), t, step_input(t, 0.0, -3.0))
    assert np.min(lim_down["dx"]) == -0.55


def check_force_limit(t=grid(2.0)):
    model = base_cart(force_limit={"F_max": 100.0})
    for s in (1, -1):
        u = step_input(t, 0.0, s * 2.0)
        assert terminal_speed(sim(model, t, u), t) == pytest.approx(s * 100.0 / B_X, rel=1e-2)
        assert terminal_speed(sim(base_cart(), t, u), t) == pytest.approx(s * 2.0 * ALPHA / B_X, rel=1e-2)
    # inside the limit nothing changes
    u = step_input(t, 0.0, 0.3)
    np.testing.assert_array_equal(sim(model, t, u)["x"], sim(base_cart(), t, u)["x"])


def check_drive_deadzone(t=grid(2.0)):
    model = base_cart(drive_deadzone={"u_dz": 0.5})
    for s in (1, -1):
        small = step_input(t, 0.0, s * 0.3)
        assert np.all(sim(model, t, small)["x"] == 0.0)
        assert s * sim(base_cart(), t, small)["x"][-1] > 0.1
        big = step_input(t, 0.0, s * 1.5)
        assert terminal_speed(sim(model, t, big), t) == pytest.approx(s * ALPHA * 1.0 / B_X, rel=1e-2)


def check_input_delay(t=grid(1.0)):
    u = step_input(t, 0.2, 1.0)
    base = sim(base_cart(), t, u)
    delayed = sim(base_cart(input_delay={"tau_d": 0.05}), t, u)
    assert base["x"][t > 0.201].min() > 0
    assert np.all(delayed["x"][t <= 0.25 + 1e-9] == 0.0)
    np.testing.assert_allclose(delayed["x"][50:], base["x"][:-50], rtol=1e-9, atol=1e-13)


def check_motor_lag(t=grid(1.5)):
    tau_m, t0, dv = 0.05, 0.1, 1.0
    F = ALPHA * dv
    u = step_input(t, t0, dv)
    lag = sim(base_cart(motor_lag={"tau_m": tau_m}), t, u)
    base = sim(base_cart(), t, u)
    s = np.clip(t - t0, 0, None)
    tau_1 = (M + m) / B_X
    np.testing.assert_allclose(lag["F_m"], F * (1 - np.exp(-s / tau_m)), atol=1e-6 * F)
    v_lag = F / B_X * (1 - (tau_1 * np.exp(-s / tau_1) - tau_m * np.exp(-s / tau_m)) / (tau_1 - tau_m))
    v_base = F / B_X * (1 - np.exp(-s / tau_1))
    assert np.max(np.abs(lag["dx"] - v_lag)) < 0.01 * F / B_X
    assert np.max(np.abs(base["dx"] - v_base)) < 0.01 * F / B_X
    assert np.all(lag["x"] <= base["x"] + 1e-12) and lag["x"][-1] < base["x"][-1]


def check_cart_spring(t=grid(4.0)):
    k_c, x_0 = 2000.0, 0.05
    model = base_cart(cart_spring={"k_c": k_c, "x_0": x_0})
    rest = sim(model, t, np.full_like(t, V_OFF))
    assert rest["x"][-1] == pytest.approx(x_0, rel=1e-3)  # pulled from 0 to the spring's rest point
    assert np.all(sim(base_cart(), t, np.full_like(t, V_OFF))["x"] == 0.0)
    u = step_input(t, 0.0, 0.5)
    pushed = sim(model, t, u)
    assert pushed["x"][-1] == pytest.approx(x_0 + ALPHA * 0.5 / k_c, rel=1e-3)  # static deflection F / k_c
    assert sim(base_cart(), t, u)["x"][-1] > 0.5  # without it the cart keeps going
    back = sim(model, t, np.full_like(t, V_OFF), x0=(0.2, 0.0, 0.0, 0.0))
    assert back["x"][-1] == pytest.approx(x_0, rel=1e-3)


EFFECT_CHECKS = {
    "drive": check_drive,
    "viscous_cart": check_viscous_cart,
    "coulomb_cart": check_coulomb_cart,
    "static_cart": check_static_cart,
    "stribeck_cart": check_stribeck_cart,
    "asymmetric_cart": check_asymmetric_cart,
    "viscous_pendulum": check_viscous_pendulum,
    "coulomb_pendulum": check_coulomb_pendulum,
    "velocity_limit": check_velocity_limit,
    "force_limit": check_force_limit,
    "drive_deadzone": check_drive_deadzone,
    "input_delay": check_input_delay,
    "motor_lag": check_motor_lag,
    "cart_spring": check_cart_spring,
}


@pytest.mark.parametrize("effect", list(EFFECT_CHECKS))
def test_effect_changes_response_as_predicted(effect):
    EFFECT_CHECKS[effect]()


def test_every_catalogue_effect_is_checked():
    from plants import CATALOGUE, sct_model

    spec8 = {"drive", "viscous_cart", "coulomb_cart", "static_cart", "stribeck_cart", "asymmetric_cart",
             "viscous_pendulum", "coulomb_pendulum", "velocity_limit", "force_limit", "drive_deadzone",
             "input_delay", "motor_lag", "cart_spring"}
    assert spec8 <= set(EFFECT_CHECKS) and spec8 <= set(CATALOGUE)
