"""Parameter fitting: bounded nonlinear least squares on the multiple-shooting residual.

The optimiser works on scaled variables (each parameter divided by a typical
magnitude) so that b_x ~ 900 and tau_c ~ 0.004 are equally easy to move. Bounds are
the catalogue's physical ranges. When mu_s and mu_c are both free, mu_s is
parametrised as mu_c + d with d >= 0, so every fit satisfies mu_s >= mu_c. Confidence
intervals come from the Jacobian at the optimum (Gauss-Newton covariance scaled by
the residual variance); residual samples within a segment are correlated, so read
them as lower bounds of the true uncertainty.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, minimize_scalar

from ..errors import PendcError
from ..model.effects import CATALOGUE
from ..model.plant import PlantModel
from .shooting import ShootingProblem

PLANT_BOUNDS = (1e-9, 1e9)


@dataclass(frozen=True)
class FitResult:
    """Fitted values, 95 % intervals, costs before and after, and the model with the values set."""

    model: PlantModel
    values: dict
    ci95: dict
    cost_before: float
    cost_after: float
    n_residuals: int
    evaluations: int
    converged: bool
    message: str


def parameter_bounds(model: PlantModel, name: str) -> tuple[float, float]:
    for effect in model.effects:
        for p in CATALOGUE[effect].params:
            if p.name == name:
                return p.lo, p.hi
    return PLANT_BOUNDS


class _Transform:
    """Scaled optimiser variables <-> parameter values (with the mu_s >= mu_c substitution)."""

    def __init__(self, model: PlantModel, free: list, start: np.ndarray):
        self.free = list(free)
        self.scale = np.maximum(np.abs(start), [self._typical(model, p) for p in self.free])
        self.ordered = "mu_s" in self.free and "mu_c" in self.free
        self.i_s = self.free.index("mu_s") if self.ordered else None
        self.i_c = self.free.index("mu_c") if self.ordered else None
        lo, hi = zip(*(parameter_bounds(model, p) for p in self.free)) if self.free else ((), ())
        self.lo, self.hi = np.array(lo, float), np.array(hi, float)
        if self.ordered:
            self.lo[self.i_s], self.hi[self.i_s] = 0.0, self.hi[self.i_s]

    @staticmethod
    def _typical(model, name):
        for effect in model.effects:
            for p in CATALOGUE[effect].params:
                if p.name == name:
                    return max(abs(p.default), (p.hi - p.lo) * 1e-2, 1e-6)
        return 1e-6

    def to_z(self, values: np.ndarray) -> np.ndarray:
        v = np.array(values, float)
        if self.ordered:
            v[self.i_s] = max(v[self.i_s] - v[self.i_c], 0.0)
        return v / self.scale

    def to_values(self, z: np.ndarray) -> np.ndarray:
        v = np.asarray(z, float) * self.scale
        if self.ordered:
            v = v.copy()
            v[self.i_s] = v[self.i_s] + v[self.i_c]
        return v

    def bounds(self):
        return self.lo / self.scale, self.hi / self.scale


def grid_search(problem: ShootingProblem, tf: "_Transform", z: np.ndarray, points: int = 9) -> np.ndarray:
    """One pass of coordinate-wise grid search over each parameter's physical range.

    Delays, dead zones and limits change the cost in steps (a delay moves in whole
    integration steps), so a local optimiser started far off sees a flat or ragged
    surface; a coarse global look at each coordinate first puts it in the right basin.
    """
    lo, hi = tf.bounds()
    z = z.copy()

    def cost_at(i, g):
        trial = z.copy()
        trial[i] = g
        return problem.cost(tf.to_values(trial))

    for i in range(len(z)):
        a, b = lo[i], hi[i]
        if a >= 0 and b > 0:
            a = max(a, b * 1e-4)
            grid = np.geomspace(a, b, points) if b / a > 20 else np.linspace(a, b, points)
        else:
            grid = np.linspace(a, b, points)
        grid = np.unique(np.append(grid, z[i]))
        costs = [cost_at(i, g) for g in grid]
        k = int(np.argmin(costs))
        # refine between the neighbours of the best grid point (derivative-free: the
        # cost may be a staircase in this coordinate)
        left, right = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
        if right > left:
            res = minimize_scalar(lambda g: cost_at(i, g), bounds=(left, right), method="bounded",
                                  options={"xatol": 1e-3 * max(abs(grid[k]), 1e-9) + 1e-12, "maxiter": 30})
            z[i] = res.x if res.fun < costs[k] else grid[k]
        else:
            z[i] = grid[k]
    return z


def fit_parameters(model: PlantModel, datasets: list, free: list, start: dict | None = None,
                   dt: float = 1e-4, segment: float = 0.5, max_evaluations: int = 200,
                   search: bool = True, subset: str = "all") -> FitResult:
    """Fit ``free`` parameters of ``model`` to ``datasets`` (Measurements); others stay fixed.

    ``search`` runs a coarse grid search per parameter before the local optimiser."""
    if not free:
        raise PendcError("nothing to fit: no free parameters")
    problem = ShootingProblem(model, datasets, free, dt=dt, segment=segment, subset=subset)
    x0 = problem.start_values()
    if start:
        for i, p in enumerate(free):
            if p in start:
                x0[i] = float(start[p])
    tf = _Transform(model, free, x0)
    lo, hi = tf.bounds()
    z0 = np.clip(tf.to_z(x0), lo, hi)
    cost_before = problem.cost(tf.to_values(z0))
    if search:
        z0 = grid_search(problem, tf, z0)
    try:
        sol = least_squares(lambda z: problem.residual(tf.to_values(z)), z0, bounds=(lo, hi), method="trf",
                            diff_step=1e-2, x_scale="jac", max_nfev=max_evaluations)
    except (ValueError, FloatingPointError) as exc:
        raise PendcError(f"fit failed to run: {exc}") from None
    values = tf.to_values(sol.x)
    ci = _intervals(sol, tf, values, problem.segment_blocks())
    fitted = model.with_params(dict(zip(free, values)))
    return FitResult(model=fitted, values=dict(zip(free, map(float, values))), ci95=ci,
                     cost_before=cost_before, cost_after=float(sol.cost), n_residuals=problem.size,
                     evaluations=int(sol.nfev), converged=bool(sol.status > 0), message=str(sol.message))


def _intervals(sol, tf: _Transform, values: np.ndarray, blocks: list) -> dict:
    """95 % intervals from a cluster-robust (sandwich) covariance, one cluster per segment:
    residuals inside a segment are strongly correlated, so treating them as independent
    (plain Gauss-Newton) would make the intervals far too narrow."""
    J, r = sol.jac, sol.fun
    try:
        bread = np.linalg.pinv(J.T @ J)
    except np.linalg.LinAlgError:
        return {p: [float("-inf"), float("inf")] for p in tf.free}
    meat = np.zeros_like(bread)
    for a, b in blocks:
        g = J[a:b].T @ r[a:b]
        meat += np.outer(g, g)
    n_clusters = max(len(blocks), 2)
    cov_z = bread @ meat @ bread * n_clusters / (n_clusters - 1)
    # map the covariance of the scaled variables to the parameters (linear map)
    A = np.diag(tf.scale)
    if tf.ordered:
        A[tf.i_s, tf.i_c] = tf.scale[tf.i_c]
    cov = A @ cov_z @ A.T
    half = 1.96 * np.sqrt(np.maximum(np.diag(cov), 0.0))
    return {p: [float(v - h), float(v + h)] for p, v, h in zip(tf.free, values, half)}
