"""Equation-error evidence: the force and torque the model leaves unexplained, in words.

Positions are smoothed and differentiated (Savitzky-Golay, ~51 ms, cubic) to get
velocities and accelerations; the Euler-Lagrange left-hand sides then give the
generalized force on the cart and torque at the pivot that the data *needed*, and
the model's own force/torque at the measured states is subtracted. What remains is
the residual a missing effect has to supply. Samples where the cart is nearly at
rest are left out of cart-force statistics: there the model's friction is a sticking
rule that a measured (never exactly zero) velocity cannot exercise. A held cart has no
cart-force statistics, a removed pendulum no pivot torque (and no pendulum mass).
"""

from __future__ import annotations

import numpy as np
import sympy as sp
from scipy.signal import savgol_filter

from ..model.plant import PlantModel
from .outputs import experiment_of

WINDOW = 0.051
MOVING = 0.005   # m/s
MIN_SAMPLES = 20  # fewer samples than this give no correlation worth reporting
# wavelengths (m) of the position-periodic forces looked for: rail ripple, screw pitch, cogging
WAVELENGTHS = (0.005, 0.01, 0.02, 0.03, 0.04, 0.06, 0.08, 0.12, 0.2)


def _derivatives(t, y):
    h = float(np.median(np.diff(t)))
    n = max(7, int(round(WINDOW / h)) | 1)
    if len(y) <= n:
        return np.gradient(y, t), np.gradient(np.gradient(y, t), t)
    return savgol_filter(y, n, 3, deriv=1, delta=h), savgol_filter(y, n, 3, deriv=2, delta=h)


def signals(data) -> dict:
    """Positions, their smoothed derivatives, the input and the experiment of ``data``."""
    t = np.asarray(data.t, float)
    x, th = np.asarray(data.column("x"), float), np.asarray(data.column("theta"), float)
    dx, ddx = _derivatives(t, x)
    dth, ddth = _derivatives(t, th)
    exp = experiment_of(data)
    if exp == "cart_held":
        dx, ddx = np.zeros_like(x), np.zeros_like(x)
    elif exp == "pendulum_removed":
        dth, ddth = np.zeros_like(th), np.zeros_like(th)
    return {"t": t, "u": np.asarray(data.u, float), "x": x, "dx": dx, "ddx": ddx, "theta": th, "dtheta": dth,
            "ddtheta": ddth, "experiment": exp}


def _numeric(model: PlantModel, name: str):
    """numpy function of (x, dx, theta, dtheta, u) for an assignment of the model (a lag's
    state takes the value of F_in: the force it would settle to).

    The assignments are evaluated one after another, each lambdified on its own: inlined
    into one expression, a force limit or dead zone ends up inside the sticking rule's
    condition, and sympy's printer then simplifies that logic for seconds per call."""
    eq = model.equations
    target = next((s for s, _ in eq.assignments if s.name == name), None)
    if target is None:
        return lambda **kw: np.zeros_like(kw["x"])
    values = dict(zip(eq.params, (float(v) for v in model.parameter_vector())))
    offsets = {n: float(sp.sympify(e).subs(values)) for n, e in eq.sensor_offsets}
    x, dx, theta, dtheta = eq.states[:4]
    lag = eq.states[4:]
    steps = []
    for sym, expr in eq.assignments:
        args = sorted(expr.free_symbols, key=lambda s: s.name)
        steps.append((sym, args, sp.lambdify(args, expr, "numpy")))
        if sym == target:
            break

    def evaluate(**kw):
        shape = np.shape(kw["x"])
        # the data are sensor readings: the true position is the reading minus the offset
        env = {**values, x: kw["x"] - offsets.get("x", 0.0), dx: kw["dx"],
               theta: kw["theta"] - offsets.get("theta", 0.0), dtheta: kw["dtheta"], eq.input: kw["u"]}
        with np.errstate(all="ignore"):
            for sym, args, fn in steps:
                env[sym] = np.broadcast_to(np.asarray(fn(*(env[a] for a in args)), float), shape)
                if sym.name == "F_in":
                    env.update(dict.fromkeys(lag, env[sym]))
        return np.array(env[target], dtype=float)
    return evaluate


