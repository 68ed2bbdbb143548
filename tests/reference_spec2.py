"""Independent reference implementation of the spec §2 plant (thesis Table 14 model).

What it is for: an oracle for ``pendc.sim`` that shares *no code* with it. pendc
derives its equations of motion with sympy from the Lagrangian and generates a
numba kernel from them; this module instead types in, by hand, the thesis' own
solved form of the equations (II.46 - II.48) and the Stribeck friction law
(II.106) with the sticking rule exactly as spec §2 words it. If the two agree on
a long, rich input (the 20 s chirp), the derivation, the effect assembly, the
code generation and the integrator of pendc are all cross-checked at once.

The model is fixed to the structure of ``models/sct_thesis_final.toml``:

* drive ``F_in = alpha (u - V_off)`` (II.1), input held constant between samples (ZOH);
* viscous cart friction ``-b_x dx`` and pivot damping ``-b_theta dtheta``;
* cart friction without the viscous part (II.106), normal force ``F_N = (M + m) g``::

      dx != 0 (exact zero test):  F' = -(mu_c + (mu_s - mu_c) exp(-(|dx|/v_s)^gamma)) F_N sgn(dx)
      dx == 0, |F_in| <  mu_s F_N: F' = -F_in
      dx == 0, otherwise:          F' = -mu_s F_N sgn(F_in)

* ``f_TOT = F_in + F'`` and, with ``k = (mL^2 + I)(M + m) - m^2 L^2 cos^2 theta`` (II.46),
  the accelerations of II.47 (ddtheta) and II.48 (ddx);
* the cart velocity clamped to ``|dx| <= v_max`` after every integration step.

Integration is classic fourth-order Runge-Kutta at a fixed step (default 10 us);
each sample interval ``[t_k, t_k+1)`` is cut into ``ceil(span / dt)`` equal steps.
All parameters are plain floats with the Table 14 values as defaults; nothing
is imported from pendc.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# Thesis Table 14 (final identified parameters), spec §3.
TABLE14 = dict(
    g=9.80665, M=103.205, m=0.581, L=0.138867, I=6.21034e-3,
    b_x=877.31327, b_theta=0.0012889,
    mu_c=0.1331798, mu_s=0.1035951, v_s=0.9539722, gamma=1.0,
    alpha=260.78841, V_off=5.264616, v_max=0.55,
)
PARAM_ORDER = tuple(TABLE14)


@njit(cache=True)
def _sgn(v):
    if v > 0.0:
        return 1.0
    if v < 0.0:
        return -1.0
    return 0.0


@njit(cache=True)
def _derivs(x, dx, th, dth, F_in, g, M, m, L, I, b_x, b_theta, mu_c, mu_s, v_s, gamma):
    """(dx, ddx, dtheta, ddtheta) of II.47/II.48 with the II.106 friction."""
    F_N = (M + m) * g
    # II.106 plus the sticking rule of spec §2 (v_stick = 0: exact zero test)
    if dx != 0.0:
        fric = -(mu_c + (mu_s - mu_c) * math.exp(-((abs(dx) / v_s) ** gamma))) * F_N * _sgn(dx)
    elif abs(F_in) < mu_s * F_N:
        fric = -F_in
    else:
        fric = -mu_s * F_N * _sgn(F_in)
    f_tot = F_in + fric

    s = math.sin(th)
    c = math.cos(th)
    k = (m * L * L + I) * (M + m) - m * m * L * L * c * c  # II.46
    # II.47
    ddth = (-(m * m * L * L * c * s) / k * dth * dth
            - (m * L * c * b_x) / k * dx
            + (m * L * c) / k * f_tot
            - ((M + m) * m * g * L * s) / k
            - ((M + m) * b_theta) / k * dth)
    # II.48 (the bracket of II.47 is ddth)
    ddx = (m * L * c * ddth - m * L * dth * dth * s - b_x * dx + f_tot) / (M + m)
    return dx, ddx, dth, ddth


@njit(cache=True)
def _simulate(t, u, s0, dt, g, M, m, L, I, b_x, b_theta, mu_c, mu_s, v_s, gamma, alpha, V_off, v_max):
    n = t.shape[0]
    out = np.empty((n, 4))
    x, dx, th, dth = s0[0], s0[1], s0[2], s0[3]
    out[0, 0] = x
    out[0, 1] = dx
    out[0, 2] = th
    out[0, 3] = dth
    for kk in range(n - 1):
        span = t[kk + 1] - t[kk]
        nsub = int(math.ceil(span / dt - 1e-9))
        if nsub < 1:
            nsub = 1
        h = span / nsub
        F_in = alpha * (u[kk] - V_off)  # II.1, ZOH
        for _ in range(nsub):
            a1, b1, c1, d1 = _derivs(x, dx, th, dth, F_in, g, M, m, L, I, b_x, b_theta, mu_c, mu_s, v_s, gamma)
            a2, b2, c2, d2 = _derivs(x + 0.5 * h * a1, dx + 0.5 * h * b1, th + 0.5 * h * c1, dth + 0.5 * h * d1,
                                     F_in, g, M, m, L, I, b_x, b_theta, mu_c, mu_s, v_s, gamma)
            a3, b3, c3, d3 = _derivs(x + 0.5 * h * a2, dx + 0.5 * h * b2, th + 0.5 * h * c2, dth + 0.5 * h * d2,
                                     F_in, g, M, m, L, I, b_x, b_theta, mu_c, mu_s, v_s, gamma)
            a4, b4, c4, d4 = _derivs(x + h * a3, dx + h * b3, th + h * c3, dth + h * d3,
                                     F_in, g, M, m, L, I, b_x, b_theta, mu_c, mu_s, v_s, gamma)
            x = x + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
            dx = dx + h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
            th = th + h / 6.0 * (c1 + 2.0 * c2 + 2.0 * c3 + c4)
            dth = dth + h / 6.0 * (d1 + 2.0 * d2 + 2.0 * d3 + d4)
            # velocity saturation (thesis Fig. III.2), after integration
            if dx > v_max:
                dx = v_max
            elif dx < -v_max:
                dx = -v_max
        out[kk + 1, 0] = x
        out[kk + 1, 1] = dx
        out[kk + 1, 2] = th
        out[kk + 1, 3] = dth
    return out


def simulate_reference(t, u, x0=(0.0, 0.0, 0.0, 0.0), dt=1e-5, **params):
    """States at the sample times ``t`` for the ZOH input ``u`` (V).

    Returns a dict of arrays ``x, dx, theta, dtheta``. Keyword arguments override
    the Table 14 parameters (``g M m L I b_x b_theta mu_c mu_s v_s gamma alpha V_off v_max``).
    """
    unknown = set(params) - set(TABLE14)
    if unknown:
        raise TypeError(f"unknown parameter(s): {sorted(unknown)}")
    p = {**TABLE14, **{k: float(v) for k, v in params.items()}}
    t = np.ascontiguousarray(t, dtype=np.float64)
    u = np.ascontiguousarray(u, dtype=np.float64)
    s0 = np.asarray(x0, dtype=np.float64)
    out = _simulate(t, u, s0, float(dt), *(p[k] for k in PARAM_ORDER))
    return {"x": out[:, 0], "dx": out[:, 1], "theta": out[:, 2], "dtheta": out[:, 3]}
