"""Equation-error evidence: the acceleration the model leaves unexplained, in words.

Positions are smoothed and differentiated (Savitzky-Golay, ~51 ms, cubic:
:func:`pendc.ident.smoothing.velocity_and_acceleration`) to get velocities and
accelerations; the model's own accelerations at the measured states and input are
subtracted. What remains, per coordinate of the plant (e.g. a cart's force and a
pendulum's torque), is the residual a missing effect has to supply. The coordinates, their
rates and which of them are angles come from the plant interface, the accelerations from
the model's state equations, so the same code reads any plant.

Samples where a translation is nearly at rest (below ``MOVING`` of its rate's unit) are
left out of its statistics: there the model's friction is a sticking rule that a measured
(never exactly zero) velocity cannot exercise. A coordinate the experiment holds (a
clamped body, a removed one) has no statistics.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.plant import PlantModel
from ..sim.experiment_axes import irrelevant_axes
from ..sim.signals import signals_of
from .outputs import experiment_of
from .plant_roles import drive_offset
from .smoothing import velocity_and_acceleration

MOVING = {"m/s": 0.005}   # per rate unit: below this a translation counts as standing (sticking friction)
MIN_SAMPLES = 20  # fewer samples than this give no correlation worth reporting
# wavelengths (m) of the position-periodic forces looked for along a translation: rail
# ripple, screw pitch, cogging
WAVELENGTHS = (0.005, 0.01, 0.02, 0.03, 0.04, 0.06, 0.08, 0.12, 0.2)


def acceleration_name(rate: str) -> str:
    """The name of a rate's derivative (``d<position>`` -> ``dd<position>``), as the equations name it."""
    return f"d{rate}"


def signals(data, model: PlantModel | None = None) -> dict:
    """Positions, their smoothed rates and accelerations, the input and the experiment of
    ``data`` (keys: the plant's state names, ``d<rate>`` for accelerations, the input's name,
    ``t`` and ``experiment``). A position the experiment holds has zero rate and acceleration."""
    sig = signals_of(getattr(data, "signals", None) if model is None else model)
    t = np.asarray(data.t, float)
    exp = experiment_of(data, model)
    held = irrelevant_axes(model, exp)
    out = {"t": t, sig.input: np.asarray(data.u, float), "experiment": exp}
    for p in sig.positions:
        y = np.asarray(data.column(p), float)
        rate = sig.rate(p)
        v, a = velocity_and_acceleration(t, y)
        if p in held:
            v, a = np.zeros_like(y), np.zeros_like(y)
        out[p] = y
        if rate is not None:
            out[rate], out[acceleration_name(rate)] = v, a
    return out


def _numeric(model: PlantModel, names: tuple):
    """numpy function of the measured signals (keyword arguments by state and input name)
    giving the model's values of ``names`` (assignments or state derivatives ``d<rate>``).

    The assignments are evaluated one after another, each lambdified on its own: inlined
    into one expression, a force limit or dead zone ends up inside the sticking rule's
    condition, and sympy's printer then simplifies that logic for seconds per call. A lag
    state takes its settled value (its initial value for the present input)."""
    eq = model.equations
    sig = signals_of(model)
    values = dict(zip(eq.params, (float(v) for v in model.parameter_vector())))
    offsets = {n: float(sp.sympify(e).subs(values)) for n, e in eq.sensor_offsets}
    nm = len(eq.states) - len(eq.initial)
    derivative = {acceleration_name(s.name): sp.sympify(d) for s, d in zip(eq.states, eq.derivatives)}

    def compiled(expr):
        args = sorted(expr.free_symbols, key=lambda s: s.name)
        return args, sp.lambdify(args, expr, "numpy")

    lags = {state: compiled(sp.sympify(init)) for state, init in zip(eq.states[nm:], eq.initial)}
    steps = [(sym, *compiled(expr)) for sym, expr in eq.assignments]
    steps += [(sp.Symbol(f"__out_{n}"), *compiled(derivative[n])) for n in names if n in derivative]

    def evaluate(**kw):
        shape = np.shape(kw[sig.input])
        env = dict(values)
        for s in eq.states[:nm]:
            # the data are sensor readings: the true position is the reading minus the offset
            env[s] = np.asarray(kw.get(s.name, np.zeros(shape)), float) - offsets.get(s.name, 0.0)
        env[eq.input] = kw[sig.input]

        def value(args, fn):
            for a in args:
                if a not in env and a in lags:     # a lag state: the value it settles to
                    env[a] = value(*lags[a])
            return np.broadcast_to(np.asarray(fn(*(env[a] for a in args)), float), shape)

        with np.errstate(all="ignore"):
            for sym, args, fn in steps:
                env[sym] = value(args, fn)
        out = {}
        for n in names:
            key = sp.Symbol(f"__out_{n}") if n in derivative else next((s for s, _ in eq.assignments if s.name == n),
                                                                         None)
            out[n] = np.array(env[key], dtype=float) if key is not None else np.zeros(shape)
        return out
    return evaluate


