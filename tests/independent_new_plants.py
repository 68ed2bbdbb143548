"""An independent generator of measurement data for the plants added as files (issue 21): the
Quanser BB01 ball and beam on the SRV02 servo (models/ball_beam.toml), the SRV02 driving the
Rotary Flexible Joint, a two-mass drive (models/two_mass_drive.toml), and the DBPEN-LIN double
pendulum on the IP02 cart (models/double_pendulum_cart.toml).

Nothing here comes from pendc (nothing is imported from it, nothing is derived with it): the
equations of motion are written out below by hand from the physics and the published Quanser
sources the plant files cite, integrated by scipy's ``solve_ivp`` (DOP853, rtol 1e-10, one call
per zero-order-hold sample of the input), and the sensors are quantised here as the hardware
reads them. The parameter VALUES are read from the plant files with ``tomllib`` (the numbers of
``[plant]`` and ``[effects.*]``, and the sensors' bands, bits and range), so that a disagreement
with pendc is one of equations, not of figures; the equations are not read from the files.

The plants drift or are unstable open loop (the ball rolls off the beam; the servo and the
cart are integrators), so each run is made under a simple stabilising feedback that lives in this
generator, sampled at the input's rate from the true state: the file records the commanded
(held) voltage, which is all a simulation of the plant needs.

* Ball and beam (Quanser's BB01 model; the servo of config_srv02.m): states theta (servo load
  shaft), x (ball from the beam's middle, downhill for theta > 0). The beam tilts by
  a = (r_arm / L_beam) theta; the ball rolls without slipping, so its mass becomes
  M = m_b + J_b / r_b^2. The energies are T = J_eq theta'^2 / 2 + M x'^2 / 2 and
  V = -m_b g x sin(a) (Quanser's, the ball's spin about the beam's pivot and the beam's inertia
  left out), whence::

      J_eq theta'' = tau_m - B_eq theta' + m_b g x (r_arm / L_beam) cos(a)
      M x''        = m_b g sin(a) - b_x x'                      (b_x: the hidden rolling resistance)
      tau_m = eta_g eta_m k_t K_g (u - K_g k_m theta') / R_m     (the SRV02's motor through its gears)

  Sensors: the SRV02 encoder (1024 lines, x4: 4096 counts per revolution, counted from the
  start) and the ball's track through a 12-bit converter over the beam,
  code = clamp(floor((x - lo) 2^bits / (hi - lo)), 0, 2^bits - 1), read back as the middle of
  its step, lo + (code + 1/2) (hi - lo) / 2^bits.
  Feedback: a cascade as in Quanser's BB01 lab, an outer PD of the ball to a setpoint giving
  the servo's reference angle, an inner P of the servo angle; a small random voltage on top.

* Two-mass drive (Quanser setup_flexjoint_exp.m, config_srv02.m, config_rotflex.m): states
  theta (servo output shaft) and alpha (the arm's deflection in the joint; the arm's angle is
  theta + alpha). T = J_eq theta'^2 / 2 + J_l (theta' + alpha')^2 / 2, V = K_s alpha^2 / 2; the
  motor and the gears' damping act on theta, the arm's bearing (turning on the hub) on alpha::

      [J_eq + J_l  J_l] [theta'']   [tau_m - B_eq theta'                    ]
      [J_l        J_l ] [alpha''] = [-K_s alpha - B_l alpha' - tau_l sgn(alpha')]

  (B_l, tau_l: hidden viscous and dry friction of the arm's bearing; an ``alpha_off`` may be
  added to the joint encoder's reading). Sensors: two encoders of 1024 lines, x4.
  Feedback: a PD of the servo angle to a reference that steps, the lab's "position control
  of the flexible joint" without the arm's feedback, so the arm rings on every step.

* Double pendulum on a cart (Quanser setup_ip02_dbpen.m, config_ip02.m, config_sp.m): states x
  (cart), alpha (bottom link from hanging down), beta (top link relative to the bottom one, the
  hinge encoder's angle). The equations, by Lagrange in the links' absolute angles, are in
  :func:`dbpen_rhs`: the cart with the rotor's inertia lumped in (the rotor turns K_g x / r_mp),
  each link a mass at its centre with an inertia about it, the hinge a point mass at the bottom
  link's tip; Quanser's cart force law; viscous damping at the cart, the pivot and the hinge (on
  the relative rate, as the plant file assumes). Sensors: three encoders of 1024 lines, x4 (the
  cart's counts the file's band / 2, 22.7485 um). Hidden: an offset ``alpha_off`` of the bottom
  link's encoder. Feedback: a PD of the cart to a setpoint that steps within +-10 cm; the links
  hang and swing under it.

From Python::

    from tests.independent_new_plants import run, write_csv
    r = run("ball_beam", seconds=8.0, seed=1, hidden={"b_x": 0.04})
    write_csv("bb.csv", r)

From the command line (repository root)::

    python tests/independent_new_plants.py ball_beam OUT.csv [--seconds 8] [--seed 1] [--hidden b_x=0.04]

Columns written: ``t, u`` and the positions as the sensors read them (``theta, x``,
``theta, alpha`` or ``x, alpha, beta``); ``# key: value`` lines say what made the file.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

MODELS = Path(__file__).resolve().parents[1] / "models"
FS = 1000.0                     # samples per second (input held, states read at each)
RTOL, ATOL = 1e-10, 1e-12


# -- the plant files' numbers (values only) ------------------------------------------------------

def file_values(plant: str) -> dict:
    """The numbers of ``[plant]`` and every ``[effects.*]`` table of ``models/PLANT.toml``."""
    doc = tomllib.loads((MODELS / f"{plant}.toml").read_text(encoding="utf-8"))
    values = {k: float(v) for k, v in doc["plant"].items() if isinstance(v, (int, float))}
    for table in doc.get("effects", {}).values():
        values.update({k: float(v) for k, v in table.items() if isinstance(v, (int, float))})
    return values


def file_sensors(plant: str) -> dict:
    """``{state: ("encoder", count) | ("adc", bits, lo, hi)}`` of the file: an encoder's count is
    half of its ``band`` (x4 decoding: two counts per light or dark band)."""
    doc = tomllib.loads((MODELS / f"{plant}.toml").read_text(encoding="utf-8"))
    out = {}
    for s in doc.get("sensors", {}).values():
        if s.get("kind", "quadrature_encoder") == "adc":
            out[s["state"]] = ("adc", int(s["bits"]), float(s["range"][0]), float(s["range"][1]))
        else:
            out[s["state"]] = ("encoder", float(s["band"]) / 2)
    return out


# -- sensors, as the hardware reads them ---------------------------------------------------------

def encoder(position: np.ndarray, step: float) -> np.ndarray:
    """A x4-decoded encoder's reading: whole counts (of ``step``) moved since the first sample."""
    start = position[0]
    return start + np.floor((position - start) / step + 1e-9) * step


