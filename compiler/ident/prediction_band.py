"""Prediction bands: what a fitted model predicts, given what the fit left uncertain.

A fitted model is a distribution (:class:`~pendc.model.fit_uncertainty.FitUncertainty`: the
fit's covariance, stored in the model file). :func:`prediction_band` draws parameter sets from
it, simulates each on the measured run in free run and with the horizon restarts (as
:func:`pendc.ident.compare.compare` does the nominal model), and keeps, per output and sample,
the central 95 % of the simulated values. ``outside`` is how often the measurement leaves
the band: about 5 % or less says the fit's uncertainty explains the model's error; much more
says the error is structural (a missing effect, noise the band does not hold), not a matter of
parameter values. The band holds parameter uncertainty and the sensors' quantisation (half a
count each side: a reading of a value inside the band lies inside it), not sensor noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import PendcError
from ..model.fit_uncertainty import BAND_SAMPLES, FitUncertainty
from ..model.plant import PlantModel
from ..sim.simulator import Simulator
from .fit import parameter_bounds
from .horizon import DEFAULT_HORIZON, horizon_run, integration_step, measured_motion
from .outputs import experiment_of
from .smoothing import velocity_error_sd
from .start_rates import data_start_fit, free_run_start

LEVEL = 0.95


@dataclass(frozen=True)
class PredictionBand:
    """``free[k]`` and ``horizon[k]``: (low, high) arrays of output ``k`` over the run's samples
    (free run; horizon restarts, NaN where no segment predicts); ``outside_free[k]`` and
    ``outside_horizon[k]``: the fraction of samples where the measurement lies outside.
    ``diverged`` counts draws whose simulation diverged (left out of the band)."""

    uncertainty: FitUncertainty
    samples: int
    seed: int
    free: dict
    horizon: dict
    outside_free: dict
    outside_horizon: dict
    horizon_s: float = DEFAULT_HORIZON
    diverged: int = 0

    def to_json(self) -> dict:
        """Plain JSON: how the band was made and how often the data leave it (fractions)."""
        u = self.uncertainty
        return {"level": LEVEL, "samples": self.samples, "seed": self.seed, "diverged": self.diverged,
                "parameters": {n: {"value": float(m), "std": float(s)} for n, m, s in zip(u.names, u.mean, u.std)},
                "from": u.source, "outside_free_run": dict(self.outside_free),
                "outside_horizon": dict(self.outside_horizon), "horizon_s": self.horizon_s,
                "label": "fraction of samples where the measurement is outside the 95 % prediction band"}

    def lines(self) -> list:
        """The text report's lines: where the band comes from and how often the data leave it."""
        out = [f"prediction band ({self.samples} draws of {self.uncertainty.describe()}):"]
        for k in self.outside_free:
            out.append(f"  {k}: measurement outside the 95 % band {100 * self.outside_free[k]:.1f} % of the time "
                       f"in free run, {100 * self.outside_horizon[k]:.1f} % on the {self.horizon_s:g} s horizon")
        if self.diverged:
            out.append(f"  {self.diverged} of {self.samples} draws diverged and are not in the band")
        return out