def _coordinates(model: PlantModel) -> list:
    """``(position, rate, acceleration name)`` of every coordinate with a rate."""
    sig = signals_of(model)
    return [(p, sig.rate(p), acceleration_name(sig.rate(p))) for p in sig.positions if sig.rate(p) is not None]


def target_name(model: PlantModel, position: str) -> str:
    """How a report names a coordinate's residual: "<body> acceleration" (the body the plant file names)."""
    return f"{signals_of(model).body_of(position)} acceleration"


def residuals(model: PlantModel, sig: dict) -> dict:
    """Per coordinate (by position name), the acceleration the data need beyond what ``model``
    gives at the measured states and input (``model`` set to the data's experiment)."""
    model = model.for_experiment(sig.get("experiment", model.experiment))
    coords = _coordinates(model)
    kw = _kwargs(model, sig)
    own = _numeric(model, tuple(a for _, _, a in coords))(**kw)
    return {p: sig[a] - own[a] for p, _, a in coords}


def _kwargs(model, sig: dict) -> dict:
    s = signals_of(model)
    return {k: sig[k] for k in (*s.mechanical, s.input) if k in sig}


def _usable(model: PlantModel, sig: dict) -> dict:
    """Per coordinate, the samples its statistics may use (None: the coordinate is held)."""
    s = signals_of(model)
    held = irrelevant_axes(model, sig["experiment"])
    out = {}
    for p, rate, _ in _coordinates(model):
        if p in held:
            continue
        threshold = MOVING.get(s.unit(rate))
        if threshold is None:
            out[p] = slice(None)
            continue
        moving = np.abs(sig[rate]) > threshold
        if np.count_nonzero(moving) >= MIN_SAMPLES:
            out[p] = moving
    return out


def _corr(a, b) -> float:
    """Pearson correlation; 0 when either side is constant or there are too few samples."""
    if a.size < MIN_SAMPLES:
        return 0.0
    a, b = a - a.mean(), b - b.mean()
    den = float(np.sqrt((a @ a) * (b @ b)))
    return float(a @ b / den) if den > 1e-300 else 0.0


def describe_candidate(base: PlantModel, fitted: PlantModel, effect: str, datasets: list, score: float) -> str:
    """One or two sentences a control engineer can check against the plots."""
    parts = [base.rigid_body.notes.evidence.get(effect, f"adding {effect} reduces the error")]
    values = ", ".join(f"{k} = {v:.4g}" for k, v in fitted.effects.get(effect, {}).items())
    r = _contribution_correlation(base, fitted, datasets)
    if r is not None:
        parts.append(f"what {effect} adds correlates with the residual at r = {r:.2f}")
    parts.append(f"fitted {values}; it removes {100 * max(score, 0):.0f} % of the held-out simulation error")
    return "; ".join(parts) + "."


def _contribution_correlation(base, fitted, datasets):
    """Correlation of what the effect adds with the residual, on the coordinate where its
    contribution is largest against the residual's own spread."""
    rs = []
    for data in datasets:
        sig = signals(data, base)
        exp_base, exp_fit = base.for_experiment(sig["experiment"]), fitted.for_experiment(sig["experiment"])
        coords = _coordinates(base)
        res = residuals(base, sig)
        names = tuple(a for _, _, a in coords)
        kw = _kwargs(base, sig)
        with_effect, without = _numeric(exp_fit, names)(**kw), _numeric(exp_base, names)(**kw)
        best, share = None, 0.0
        for p, keep in _usable(base, sig).items():
            a = acceleration_name(signals_of(base).rate(p))
            added = (with_effect[a] - without[a])[keep]
            spread = float(np.std(res[p][keep]))
            size = float(np.std(added)) / spread if spread > 0 else 0.0
            if size > share:
                best, share = (p, added, keep), size
        if best is not None:
            p, added, keep = best
            rs.append(_corr(res[p][keep], added))
    return float(np.mean(rs)) if rs else None