def adc(value: np.ndarray, bits: int, lo: float, hi: float) -> np.ndarray:
    """A converter's reading: code = clamp(floor((s - lo) 2^bits / (hi - lo)), 0, 2^bits - 1),
    read back as the middle of its step."""
    q = (hi - lo) / 2 ** bits
    code = np.clip(np.floor((value - lo) / q), 0, 2 ** bits - 1)
    return lo + (code + 0.5) * q


def read_sensors(plant: str, states: dict) -> dict:
    out = {}
    for name, spec in file_sensors(plant).items():
        out[name] = encoder(states[name], spec[1]) if spec[0] == "encoder" else adc(states[name], *spec[1:])
    return out


# -- the equations of motion, by hand --------------------------------------------------------------

def motor_torque(u: float, rate: float, p: dict) -> float:
    """The SRV02's DC motor through its gears, at the load shaft (Quanser's servo model)."""
    return p["eta_g"] * p["eta_m"] * p["k_t"] * p["K_g"] * (u - p["K_g"] * p["k_m"] * rate) / p["R_m"]


def ball_beam_rhs(_t, y, u: float, p: dict):
    """y = (theta, dtheta, x, dx)."""
    theta, dtheta, x, dx = y
    lever = p["r_arm"] / p["L_beam"]
    a = lever * theta
    M = p["m_b"] + p["J_b"] / p["r_b"] ** 2
    ddtheta = (motor_torque(u, dtheta, p) - p["B_eq"] * dtheta
               + p["m_b"] * p["g"] * x * lever * math.cos(a)) / p["J_eq"]
    ddx = (p["m_b"] * p["g"] * math.sin(a) - p.get("b_x", 0.0) * dx) / M
    return (dtheta, ddtheta, dx, ddx)


