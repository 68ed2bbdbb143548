"""Labelled fit figures: what a percentage means, on which file.

"fit %" used to mean three things without a label. Every figure here says what it is:
the *k-step horizon fit* (the simulation restarts from the measured state every
``horizon`` seconds: what identification minimises) or the *free-run fit* (one
simulation from the first sample to the last), per file and pooled.
fit% = 100 (1 - |sim - data| / |data - mean(data)|) per output (MATLAB's ``compare``).
A free-run fit of an angle counts each extra turn of an unwrapped angle as 2 pi of error, so
the wrapped-angle error (the angle difference folded into (-pi, pi]) is given beside it.
"""

from __future__ import annotations

import numpy as np

from ..model.plant import PlantModel
from ..sim.simulator import Simulator
from .regimes import swing_angle
from .shooting import ShootingProblem, horizon_figures
from .start_rates import free_run_start, start_fit


def _fit(err: np.ndarray, y: np.ndarray) -> float:
    den = float(np.sum((y - np.mean(y)) ** 2))
    if den <= 0:
        return 0.0
    return 100.0 * (1.0 - float(np.sqrt(np.sum(err ** 2) / den)))


def free_run_figures(model: PlantModel, datasets: list, dt: float = 1e-4, outputs=None) -> dict:
    """Free-run fit per file and pooled: ``{"label", "pooled", "files": [{"file", "experiment",
    "fit", "wrapped_<angle>_rms"}]}`` (the RMS free-run error of the plant's last periodic position,
    e.g. a pendulum's angle, wrapped to one turn); a run that diverges scores -inf."""
    problem = ShootingProblem(model, datasets, [], dt=dt, segment=1e9, outputs=outputs)
    files, num, den, wrapped_sq, wrapped_n = [], {}, {}, 0.0, 0
    for rec, limits in zip(problem.records, problem.limits):
        sim = problem.sim_for(rec)
        p = sim.param_vector
        s0 = sim.true_state(sim.initial_vector(rec.positions, rec.rates, 0), p)
        refine = start_fit(sim, rec.t, rec.positions, rec.estimated, rec.outputs, problem.resolution, problem.scales)
        s0 = free_run_start(sim, rec.t, rec.u, s0, refine)
        states, valid = sim.raw(rec.t, rec.u, s0, p)
        off = sim.offset_values(p)
        fit, extra = {}, {}
        swing = swing_angle(model)
        for o in sim.signals.positions:
            if o not in rec.outputs:
                continue
            col = sim.signals.index(o)
            y = rec.positions[o]
            if valid < rec.t.size:
                fit[o] = float("-inf")
                continue
            err = sim.reading(o, states[:, col] + off[o], limits) - y
            fit[o] = _fit(err, y)
            num[o] = num.get(o, 0.0) + float(err @ err)
            den[o] = den.get(o, 0.0) + float(np.sum((y - np.mean(y)) ** 2))
            if o == swing:       # the swinging angle (a pendulum's), wrapped
                wrapped = np.angle(np.exp(1j * err))
                key = f"wrapped_{o}_rms"
                extra[key] = float(np.sqrt(np.mean(wrapped ** 2)))
                wrapped_sq, wrapped_n = wrapped_sq + float(wrapped @ wrapped), wrapped_n + wrapped.size
        files.append({"file": rec.source, "experiment": rec.experiment, "fit": fit, **extra})
    pooled = {o: (100.0 * (1.0 - float(np.sqrt(num[o] / den[o]))) if den[o] > 0 else 0.0) for o in num}
    for f in files:   # a diverged file makes the pooled figure meaningless
        for o, v in f["fit"].items():
            if not np.isfinite(v):
                pooled[o] = v
    out = {"label": "free-run fit", "pooled": pooled, "files": files}
    if wrapped_n:
        out[key] = float(np.sqrt(wrapped_sq / wrapped_n))
    return out


def figures(model: PlantModel, datasets: list, horizon: float = 0.5, dt: float = 1e-4, outputs=None) -> dict:
    """Both labelled figures: ``{"horizon": ..., "free_run": ...}``."""
    return {"horizon": horizon_figures(model, datasets, horizon, dt, outputs),
            "free_run": free_run_figures(model, datasets, dt, outputs)}


def values_text(fig: dict) -> str:
    """``<output> 97.1 %, <angle> 88.0 % (wrapped-angle RMS error 0.012 rad)`` of one figure dict."""
    parts = ", ".join(f"{o} {v:.1f} %" for o, v in (fig.get("pooled") or fig.get("fit")).items())
    wrapped = [k for k in fig if k.startswith("wrapped_") and k.endswith("_rms")]
    if wrapped:
        parts += f" (wrapped-angle RMS error {fig[wrapped[0]]:.3g} rad)"
    return parts or "no output compared"


def describe(fig: dict) -> str:
    """``0.5 s horizon fit: <output> 97.1 %, <angle> 88.0 %`` (pooled)."""
    return f"{fig['label']}: {values_text(fig)}"


UNWRAPPED_NOTE = ("a free-run fit of an angle counts each extra turn of the unwrapped angle as 2 pi of error; "
                  "the wrapped-angle error is given beside it, and the 0.5 s horizon fit does not depend on turns")