def _basis(model: PlantModel, sig: dict) -> dict:
    """Simple signals a missing force may follow: each position (and sin/cos of an angle),
    each rate, its sign and its square with sign, the input about its centre, and
    position-periodic forces along each translation."""
    s = signals_of(model)
    offset = drive_offset(model)
    centre, centre_name = offset if offset is not None else (0.0, "")
    basis = {}
    for p in s.positions:
        basis[p] = sig[p]
        if s.period(p) is not None:
            basis[f"sin({p})"], basis[f"cos({p})"] = np.sin(sig[p]), np.cos(sig[p])
        rate = s.rate(p)
        if rate is not None:
            v = sig[rate]
            basis[rate], basis[f"sgn({rate})"], basis[f"{rate}*|{rate}|"] = v, np.sign(v), v * np.abs(v)
    basis[f"{s.input} - {centre_name}" if centre_name else s.input] = sig[s.input] - centre
    for p in [p for p in s.positions if s.period(p) is None]:
        for lam in WAVELENGTHS:   # position-periodic forces (ripple, cogging) show only against the position
            basis[f"sin(2 pi {p}/{lam:g})"] = np.sin(2 * np.pi * sig[p] / lam)
            basis[f"cos(2 pi {p}/{lam:g})"] = np.cos(2 * np.pi * sig[p] / lam)
    return basis


def residual_correlations(model: PlantModel, datasets: list, top: int = 6) -> list:
    """What the unexplained accelerations correlate with, strongest first."""
    rows = []
    for data in datasets:
        sig = signals(data, model)
        res = residuals(model, sig)
        basis = _basis(model, sig)
        targets = [(target_name(model, p), res[p][keep], keep) for p, keep in _usable(model, sig).items()]
        for name, b in basis.items():
            for target, r, keep in targets:
                rows.append({"signal": name, "target": target, "r": _corr(r, b[keep]), "file": data.source})
    rows.sort(key=lambda r: -abs(r["r"]))
    return rows[:top]


# How strong a correlation must be for a parameter hint (the body's notes say which
# constants a residual following a signal points at)
HINT_R = 0.4


def _signal_kind(model: PlantModel, body: str, signal: str) -> str | None:
    """What ``signal`` is for ``body``: "angle", "rate" (of the body's own position), "input"."""
    s = signals_of(model)
    for p in [p for p in s.positions if s.body_of(p) == body]:
        if s.period(p) is not None and signal in (p, f"sin({p})"):
            return "angle"
        if signal == s.rate(p):
            return "rate"
    return "input" if signal.split(" ", 1)[0] == s.input else None


def parameter_hint(model: PlantModel, correlations: list, fitted=()) -> tuple | None:
    """``(parameters, reasons)`` to free when the strong correlations point at constants the
    model has (its body's notes say which signal points at which constants), or None.

    ``fitted``: the parameters the fit that made ``model`` freed. They are never proposed again
    (the advice would loop); a hint whose constants were all fitted proposes what else sets the
    same thing (the hint's ``also``), and says so."""
    names = set(model.parameter_names())
    fitted = set(fitted)
    params, reasons = {}, {}
    for row in correlations:
        if abs(row["r"]) < HINT_R:
            break
        body = row["target"].rsplit(" ", 1)[0]
        kind = _signal_kind(model, body, row["signal"])
        for hint_body, hint_kind, hint_params, reason, also in model.rigid_body.notes.parameter_hints:
            if (hint_body, hint_kind) != (body, kind) or not all(p in names for p in hint_params.split(",")):
                continue
            wanted = [p for p in hint_params.split(",") if p not in fitted]
            if not wanted:
                wanted = [p for p in also.split(",") if p in names and p not in fitted]
                if not wanted:
                    continue
                reason = (f"{reason}, though the fit that made this model freed {hint_params.replace(',', ', ')} "
                          f"already: what else sets it is {', '.join(wanted)}")
            params.update(dict.fromkeys(wanted))
            reasons[reason] = None
    return (",".join(params), "; ".join(reasons)) if params else None
