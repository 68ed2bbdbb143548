"""An independent generator of Furuta pendulum (Quanser QUBE-Servo 2) measurement data.

Nothing here comes from pendc: the equations of motion are written out by hand in the
manipulator form of Cazzolato & Prime (2011, "On the dynamics of the Furuta pendulum",
slender symmetric pendulum), integrated by scipy's ``solve_ivp`` (RK45, one call per
zero-order-hold sample of the input), and the encoders are quantised here (×4 decoding of
512-line disks: 2048 counts per revolution, counted from the initial state). So data made here
test pendc's Furuta model, simulator and identification from outside, as a lab's recording
would, with whatever hidden effect the caller switches on.

From Python::

    from tests.independent_furuta import QUBE, stimulus, simulate, write_csv
    t, u = stimulus(seconds=10.0, seed=1)                 # chirp + steps within +-5 V, 1 kHz
    run = simulate(t, u, params={**QUBE, "tau_r": 0.003}) # hidden: dry friction on the arm
    write_csv("hidden_coulomb_arm.csv", run, hidden="coulomb_arm tau_r=0.003")

From the command line (repository root)::

    python tests/independent_furuta.py OUT.csv [--seconds 10] [--seed 1] [--tau-r 0.003]
        [--alpha-offset 0.05] [--arm-held] [--no-quantize]

Parameters are the names of ``models/furuta_qube.toml`` (``g J_r L_r m_p L_p R_m k_t k_m
D_r D_p``) plus the hidden effects: ``tau_r`` (N*m, dry friction of the arm: -tau_r sgn(dphi)
while it turns, and it stands while the friction can hold it) and ``alpha_p_off`` (rad, added
to the pendulum's reading). Columns written: ``t, u, phi_r, alpha_p`` (angles as the encoders read them) and
``dphi_r, dalpha_p`` (true rates); ``# key: value`` lines say what made the file.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile

import numpy as np
from scipy.integrate import solve_ivp

# The QUBE-Servo 2's published figures (user manual; Quanser's qube2_rotpen_param.m)
QUBE = {"g": 9.81, "J_r": 0.095 * 0.085 ** 2 / 12, "L_r": 0.085, "m_p": 0.024, "L_p": 0.129,
        "R_m": 8.4, "k_t": 0.042, "k_m": 0.042, "D_r": 0.0015, "D_p": 0.0005}
COUNTS_PER_REV = 4 * 512
RESOLUTION = 2 * math.pi / COUNTS_PER_REV


def _terms(y, u, p: dict):
    """Mass matrix entries, the arm's right side without dry friction, and the pendulum's."""
    _, dphi, alpha, dalpha = y
    m, l2 = p["m_p"], p["L_p"] / 2
    J0h, J2h, K = p["J_r"] + m * p["L_r"] ** 2, m * p["L_p"] ** 2 / 3, m * p["L_r"] * l2
    s, c = math.sin(alpha), math.cos(alpha)
    r1 = (p["k_t"] * (u - p["k_m"] * dphi) / p["R_m"] - p["D_r"] * dphi
          + K * s * dalpha ** 2 - 2 * J2h * s * c * dphi * dalpha)
    r2 = -p["D_p"] * dalpha + J2h * s * c * dphi ** 2 - p["g"] * m * l2 * s
    return (J0h + J2h * s * s, K * c, J2h), r1, r2


def accelerations(y, u, p: dict, friction: float = 0.0) -> tuple:
    """(arm'', pendulum'') at state ``y = (phi, dphi, alpha, dalpha)`` and voltage ``u``, the arm's
    dry friction torque being ``friction`` (its sign included: -tau_r sgn(dphi) while slipping).

    Cazzolato & Prime's slender-pendulum equations with theta1 = phi (arm), theta2 = alpha
    (pendulum from hanging down), l2 = L_p / 2, J0h = J_r + m_p L_r^2, J2h = m_p L_p^2 / 3::

        (J0h + J2h s^2) phi'' + m L_r l2 c alpha'' - m L_r l2 s alpha'^2 + 2 J2h s c phi' alpha'
            + D_r phi' = k_t (u - k_m phi') / R_m + friction
        m L_r l2 c phi'' + J2h alpha'' - J2h s c phi'^2 + D_p alpha' + g m l2 s = 0
    """
    (a11, a12, a22), r1, r2 = _terms(y, u, p)
    r1 += friction
    det = a11 * a22 - a12 * a12
    return (a22 * r1 - a12 * r2) / det, (a11 * r2 - a12 * r1) / det


def holding_torque(y, u, p: dict) -> float:
    """The torque the arm's dry friction must supply to keep a standing arm (dphi = 0) standing."""
    (_, a12, a22), r1, r2 = _terms(y, u, p)
    return a12 * r2 / a22 - r1


