"""How large is a residual that is nothing but noise?

When the model is complete, the shooting residual is what the measurement chain adds:
encoder quantisation of the positions (and of the start states derived from them) and
the unmeasured noise on the drive's input. This module measures that floor directly:
the model itself is run on the file's input through the same chain (a 12-bit DAC over the
input's range and 5 mV of input noise, as :mod:`pendc.ident.datagen` and the rig have them,
quantised to the file's resolution), and the synthetic run is scored exactly like the data. A data
residual not clearly above that floor holds nothing systematic for a missing effect
to explain.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import PendcError
from ..model.plant import PlantModel
from ..sim.simulator import Simulator
from .datagen import degrade_input
from .shooting import ShootingProblem

NOISE_FACTOR = 2.0   # a residual within this factor of the noise-only one is noise


@dataclass(frozen=True, eq=False)
class SyntheticRun:
    """A measurement-like run (the attributes identification reads)."""

    t: np.ndarray
    u: np.ndarray
    columns: dict
    source: str
    experiment: str
    missing: tuple = ()
    resolution: dict = None
    signals: object = None   # the plant's signals (no rate columns: velocities are estimated)

    def column(self, name: str) -> np.ndarray:
        """The column ``name``."""
        return self.columns[name]


def _quantise(y: np.ndarray, step: float) -> np.ndarray:
    return y[0] + (np.floor(y / step) - np.floor(y[0] / step)) * step


def noise_run(model: PlantModel, problem: ShootingProblem, index: int, seed: int = 5) -> SyntheticRun | None:
    """The model's own response to record ``index``'s input, through the measurement chain
    (None if the free run leaves the finite range)."""
    rec = problem.records[index]
    sim = Simulator(model.for_experiment(rec.experiment), dt=problem.sim_for(rec).dt, method=problem.sim.method)
    s0 = sim.true_state(sim.initial_vector(rec.positions, rec.rates, 0))
    applied = degrade_input(rec.u, model.interface.input.range, seed=seed)
    out, valid = sim.raw(rec.t, applied, s0, sim.param_vector)
    if valid < rec.t.size:
        return None
    off = sim.offset_values(sim.param_vector)
    limits = problem.limits[index]
    cols = {k: sim.reading(k, out[:, sim.signals.index(k)] + off[k], limits) for k in sim.signals.positions}
    res = problem.resolution
    cols = {k: _quantise(v, res.get(k, 1e-12)) for k, v in cols.items()}
    return SyntheticRun(t=rec.t, u=rec.u, columns=cols, source=f"noise-only run of {rec.source}",
                        experiment=rec.experiment, resolution=dict(res), signals=sim.signals)


def _mean_squares(problem: ShootingProblem) -> dict:
    """Mean squared error per output over all segments (inf if a segment diverged)."""
    total, count = {}, {}
    for rec, segs in zip(problem.records, problem.errors(np.array([]))):
        for e in segs:
            for o in rec.outputs:
                total[o] = total.get(o, 0.0) + (np.inf if e is None else float(e[o] @ e[o]))
                count[o] = count.get(o, 0) + (1 if e is None else e[o].size)
    return {o: total[o] / count[o] for o in total}


def noise_ratio(model: PlantModel, datasets: list, dt: float = 1e-4, segment: float = 0.5, outputs=None) -> dict:
    """Per output, the mean squared residual of ``model`` on the data over that on noise-only
    runs of the model itself (1 = as well explained as the measurement chain allows; inf
    when the noise-only runs cannot be made)."""
    problem = ShootingProblem(model, datasets, [], dt=dt, segment=segment, outputs=outputs)
    data_ms = _mean_squares(problem)
    runs = [noise_run(model, problem, i) for i in range(len(problem.records))]
    runs = [r for r in runs if r is not None]
    try:
        noise_ms = _mean_squares(ShootingProblem(model, runs, [], dt=dt, segment=segment, outputs=outputs,
                                                 scales=problem.scales)) if runs else {}
    except PendcError:    # the noise-only run does not move the outputs the data move
        noise_ms = {}
    out = {}
    for o, v in data_ms.items():
        n = noise_ms.get(o, 0.0)
        out[o] = float(v / n) if n > 0 and np.isfinite(v) else float("inf")
    return out