def two_mass_rhs(_t, y, u: float, p: dict, slip: float = 0.0):
    """y = (theta, dtheta, alpha, dalpha); ``slip`` is the sign the arm's dry friction takes
    (fixed over a call, so the integrator never meets the switch)."""
    theta, dtheta, alpha, dalpha = y
    Je, Jl = p["J_eq"], p["J_l"]
    q_theta = motor_torque(u, dtheta, p) - p["B_eq"] * dtheta
    q_alpha = -p["K_s"] * alpha - p.get("B_l", 0.0) * dalpha - p.get("tau_l", 0.0) * slip
    # [[Je + Jl, Jl], [Jl, Jl]] (theta'', alpha'') = (q_theta, q_alpha); determinant Je * Jl
    ddtheta = (Jl * q_theta - Jl * q_alpha) / (Je * Jl)
    ddalpha = (-Jl * q_theta + (Je + Jl) * q_alpha) / (Je * Jl)
    return (dtheta, ddtheta, dalpha, ddalpha)


def cart_force(u: float, dx: float, p: dict) -> float:
    """The IP02's motor force on the cart through its gearbox and pinion (QuanserCartPole.m)."""
    return p["eta_g"] * p["K_g"] * p["k_t"] * (p["eta_m"] * u - p["K_g"] * p["k_m"] * dx / p["r_mp"]) / (p["R_m"] * p["r_mp"])


def dbpen_rhs(_t, y, u: float, p: dict):
    """y = (x, dx, alpha, dalpha, beta, dbeta): the double pendulum on a cart, by Lagrange in the
    links' absolute angles th1 = alpha, th2 = alpha + beta (from hanging down)::

        M  = M_c + J_m (K_g / r_mp)^2          (the rotor turns K_g x / r_mp: Quanser's lumped cart)
        Mt = M + m_1 + M_h + m_2,  a1 = m_1 l_1 + (M_h + m_2) L_1,  a2 = m_2 l_2,  a12 = m_2 L_1 l_2
        I1 = J_1 + m_1 l_1^2 + (M_h + m_2) L_1^2,  I2 = J_2 + m_2 l_2^2

        Mt x'' + a1 c1 th1'' + a2 c2 th2'' - a1 s1 th1'^2 - a2 s2 th2'^2                = Q_x
        a1 c1 x'' + I1 th1'' + a12 c12 th2'' + a12 s12 th2'^2 + g a1 s1                  = Q_th1
        a2 c2 x'' + a12 c12 th1'' + I2 th2'' - a12 s12 th1'^2 + g a2 s2                  = Q_th2

    (c12 = cos(th1 - th2), s12 = sin(th1 - th2)). The forces: Q_x = F_motor - B_eq x' on the cart,
    -B_p1 alpha' at the pivot and -B_p2 beta' in the hinge (on the relative rate, as the plant
    file assumes); by virtual work Q_th1 = Q_alpha - Q_beta, Q_th2 = Q_beta."""
    x, dx, alpha, dalpha, beta, dbeta = y
    th1, th2 = alpha, alpha + beta
    w1, w2 = dalpha, dalpha + dbeta
    M = p["M_c"] + p["J_m"] * (p["K_g"] / p["r_mp"]) ** 2
    Mt = M + p["m_1"] + p["M_h"] + p["m_2"]
    a1 = p["m_1"] * p["l_1"] + (p["M_h"] + p["m_2"]) * p["L_1"]
    a2 = p["m_2"] * p["l_2"]
    a12 = p["m_2"] * p["L_1"] * p["l_2"]
    I1 = p["J_1"] + p["m_1"] * p["l_1"] ** 2 + (p["M_h"] + p["m_2"]) * p["L_1"] ** 2
    I2 = p["J_2"] + p["m_2"] * p["l_2"] ** 2
    s1, c1, s2, c2 = math.sin(th1), math.cos(th1), math.sin(th2), math.cos(th2)
    s12, c12 = math.sin(th1 - th2), math.cos(th1 - th2)
    q_x = cart_force(u, dx, p) - p["B_eq"] * dx
    q_a, q_b = -p["B_p1"] * dalpha, -p["B_p2"] * dbeta
    # the symmetric mass matrix [[A, B, C], [B, D, E], [C, E, F]] and the right side (r0, r1, r2)
    A, B, C, D, E, F = Mt, a1 * c1, a2 * c2, I1, a12 * c12, I2
    r0 = q_x + a1 * s1 * w1 ** 2 + a2 * s2 * w2 ** 2
    r1 = q_a - q_b - a12 * s12 * w2 ** 2 - p["g"] * a1 * s1
    r2 = q_b + a12 * s12 * w1 ** 2 - p["g"] * a2 * s2
    # Cramer's rule with the cofactors of the symmetric matrix
    k00, k01, k02 = D * F - E * E, C * E - B * F, B * E - C * D
    k11, k12, k22 = A * F - C * C, B * C - A * E, A * D - B * B
    det = A * k00 + B * k01 + C * k02
    ddx = (k00 * r0 + k01 * r1 + k02 * r2) / det
    dd1 = (k01 * r0 + k11 * r1 + k12 * r2) / det
    dd2 = (k02 * r0 + k12 * r1 + k22 * r2) / det
    return (dx, ddx, dalpha, dd1, dbeta, dd2 - dd1)