def residuals(model: PlantModel, sig: dict) -> tuple[np.ndarray, np.ndarray]:
    """(cart force, pivot torque) the data need beyond what ``model`` supplies."""
    p = model.plant
    M, m, L, I, g = p["M"], p["m"], p["L"], p["I"], p["g"]
    exp = sig.get("experiment", "free")
    model = model.for_experiment(exp)
    if exp == "pendulum_removed":
        m = 0.0
    off = dict((n, model.parameter_values()[e.name]) for n, e in model.equations.sensor_offsets)
    th, dth = sig["theta"] - off.get("theta", 0.0), sig["dtheta"]
    need_x = (M + m) * sig["ddx"] - m * L * np.cos(th) * sig["ddtheta"] + m * L * dth**2 * np.sin(th)
    need_t = (m * L**2 + I) * sig["ddtheta"] - m * L * np.cos(th) * sig["ddx"] + m * g * L * np.sin(th)
    kw = {k: sig[k] for k in ("x", "dx", "theta", "dtheta", "u")}
    return need_x - _numeric(model, "F_cart")(**kw), need_t - _numeric(model, "tau_pend")(**kw)


def _corr(a, b) -> float:
    """Pearson correlation; 0 when either side is constant or there are too few samples."""
    if a.size < MIN_SAMPLES:
        return 0.0
    a, b = a - a.mean(), b - b.mean()
    den = float(np.sqrt((a @ a) * (b @ b)))
    return float(a @ b / den) if den > 1e-300 else 0.0


SENTENCES = {
    "cart_spring": "the residual force on the cart grows with position and pulls the cart back (a spring or cable)",
    "asymmetric_cart": "the residual force on the cart follows sgn(dx) with a different size left and right",
    "coulomb_cart": "the residual force on the cart follows sgn(dx): dry friction",
    "viscous_cart": "the residual force on the cart is proportional to its speed",
    "static_cart": "the cart stays stuck for inputs the model says would move it",
    "coulomb_pendulum": "the residual torque at the pivot follows -sgn(dtheta): dry friction in the pivot",
    "viscous_pendulum": "the residual torque at the pivot is proportional to -dtheta: viscous damping of the swing",
    "drive_deadzone": "the cart does not respond to small inputs around V_off: a dead zone in the drive",
    "force_limit": "the drive force stops growing for large inputs: a current limit",
    "motor_lag": "the force builds up with a first-order lag after input changes",
    "input_delay": "the response starts a fixed time after the input changes: a transport delay",
    "velocity_limit": "the cart speed saturates",
    "quadratic_pendulum": "the residual torque at the pivot grows with -dtheta|dtheta|: air drag on the swing",
    "theta_offset": "the pendulum rests at an angle the sensor does not call zero: an offset of the angle encoder",
    "x_offset": "the cart's forces look shifted along the track: an offset of the position sensor",
    "end_stops": "the cart is pushed back hard near the ends of the track: end stops",
}


def describe_candidate(base: PlantModel, fitted: PlantModel, effect: str, datasets: list, score: float) -> str:
    """One or two sentences a control engineer can check against the plots."""
    parts = [SENTENCES.get(effect, f"adding {effect} reduces the error")]
    values = ", ".join(f"{k} = {v:.4g}" for k, v in fitted.effects.get(effect, {}).items())
    r = _contribution_correlation(base, fitted, datasets)
    if r is not None:
        parts.append(f"what {effect} adds correlates with the residual at r = {r:.2f}")
    parts.append(f"fitted {values}; it removes {100 * max(score, 0):.0f} % of the held-out simulation error")
    return "; ".join(parts) + "."