def prediction_band(model: PlantModel, data, uncertainty: FitUncertainty, samples: int = BAND_SAMPLES,
                    seed: int = 0, dt: float = 1e-4, method: str = "rk4", horizon: float = DEFAULT_HORIZON,
                    outputs=None) -> PredictionBand:
    """The 95 % band of ``model``'s free run and ``horizon`` s prediction on ``data`` over
    ``samples`` parameter draws from ``uncertainty`` (each clipped to its physical range);
    ``outputs``: the positions compared (default: the plant's). See the module docstring."""
    if samples < 2:
        raise PendcError(f"a prediction band needs at least 2 draws, got {samples}")
    experiment = experiment_of(data, model)
    if experiment != model.experiment:
        model = model.for_experiment(experiment)
    t, u = np.asarray(data.t, dtype=np.float64), np.asarray(data.u, dtype=np.float64)
    sim = Simulator(model, dt=integration_step(dt, t, model), method=method)
    outputs = tuple(outputs) if outputs is not None else sim.signals.positions
    y = {k: np.asarray(data.column(k), dtype=np.float64) for k in outputs}
    position, velocity = measured_motion(data, model)
    refine = data_start_fit(sim, data, model, position, outputs)
    bounds = {n: parameter_bounds(model, n) for n in uncertainty.names}
    free = {k: [] for k in outputs}
    ahead = {k: [] for k in outputs}
    diverged = 0
    rng = np.random.default_rng([seed, 1])
    for draw in uncertainty.sample(samples, seed=seed, bounds=bounds):
        values = dict(zip(uncertainty.names, map(float, draw)))
        p = sim.vector(values)
        start = _start_as_sensed(sim, data, position, velocity, rng)
        try:
            x0 = free_run_start(sim, t, u, sim.true_state(sim.initial_vector(*start, 0), p), refine, p)
            run = sim(t, u, x0=tuple(x0), params=values)
            restarted = horizon_run(model, data, outputs=outputs, horizon=horizon, dt=dt, method=method,
                                    params=values, motion=start)
        except PendcError:             # a draw that diverges predicts nothing; counted, not banded
            diverged += 1
            continue
        for k in outputs:
            free[k].append(run.outputs[k])
            ahead[k].append(restarted.outputs[k])
    if samples - diverged < 2:
        raise PendcError(f"{data.source}: {diverged} of {samples} parameter draws diverged; no prediction band")
    q = (100 * (1 - LEVEL) / 2, 100 * (1 + LEVEL) / 2)
    half = {k: 0.5 * (sim.signals.resolution(k) or 0.0) for k in outputs}
    band_free = {k: _widen(np.percentile(np.array(free[k]), q, axis=0), half[k]) for k in outputs}
    band_ahead = {k: _widen(_percentiles(np.array(ahead[k]), q), half[k]) for k in outputs}
    return PredictionBand(uncertainty=uncertainty, samples=samples, seed=seed, free=band_free, horizon=band_ahead,
                          outside_free={k: _outside(y[k], *band_free[k]) for k in outputs},
                          outside_horizon={k: _outside(y[k], *band_ahead[k]) for k in outputs},
                          horizon_s=float(horizon), diverged=diverged)


def _start_as_sensed(sim: Simulator, data, position: dict, velocity: dict, rng) -> tuple:
    """One draw of the states the runs start from, as uncertain as the sensors leave them: each
    quantised position off by a uniform error within half a count, each velocity the
    Savitzky-Golay filter estimated off by that error's effect on the filter
    (:func:`~pendc.ident.smoothing.velocity_error_sd`). Held axes and velocities the data
    give as columns are taken as measured."""
    t = np.asarray(data.t, dtype=np.float64)
    sig = sim.signals
    out_p, out_v = dict(position), dict(velocity)
    for k in sig.positions:
        step = sig.resolution(k)
        if not step or data.columns.get(k) is None:
            continue
        out_p[k] = position[k] + rng.uniform(-0.5 * step, 0.5 * step, len(t))
        rate = sig.rate(k)
        if rate is not None and data.columns.get(rate) is None and np.any(velocity[k]):
            out_v[k] = velocity[k] + rng.standard_normal(len(t)) * velocity_error_sd(t, step)
    return out_p, out_v


def _widen(band, half: float) -> tuple:
    """(low - half, high + half): a quantised reading of a value inside the band lies in this."""
    low, high = band
    return low - half, high + half


def _percentiles(draws: np.ndarray, q: tuple) -> tuple:
    """(low, high) over the draws (rows) at every sample a segment predicts (NaN columns are the
    same in every draw: the restarts are)."""
    low, high = np.full(draws.shape[1], np.nan), np.full(draws.shape[1], np.nan)
    covered = np.isfinite(draws).all(axis=0)
    if covered.any():
        low[covered], high[covered] = np.percentile(draws[:, covered], q, axis=0)
    return low, high


def _outside(y: np.ndarray, low: np.ndarray, high: np.ndarray) -> float:
    """Fraction of the samples the band covers (not NaN) where ``y`` lies outside [low, high]."""
    covered = np.isfinite(low) & np.isfinite(high)
    if not covered.any():
        return float("nan")
    return float(np.mean((y[covered] < low[covered]) | (y[covered] > high[covered])))