# -- the feedback inside the generator and its references -----------------------------------------

def _steps(rng, n: int, hold: tuple, level: tuple) -> np.ndarray:
    """A piecewise-constant sequence of ``n`` samples: random levels held for random times."""
    out = np.empty(n)
    k = 0
    while k < n:
        m = int(rng.uniform(*hold) * FS)
        out[k:k + m] = rng.uniform(*level)
        k += m
    return out


def _ball_beam_control(rng, n: int):
    """(setpoints, dither): the ball's setpoint steps within +-8 cm every 1-2 s; +-0.1 V of
    random steps (50-200 ms) on the voltage keep the servo excited."""
    ref = _steps(rng, n, (1.0, 2.0), (-0.08, 0.08))
    dither = _steps(rng, n, (0.05, 0.2), (-0.1, 0.1))
    kx, kv, kp, kd = 12.0, 8.0, 10.0, 0.05

    def law(k, y):
        theta, dtheta, x, dx = y
        theta_ref = float(np.clip(kx * (ref[k] - x) - kv * dx, -0.8, 0.8))
        return kp * (theta_ref - theta) - kd * dtheta + dither[k]
    return law


def _two_mass_control(rng, n: int):
    """The servo's reference steps within +-0.5 rad every 0.4-1.2 s; PD of the servo angle; +-0.5 V
    of random steps on top."""
    ref = _steps(rng, n, (0.4, 1.2), (-0.5, 0.5))
    dither = _steps(rng, n, (0.02, 0.1), (-0.5, 0.5))
    kp, kd = 8.0, 0.1

    def law(k, y):
        theta, dtheta, _, _ = y
        return kp * (ref[k] - theta) - kd * dtheta + dither[k]
    return law


def _dbpen_control(rng, n: int):
    """The cart's setpoint steps within +-10 cm every 0.5-1.5 s (the links hang and swing under
    it); PD of the cart position; +-0.5 V of random steps on top."""
    ref = _steps(rng, n, (0.5, 1.5), (-0.1, 0.1))
    dither = _steps(rng, n, (0.02, 0.1), (-0.5, 0.5))
    kp, kd = 40.0, 0.5

    def law(k, y):
        return kp * (ref[k] - y[0]) - kd * y[1] + dither[k]
    return law