def _contribution_correlation(base, fitted, datasets):
    rs = []
    for data in datasets:
        sig = signals(data)
        rx, rt = residuals(base, sig)
        kw = {k: sig[k] for k in ("x", "dx", "theta", "dtheta", "u")}
        cx = _numeric(fitted, "F_cart")(**kw) - _numeric(base, "F_cart")(**kw)
        ct = _numeric(fitted, "tau_pend")(**kw) - _numeric(base, "tau_pend")(**kw)
        moving = np.abs(sig["dx"]) > MOVING
        cart_ok = sig["experiment"] != "cart_held" and np.count_nonzero(moving) >= MIN_SAMPLES
        pend_ok = sig["experiment"] != "pendulum_removed"
        spread_x = float(np.std(cx[moving])) if cart_ok else 0.0
        if pend_ok and np.std(ct) > 0 and np.std(ct) * 50 > spread_x * base.plant["L"]:
            rs.append(_corr(rt, ct))
        elif cart_ok and spread_x > 0:
            rs.append(_corr(rx[moving], cx[moving]))
    return float(np.mean(rs)) if rs else None


def residual_correlations(model: PlantModel, datasets: list, top: int = 6) -> list:
    """What the unexplained force and torque correlate with, strongest first."""
    rows = []
    for data in datasets:
        sig = signals(data)
        rx, rt = residuals(model, sig)
        v_off = model.effects.get("drive", {}).get("V_off", 5.0)
        x = sig["x"]
        basis = {
            "x": x, "dx": sig["dx"], "sgn(dx)": np.sign(sig["dx"]), "dx*|dx|": sig["dx"] * np.abs(sig["dx"]),
            "theta": sig["theta"], "sin(theta)": np.sin(sig["theta"]), "cos(theta)": np.cos(sig["theta"]),
            "dtheta": sig["dtheta"], "sgn(dtheta)": np.sign(sig["dtheta"]),
            "dtheta*|dtheta|": sig["dtheta"] * np.abs(sig["dtheta"]), "u - V_off": sig["u"] - v_off,
        }
        for lam in WAVELENGTHS:   # position-periodic forces (ripple, cogging) show only against x
            basis[f"sin(2 pi x/{lam:g})"] = np.sin(2 * np.pi * x / lam)
            basis[f"cos(2 pi x/{lam:g})"] = np.cos(2 * np.pi * x / lam)
        moving = np.abs(sig["dx"]) > MOVING
        targets = []
        if sig["experiment"] != "cart_held" and np.count_nonzero(moving) >= MIN_SAMPLES:
            targets.append(("cart force", rx[moving], moving))
        if sig["experiment"] != "pendulum_removed":
            targets.append(("pivot torque", rt, slice(None)))
        for name, b in basis.items():
            for target, r, keep in targets:
                rows.append({"signal": name, "target": target, "r": _corr(r, b[keep]), "file": data.source})
    rows.sort(key=lambda r: -abs(r["r"]))
    return rows[:top]


# What a strong correlation of the unexplained force/torque points at among the constants
# the model already has (rather than a missing effect): which ones to free.
PLANT_HINTS = {
    ("pivot torque", "sin(theta)"): ("I", "the swing's period is off (free I, or L)"),
    ("pivot torque", "theta"): ("I", "the swing's period is off (free I, or L)"),
    ("pivot torque", "dtheta"): ("b_theta", "the pivot damping is off"),
    ("cart force", "u - V_off"): ("alpha,V_off", "the drive gain or offset is off"),
    ("cart force", "dx"): ("b_x", "the viscous friction of the cart is off"),
}
HINT_R = 0.4


def parameter_hint(model: PlantModel, correlations: list) -> tuple | None:
    """``(parameters, reasons)`` to free when the strong correlations point at constants the
    model has, or None."""
    names = set(model.parameter_names())
    params, reasons = {}, {}
    for row in correlations:
        if abs(row["r"]) < HINT_R:
            break
        hint = PLANT_HINTS.get((row["target"], row["signal"]))
        if hint and all(p in names for p in hint[0].split(",")):
            params.update(dict.fromkeys(hint[0].split(",")))
            reasons[hint[1]] = None
    return (",".join(params), "; ".join(reasons)) if params else None