def stimulus(seconds: float = 10.0, seed: int = 1, fs: float = 1000.0, amplitude: float = 5.0) -> tuple:
    """An input of its own: a 0.2-4 Hz chirp for the first half, random steps after, in +-amplitude V."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds * fs)) + 1) / fs
    half = seconds / 2
    f0, f1 = 0.2, 4.0
    phase = 2 * np.pi * (f0 * t + (f1 - f0) * t ** 2 / (2 * half))
    u = amplitude * 0.6 * np.sin(phase)
    late = t >= half
    holds = np.cumsum(rng.uniform(0.05, 0.4, size=int(seconds / 0.05) + 2)) + half
    levels = rng.uniform(-amplitude, amplitude, size=len(holds) + 1)
    u[late] = levels[np.searchsorted(holds, t[late], side="right")]
    return t, u


def quantize(angle: np.ndarray, start: float) -> np.ndarray:
    """What a ×4-decoded 512-line encoder reads: whole counts moved since ``start``."""
    return start + np.floor((angle - start) / RESOLUTION + 1e-9) * RESOLUTION


def _advance(y, t0: float, t1: float, u: float, p: dict, arm_held: bool) -> np.ndarray:
    """Integrate over one input sample, switching between slipping and sticking of the arm.

    While the arm slips, its dry friction has the sign of the slip (fixed, so the integrator
    never chatters) and the slip ends when dphi comes back to zero; the arm then sticks if the
    friction can hold it (|holding torque| <= tau_r), else slips the other way. While it
    sticks only the pendulum moves, until the holding torque exceeds tau_r."""
    tau_r = p.get("tau_r", 0.0)
    y = np.array(y, dtype=float)
    mode = None                                   # decided from the state at the sample's start
    for _ in range(10_000):
        if t0 >= t1:
            return y
        need = holding_torque(y, u, p)
        if mode is None:
            if arm_held or (tau_r > 0 and y[1] == 0.0 and abs(need) <= tau_r):
                mode = "stick"
            else:
                mode = np.sign(y[1]) if y[1] != 0.0 else (-np.sign(need) or 1.0)
        if mode == "stick":
            def rhs(_, st):
                return (0.0, 0.0, st[3], accelerations(st, u, p, friction=holding_torque(st, u, p))[1])

            def event(_, st):
                return abs(holding_torque(st, u, p)) - tau_r
            event.direction = 1
        else:
            friction, way = -tau_r * mode, mode

            def rhs(_, st):
                dd = accelerations(st, u, p, friction)
                return (st[1], dd[0], st[3], dd[1])

            def event(_, st):
                return st[1] * way                # positive while the slip goes on
            event.direction = -1
        event.terminal = True
        with_event = tau_r > 0 and not arm_held
        sol = solve_ivp(rhs, (t0, t1), y, method="RK45", rtol=1e-9, atol=1e-11,
                        events=event if with_event else None)
        if sol.status == -1:
            raise RuntimeError(f"integration failed at t = {t0:.6g} s: {sol.message}")
        y = sol.y[:, -1].copy()
        if sol.status != 1:
            return y
        t0 = float(sol.t_events[0][0])
        y[1] = 0.0
        if mode == "stick":                       # the friction lets go: slip the way the rest pulls
            mode = -np.sign(holding_torque(y, u, p)) or 1.0
        else:                                     # the slip ended: stand if the friction can hold
            need = holding_torque(y, u, p)
            mode = "stick" if abs(need) <= tau_r else (-np.sign(need) or 1.0)
    raise RuntimeError(f"the arm switched between sticking and slipping 10000 times before t = {t1:.6g} s")


def simulate(t, u, params: dict | None = None, y0=(0.0, 0.0, 0.0, 0.0), quantize_angles: bool = True,
             arm_held: bool = False) -> dict:
    """Integrate from ``y0`` with ``u[k]`` held from ``t[k]`` to ``t[k+1]``; the states at ``t``.

    Returns ``t, u, phi_r, alpha_p`` (as the encoders read them, with any ``alpha_p_off``) and
    the true ``dphi_r, dalpha_p``, plus ``true_phi_r``/``true_alpha_p``."""
    p = {**QUBE, **(params or {})}
    t, u = np.asarray(t, dtype=float), np.asarray(u, dtype=float)
    out = np.empty((len(t), 4))
    y = np.array(y0, dtype=float)
    out[0] = y
    for k in range(len(t) - 1):
        y = _advance(y, t[k], t[k + 1], u[k], p, arm_held)
        out[k + 1] = y
    phi, alpha = out[:, 0], out[:, 2]
    if quantize_angles:
        phi, alpha = quantize(phi, y0[0]), quantize(alpha, y0[2])
    return {"t": t, "u": u, "phi_r": phi, "alpha_p": alpha + p.get("alpha_p_off", 0.0),
            "dphi_r": out[:, 1], "dalpha_p": out[:, 3], "true_phi_r": out[:, 0], "true_alpha_p": out[:, 2]}


def write_csv(path, run: dict, hidden: str = "none", experiment: str = "free") -> None:
    """The run as a measurement file (spec section 6, the Furuta's columns), written atomically."""
    lines = ["# generator: tests/independent_furuta.py (hand-written EOM, scipy solve_ivp RK45)",
             "# plant: Quanser QUBE-Servo 2 (models/furuta_qube.toml figures)",
             f"# hidden: {hidden}", f"# experiment: {experiment}", "t,u,phi_r,alpha_p,dphi_r,dalpha_p"]
    cols = [run[k] for k in ("t", "u", "phi_r", "alpha_p", "dphi_r", "dalpha_p")]
    lines += [",".join(repr(float(v)) for v in row) for row in zip(*cols)]
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".furuta_", suffix=".csv")
    with os.fdopen(fd, "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(tmp, path)


def main(argv=None) -> int:
    """Command line: write one data file (see the module docstring)."""
    ap = argparse.ArgumentParser(description="Independent Furuta (QUBE-Servo 2) data generator")
    ap.add_argument("output")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--tau-r", type=float, default=0.0, help="hidden dry friction of the arm (N*m)")
    ap.add_argument("--alpha-offset", type=float, default=0.0, help="hidden offset of the pendulum's encoder (rad)")
    ap.add_argument("--arm-held", action="store_true", help="the arm clamped: only the pendulum swings")
    ap.add_argument("--no-quantize", action="store_true")
    a = ap.parse_args(argv)
    t, u = stimulus(a.seconds, a.seed)
    y0 = (0.0, 0.0, 1.0, 0.0) if a.arm_held else (0.0, 0.0, 0.0, 0.0)
    params = {"tau_r": a.tau_r, "alpha_p_off": a.alpha_offset}
    run = simulate(t, u, params, y0=y0, quantize_angles=not a.no_quantize, arm_held=a.arm_held)
    hidden = ", ".join(f"{k}={v}" for k, v in params.items() if v) or "none"
    write_csv(a.output, run, hidden=hidden, experiment="arm_held" if a.arm_held else "free")
    return 0


if __name__ == "__main__":
    sys.exit(main())