# -- integration, one call per held input sample --------------------------------------------------

def _advance_two_mass(y, t0, t1, u, p):
    """One held sample of the two-mass drive; with dry friction on the arm, slip and stick are
    integrated separately (events where the arm's relative rate comes to zero)."""
    tau_l = p.get("tau_l", 0.0)
    if tau_l == 0.0:
        sol = solve_ivp(two_mass_rhs, (t0, t1), y, method="DOP853", rtol=RTOL, atol=ATOL, args=(u, p))
        return sol.y[:, -1]
    y = np.array(y, dtype=float)
    for _ in range(1000):
        if t0 >= t1:
            return y
        # the torque the joint's friction must supply to keep the arm from slipping (alpha'' = 0)
        # with alpha' = 0: from the second row, Jl theta'' = need - K_s alpha, theta'' from the
        # system with the arm locked, (Je + Jl) theta'' = q_theta
        q_theta = motor_torque(u, y[1], p) - p["B_eq"] * y[1]
        need = p["J_l"] * q_theta / (p["J_eq"] + p["J_l"]) + p["K_s"] * y[2]
        if y[3] == 0.0 and abs(need) <= tau_l:        # stuck: the arm turns with the hub
            def locked(_t, s):
                qt = motor_torque(u, s[1], p) - p["B_eq"] * s[1]
                return (s[1], qt / (p["J_eq"] + p["J_l"]), 0.0, 0.0)

            def free(_t, s):
                qt = motor_torque(u, s[1], p) - p["B_eq"] * s[1]
                return abs(p["J_l"] * qt / (p["J_eq"] + p["J_l"]) + p["K_s"] * s[2]) - tau_l
            free.terminal, free.direction = True, 1
            sol = solve_ivp(locked, (t0, t1), y, method="DOP853", rtol=RTOL, atol=ATOL, events=free)
            y = sol.y[:, -1].copy()
            if sol.status != 1:
                return y
            t0 = float(sol.t_events[0][0])
            y[3] = 0.0
            slip = -math.copysign(1.0, p["J_l"] * (motor_torque(u, y[1], p) - p["B_eq"] * y[1])
                                  / (p["J_eq"] + p["J_l"]) + p["K_s"] * y[2])
        else:
            slip = math.copysign(1.0, y[3]) if y[3] != 0.0 else -math.copysign(1.0, need)
        way = slip

        def stop(_t, s):
            return s[3] * way
        stop.terminal, stop.direction = True, -1
        sol = solve_ivp(two_mass_rhs, (t0, t1), y, method="DOP853", rtol=RTOL, atol=ATOL,
                        args=(u, p, slip), events=stop)
        y = sol.y[:, -1].copy()
        if sol.status != 1:
            return y
        t0 = float(sol.t_events[0][0])
        y[3] = 0.0
    raise RuntimeError("the arm switched between sticking and slipping 1000 times in one sample")


PLANTS = {
    "ball_beam": dict(rhs=ball_beam_rhs, control=_ball_beam_control, positions=("theta", "x"),
                      rates=("dtheta", "dx"), hidden=("b_x",)),
    "two_mass_drive": dict(rhs=two_mass_rhs, control=_two_mass_control, positions=("theta", "alpha"),
                           rates=("dtheta", "dalpha"), hidden=("B_l", "tau_l", "alpha_off")),
    "double_pendulum_cart": dict(rhs=dbpen_rhs, control=_dbpen_control, positions=("x", "alpha", "beta"),
                                 rates=("dx", "dalpha", "dbeta"), hidden=("alpha_off",)),
}


def replay(plant: str, t, u, params: dict | None = None, y0=None) -> np.ndarray:
    """The true states at ``t`` under the given input (``u[k]`` held from ``t[k]`` to ``t[k+1]``),
    open loop: columns (position 1, rate 1, position 2, rate 2, ...), from rest at 0 by default."""
    return _integrate(plant, np.asarray(t, float), params, y0, inputs=np.asarray(u, float))[0]


