"""Start rates from a segment's own samples, where a derivative filter cannot give them.

Every simulation that starts from data (the free run, the horizon segments, diagnose and
fit) takes its start positions from the sensors and its start rates from the data's rate
columns or, without them, from the Savitzky-Golay derivative (:mod:`.smoothing`). On a
coarse sensor and a slow plant that derivative is poor: a 2048-line encoder (0.77 mrad a
count) on a helicopter pitch that swings 70 mrad gives rates off by about 0.01 rad/s, which
moves a 0.5 s segment's end by 8 % of the output's spread, and at the very first sample the
filter's one-sided window is four times worse again (a record whose first move is one count at
1 ms started its free run at 0.77 rad/s: the model that made the data scored 60 %).

So where the filter's error at a segment's start (:func:`~.smoothing.velocity_error_sd`, from
the sensor's step) carried over half a second exceeds ``REFINE_ABOVE`` (3 %) of an output's
spread, the segment's start rates are estimated from the segment's first ``WINDOW`` (0.1 s) with the model: one
Gauss-Newton step of the simulated-minus-measured outputs (each weighted by its sensor's
rounding noise) in the start rates, with the filter's value as a prior of that standard
deviation (a maximum a posteriori estimate, as MATLAB's ``compare`` estimates a free run's initial
state). A tenth of a second holds three times the filter's window of samples, so the rate is
several times better known; it is short against the segment, so a missing effect, whose
signature grows with the square of the time (a force) while a rate's grows with the time,
leaves the rest of the segment to show it: fitted over the whole 0.5 s, the rates took up most
of a hidden rolling resistance of a ball on a beam, and the model without it scored 98.9 %. The
prior keeps a rate within about its filter error, yet even so a refined start takes up some of
what a model lacks, so only starts that need it are refined: the SCT's 20000-line pendulum
encoder on a swing decaying from 0.8 rad moves a segment by 0.9 % (not refined: with every
segment of it refined, the other lab's pendulum of docs/identification.md, whose period the
model misses by 5 %, read as one missing a damping), the filter's one-sided window at the
record's first sample by 3.2 % (its first segment and its free run are refined). Positions whose rates the
data hold, or that are held, are never refined.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..sim.experiment_axes import irrelevant_axes
from .outputs import experiment_of, resolution_of, signals_for
from .smoothing import velocity_error_sd

REFINE_ABOVE = 0.03      # of an output's spread: the filter's rate error carried over CARRIED s above which it is refined
CARRIED = 0.5            # s, the default horizon: a longer segment (fit's later stages) is judged by the same data
WINDOW = 0.1             # s at a segment's start whose samples estimate its rates (see the module docstring)
FREE_RUN_WINDOW = 0.5    # s: a free run's one start is worth more samples; the rest of the run shows the physics


@dataclass(frozen=True)
class StartFit:
    """What refining a segment's start rates needs: the compared ``outputs``, their measured
    values (``measured``: output -> array over the record), each output's noise (its rounding,
    one standard deviation) and per position whose rate is refined, the filter's error at every
    sample (``prior``: position -> array)."""

    outputs: tuple
    measured: dict
    noise: dict
    prior: dict
    limits: dict = None      # converter ranges the data reach (Simulator.limits_reached)
    window: int = 2          # samples in WINDOW seconds of the record


def uncertain_rates(t: np.ndarray, estimated, resolution: dict, scale: dict) -> dict:
    """``{position: filter error per sample}`` for each position of ``estimated`` (rates from the
    filter), zero at the samples where that error carried over ``CARRIED`` s (or the record, if
    shorter) is within ``REFINE_ABOVE`` of its ``scale`` (a start there is not refined); positions
    refined nowhere are left out ({}: the filter serves everywhere)."""
    length = min(CARRIED, float(t[-1] - t[0]))
    out = {}
    for pos in estimated:
        step, spread = resolution.get(pos), scale.get(pos)
        if not step or not spread:
            continue
        sd = velocity_error_sd(t, step)
        sd = np.where(sd * length > REFINE_ABOVE * spread, sd, 0.0)
        if sd.any():
            out[pos] = sd
    return out


def estimated_rates(data, model=None) -> tuple:
    """The positions whose rates :func:`measured_motion` takes from the derivative filter: a
    rate the data lack, of a position the data's experiment does not hold."""
    sig = signals_for(data)
    held = irrelevant_axes(model, experiment_of(data, model)) if model is not None else set()
    return tuple(p for p in sig.positions if p not in held and sig.rate(p) is not None
                 and data.columns.get(sig.rate(p)) is None)


def start_fit(sim, t, positions: dict, estimated, outputs, resolution: dict, scale: dict) -> StartFit | None:
    """The :class:`StartFit` of a record (None when no rate needs refining)."""
    prior = uncertain_rates(t, [p for p in estimated if sim.signals.rate(p) is not None], resolution, scale)
    if not prior:
        return None
    noise = {o: max(resolution.get(o, 0.0) / np.sqrt(12.0), 1e-9 * scale.get(o, 1.0)) for o in outputs}
    return StartFit(outputs=tuple(outputs), measured={o: positions[o] for o in outputs}, noise=noise, prior=prior,
                    limits=sim.limits_reached(positions), window=_window(t, WINDOW))


