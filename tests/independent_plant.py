"""A second, independent generator of measurement-like data for the identification tests.

Shares no code with pendc (nothing is imported from it): the equations are typed in by
hand for each experiment of the thesis' identification (chapter 3), the integrator is
classic RK4 at 20 us (pendc's fit model uses RK4 at 100 us, its data generator Euler at
1 us), and the measurement chain is written here again:

* free swing with the cart clamped (spec §3, pivot friction, I, L): only the pendulum
  equation holds, with the pivot fixed::

      (m L^2 + I) th'' = -m g L sin th - b_theta th' - tau_c sgn(th') - c_theta th' |th'|

* cart alone, pendulum removed (Table 2: drive, friction): no pendulum mass, F_N = M g::

      M x'' = alpha (u - V_off) + F_fric - b_x x' + F_stop - k_c (x - x_0),  |x'| clamped to v_max
      after each step
      F_fric (moving) = -(mu_c + (mu_s - mu_c) exp(-(|x'|/v_s)^gamma)) F_N sgn(x') (1 + d_mu sgn(x'))
      F_fric (x' == 0) = -F_in if |F_in| < mu_s F_N, else -mu_s F_N sgn(F_in)
      F_stop = -k_end (x - sgn(x) x_end) - b_end x' where |x| > x_end (rubber buffers at the
               track's ends, fixed to the track: where the cart meets them is absolute), else 0;
      k_c (x - x_0) a centring spring or cable (k_c = 0: none)

* the drive sees the command through a 12-bit DAC plus unmeasured Gaussian noise (held
  per sample); the file logs the command;
* the positions are read by x4 quadrature encoders (2.5 um, 2 pi / 20000 rad) counting
  from power-on, after the sensor offsets theta_off and x_off.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

X_STEP = 5e-3 / 2000.0
THETA_STEP = 2.0 * math.pi / 20000.0
SCT = dict(g=9.80665, M=103.205, m=0.581, L=0.138867, I=6.21034e-3, alpha=260.78841, V_off=5.264616,
           b_x=877.31327, b_theta=0.0012889, mu_c=0.1331798, mu_s=0.1035951, v_s=0.9539722, gamma=1.0,
           v_max=0.55, tau_c=0.0, c_theta=0.0, d_mu=0.0, theta_off=0.0, x_off=0.0,
           x_end=0.375, k_end=0.0, b_end=0.0, k_c=0.0, x_0=0.0)   # the thesis' rig: no stops, no spring


@njit(cache=True)
def _sgn(v):
    return 1.0 if v > 0.0 else (-1.0 if v < 0.0 else 0.0)


@njit(cache=True)
def _swing(th0, n, h_sample, dt, mgl, J, b, tau_c, c):
    out = np.empty(n)
    th, w = th0, 0.0
    out[0] = th
    sub = int(round(h_sample / dt))
    h = h_sample / sub
    for k in range(1, n):
        for _ in range(sub):
            a1 = (-mgl * math.sin(th) - b * w - tau_c * _sgn(w) - c * w * abs(w)) / J
            w2 = w + 0.5 * h * a1
            a2 = (-mgl * math.sin(th + 0.5 * h * w) - b * w2 - tau_c * _sgn(w2) - c * w2 * abs(w2)) / J
            w3 = w + 0.5 * h * a2
            a3 = (-mgl * math.sin(th + 0.5 * h * w2) - b * w3 - tau_c * _sgn(w3) - c * w3 * abs(w3)) / J
            w4 = w + h * a3
            a4 = (-mgl * math.sin(th + h * w3) - b * w4 - tau_c * _sgn(w4) - c * w4 * abs(w4)) / J
            th, w = th + h / 6.0 * (w + 2.0 * w2 + 2.0 * w3 + w4), w + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        out[k] = th
    return out


@njit(cache=True)
def _cart_acc(x, v, F_in, M, F_N, b_x, mu_c, mu_s, v_s, gamma, d_mu, x_end, k_end, b_end, k_c, x_0):
    if v != 0.0:
        fric = -(mu_c + (mu_s - mu_c) * math.exp(-((abs(v) / v_s) ** gamma))) * F_N * _sgn(v) * (1.0 + d_mu * _sgn(v))
    elif abs(F_in) < mu_s * F_N:
        fric = -F_in
    else:
        fric = -mu_s * F_N * _sgn(F_in)
    stop = 0.0
    if abs(x) > x_end:
        stop = -k_end * (x - _sgn(x) * x_end) - b_end * v
    return (F_in + fric - b_x * v + stop - k_c * (x - x_0)) / M


@njit(cache=True)
def _cart(u_seen, n, h_sample, dt, M, F_N, alpha, V_off, b_x, mu_c, mu_s, v_s, gamma, d_mu, v_max,
          x_end, k_end, b_end, k_c, x_0):
    out = np.empty(n)
    x, v = 0.0, 0.0
    out[0] = x
    sub = int(round(h_sample / dt))
    h = h_sample / sub
    for k in range(1, n):
        F = alpha * (u_seen[k - 1] - V_off)
        for _ in range(sub):
            a1 = _cart_acc(x, v, F, M, F_N, b_x, mu_c, mu_s, v_s, gamma, d_mu, x_end, k_end, b_end, k_c, x_0)
            a2 = _cart_acc(x + 0.5 * h * v, v + 0.5 * h * a1, F, M, F_N, b_x, mu_c, mu_s, v_s, gamma, d_mu,
                           x_end, k_end, b_end, k_c, x_0)
            a3 = _cart_acc(x + 0.5 * h * (v + 0.5 * h * a1), v + 0.5 * h * a2, F, M, F_N, b_x, mu_c, mu_s, v_s,
                           gamma, d_mu, x_end, k_end, b_end, k_c, x_0)
            a4 = _cart_acc(x + h * (v + 0.5 * h * a2), v + h * a3, F, M, F_N, b_x, mu_c, mu_s, v_s, gamma, d_mu,
                           x_end, k_end, b_end, k_c, x_0)
            x = x + h / 6.0 * (6.0 * v + h * (a1 + a2 + a3))   # RK4 for x' = v, v' = a(x, v)
            v = v + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
            v = min(max(v, -v_max), v_max)
        out[k] = x
    return out


def encoder(value: np.ndarray, step: float) -> np.ndarray:
    """What a x4 decoder reports: the first reading plus whole counts since power-on."""
    grid = np.floor(value / step)
    return value[0] + (grid - grid[0]) * step


def seen_by_drive(u: np.ndarray, noise_v: float, seed: int) -> np.ndarray:
    lsb = 10.0 / 4095.0
    return np.round(u / lsb) * lsb + np.random.default_rng(seed).normal(0.0, noise_v, u.shape)


def free_swing(duration: float, theta0: float = 1.0, fs: float = 1000.0, **params) -> dict:
    """The cart clamped, the pendulum released from ``theta0`` at rest: columns t, u, x, theta."""
    p = {**SCT, **params}
    n = int(round(duration * fs)) + 1
    t = np.arange(n) / fs
    th = _swing(theta0, n, 1.0 / fs, 2e-5, p["m"] * p["g"] * p["L"], p["m"] * p["L"] ** 2 + p["I"],
                p["b_theta"], p["tau_c"], p["c_theta"])
    return {"t": t, "u": np.full(n, p["V_off"]), "x": np.zeros(n),
            "theta": encoder(th + p["theta_off"], THETA_STEP)}


def constant_voltage_runs(levels, hold: float = 0.6, pause: float = 0.2, fs: float = 1000.0) -> tuple:
    """Table 2's experiment: the cart alone driven at constant offsets from V_off, each level
    one way then the other (so the cart stays on the track), with pauses at rest between."""
    u = []
    for e in levels:
        for sign in (1.0, -1.0):
            u += [sign * e] * int(hold * fs) + [0.0] * int(pause * fs)
    u = np.array([0.0] * int(pause * fs) + u)
    return np.arange(u.size) / fs, u


def cart_alone(levels, noise_v: float = 0.005, seed: int = 3, fs: float = 1000.0, **params) -> dict:
    """The pendulum removed; offsets ``levels`` (V from V_off) as in :func:`constant_voltage_runs`."""
    t, e = constant_voltage_runs(levels, fs=fs)
    return cart_driven(t, e, noise_v, seed, **params)


def end_stop_runs(volts: float = 1.5, press: float = 0.6, fs: float = 1000.0) -> tuple:
    """A rig engineer's check of the position sensor: from the centre, a constant voltage drives
    the cart into one end stop and holds it there, then the other way across the whole track
    into the other stop, then back towards the centre. The buffers are fixed to the track, so
    where the cart meets and rests against them is an absolute position."""
    travel = 0.375 / 0.31 * volts / 1.5        # s from the centre to an end (~0.31 m/s at 1.5 V)
    u = ([0.0] * int(0.2 * fs) + [volts] * int((travel + press) * fs) + [-volts] * int((2 * travel + press) * fs)
         + [volts] * int(travel * fs) + [0.0] * int(0.3 * fs))
    u = np.array(u)
    return np.arange(u.size) / fs, u


def cart_driven(t, e, noise_v: float = 0.005, seed: int = 3, **params) -> dict:
    """The pendulum removed, the cart starting at rest at the track centre and driven at
    ``V_off + e`` (sampled at ``t``): columns t, u, x, theta."""
    p = {**SCT, **params}
    u = p["V_off"] + np.asarray(e, float)
    fs = 1.0 / float(t[1] - t[0])
    x = _cart(seen_by_drive(u, noise_v, seed), t.size, 1.0 / fs, 2e-5, p["M"], p["M"] * p["g"], p["alpha"],
              p["V_off"], p["b_x"], p["mu_c"], p["mu_s"], p["v_s"], p["gamma"], p["d_mu"], p["v_max"],
              p["x_end"], p["k_end"], p["b_end"], p["k_c"], p["x_0"])
    return {"t": t, "u": u, "x": encoder(x + p["x_off"], X_STEP), "theta": np.zeros(t.size)}