def _integrate(plant, t, params, y0=None, inputs=None, law=None):
    spec = PLANTS[plant]
    p = {**file_values(plant), **(params or {})}
    width = 2 * len(spec["positions"])
    out = np.empty((len(t), width))
    u = np.empty(len(t)) if inputs is None else inputs
    y = np.zeros(width) if y0 is None else np.array(y0, dtype=float)
    out[0] = y
    for k in range(len(t)):
        if inputs is None:
            u[k] = float(np.clip(law(k, y), -10.0, 10.0))
        if k == len(t) - 1:
            break
        if plant == "two_mass_drive":
            y = _advance_two_mass(y, t[k], t[k + 1], u[k], p)
        else:
            sol = solve_ivp(spec["rhs"], (t[k], t[k + 1]), y, method="DOP853", rtol=RTOL, atol=ATOL,
                            args=(u[k], p))
            if sol.status != 0:
                raise RuntimeError(f"{plant}: integration failed at t = {t[k]:.6g} s: {sol.message}")
            y = sol.y[:, -1]
        out[k + 1] = y
    return out, u


def run(plant: str, seconds: float = 6.0, seed: int = 1, hidden: dict | None = None,
        quantize: bool = True) -> dict:
    """A closed-loop run of ``seconds`` at 1 kHz from rest at the origin (the links hanging), with
    the ``hidden`` parameters (names in ``PLANTS[plant]["hidden"]``) added to the plant.

    Returns ``t, u`` (the commanded, held voltage), the positions as the sensors read them
    (exact with ``quantize=False``; ``alpha_off`` added to alpha's reading), ``true_<state>`` for
    every state, ``plant`` and ``hidden``."""
    spec = PLANTS[plant]
    hidden = dict(hidden or {})
    unknown = set(hidden) - set(spec["hidden"])
    if unknown:
        raise ValueError(f"{plant}: no hidden effect {sorted(unknown)} (known: {spec['hidden']})")
    t = np.arange(int(round(seconds * FS)) + 1) / FS
    law = spec["control"](np.random.default_rng(seed), len(t))
    states, u = _integrate(plant, t, hidden, law=law)
    true = {}
    for i, (pos, rate) in enumerate(zip(spec["positions"], spec["rates"])):
        true[pos], true[rate] = states[:, 2 * i], states[:, 2 * i + 1]
    read = read_sensors(plant, true) if quantize else {q: true[q].copy() for q in spec["positions"]}
    if "alpha_off" in hidden:
        read["alpha"] = read["alpha"] + hidden["alpha_off"]
    return {"t": t, "u": u, **{q: read[q] for q in spec["positions"]},
            **{f"true_{k}": v for k, v in true.items()}, "plant": plant, "hidden": hidden}


def write_csv(path, r: dict) -> None:
    """The run as a measurement file (``# key: value`` lines, the header, one row per sample,
    floats as ``repr``), written atomically."""
    names = ["t", "u", *PLANTS[r["plant"]]["positions"]]
    hidden = ", ".join(f"{k}={v}" for k, v in r["hidden"].items()) or "none"
    lines = ["# generator: tests/independent_new_plants.py (hand-written EOM, scipy solve_ivp DOP853)",
             f"# plant: models/{r['plant']}.toml figures", f"# hidden: {hidden}", ",".join(names)]
    lines += [",".join(repr(float(v)) for v in row) for row in zip(*(r[n] for n in names))]
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".independent_", suffix=".csv")
    with os.fdopen(fd, "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(tmp, path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Independent data generator for the new plants")
    ap.add_argument("plant", choices=sorted(PLANTS))
    ap.add_argument("output")
    ap.add_argument("--seconds", type=float, default=6.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--hidden", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--no-quantize", action="store_true")
    a = ap.parse_args(argv)
    hidden = {k: float(v) for k, v in (h.split("=", 1) for h in a.hidden)}
    write_csv(a.output, run(a.plant, a.seconds, a.seed, hidden, quantize=not a.no_quantize))
    return 0


if __name__ == "__main__":
    sys.exit(main())