def data_start_fit(sim, data, model, positions: dict, outputs) -> StartFit | None:
    """:func:`start_fit` for one data set on its own: each output's resolution and spread from it."""
    outputs = tuple(o for o in outputs if o in positions)
    resolution = {o: resolution_of(data, o) for o in sim.signals.positions if o in positions}
    scale = {o: max(float(np.std(positions[o])), resolution[o]) for o in resolution}
    return start_fit(sim, np.asarray(data.t, dtype=np.float64), positions, estimated_rates(data, model), outputs,
                     resolution, scale)


def free_run_start(sim, t, u, x0, fit: StartFit | None, p=None) -> np.ndarray:
    """A free run's start state: ``x0``, its uncertain rates (``fit``) estimated from the first
    ``FREE_RUN_WINDOW`` seconds of samples at parameters ``p`` (default the model's own)."""
    if fit is None:
        return x0
    first = min(_window(t, FREE_RUN_WINDOW), len(t) - 1)
    p = sim.param_vector if p is None else p
    columns = _columns(sim, fit, 0)
    better = _map_step(sim, p, t, u, x0, 0, first, 0, fit, sim.offset_values(p), columns) if columns else None
    return x0 if better is None else better


def _columns(sim, fit: StartFit | None, a: int) -> list:
    """(state index, filter error at sample ``a``) of each rate ``fit`` refines."""
    if fit is None:
        return []
    return [(sim.signals.index(sim.signals.rate(pos)), float(sd[a])) for pos, sd in fit.prior.items() if sd[a] > 0]


def _window(t, seconds: float) -> int:
    """Samples in ``seconds`` of ``t`` (at least 2)."""
    return max(2, int(round(seconds / float(np.median(np.diff(t))))))


def run_segment(sim, p, t, u, s0, a: int, b: int, h0: int, fit: StartFit | None = None,
                offsets: dict | None = None) -> tuple:
    """``(s0, states, valid)`` of the segment from sample ``a`` to ``b`` (input history from
    ``h0``): ``sim.raw`` from ``s0``, or, with ``fit``, from ``s0`` with its uncertain rates
    estimated from the segment's first ``WINDOW`` seconds (see the module docstring; ``offsets``:
    the sensor offsets at ``p``). ``states`` rows start at ``h0``."""
    columns = _columns(sim, fit, a)
    if not columns:
        states, valid = sim.raw(t[h0:b + 1], u[h0:b + 1], s0, p, a - h0)
        return s0, states, valid
    # the step is found on the window alone; only its result runs the whole segment
    w = min(b, a + fit.window)
    better = _map_step(sim, p, t, u, s0, a, w, h0, fit, offsets or {}, columns)
    if better is not None:
        states, valid = sim.raw(t[h0:b + 1], u[h0:b + 1], better, p, a - h0)
        if valid > b - h0:
            return better, states, valid
    states, valid = sim.raw(t[h0:b + 1], u[h0:b + 1], s0, p, a - h0)
    return s0, states, valid


def _map_step(sim, p, t, u, s0, a: int, w: int, h0: int, fit: StartFit, offsets: dict, columns: list):
    """``s0`` with its rates moved by one Gauss-Newton step over samples a..w, the prior of each
    its filter error (``columns``: (state index, sd)); None when a run diverges or the step does
    not lower the posterior cost (the step of a non-linear segment can overshoot)."""
    def errors(start):
        st, ok = sim.raw(t[h0:w + 1], u[h0:w + 1], start, p, a - h0)
        return _scaled_errors(sim, fit, offsets, st, a, w, h0) if ok > w - h0 else None

    base = errors(s0)
    if base is None:
        return None
    jac = np.empty((base.size, len(columns)))
    for j, (index, sd) in enumerate(columns):
        moved = np.array(s0, dtype=np.float64)
        moved[index] += sd
        e = errors(moved)
        if e is None:
            return None
        jac[:, j] = (e - base) / sd
    weights = np.array([1.0 / sd for _, sd in columns])
    step = np.linalg.solve(jac.T @ jac + np.diag(weights ** 2), -jac.T @ base)
    better = np.array(s0, dtype=np.float64)
    for (index, _), d in zip(columns, step):
        better[index] += d
    after = errors(better)
    if after is None or float(after @ after + np.sum((step * weights) ** 2)) >= float(base @ base):
        return None
    return better


def _scaled_errors(sim, fit: StartFit, offsets: dict, states, a: int, b: int, h0: int) -> np.ndarray:
    """Simulated minus measured outputs over samples a+1..b, each over its noise, stacked."""
    return np.concatenate([(sim.reading(o, states[a - h0 + 1:b - h0 + 1, sim.signals.index(o)] + offsets.get(o, 0.0), fit.limits)
                            - fit.measured[o][a + 1:b + 1]) / fit.noise[o] for o in fit.outputs])
