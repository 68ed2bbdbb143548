"""Parameter fitting: bounded nonlinear least squares on the multiple-shooting residual.

The optimiser works on scaled variables (each parameter divided by a typical
magnitude) so that a viscous coefficient near 900 and a friction torque near 0.004 are
equally easy to move. Bounds are the catalogue's physical ranges. An ordering the plant
file declares (``[identification] constraints``: ``parameter`` at least ``at_least``, such
as static friction at least the Coulomb level) holds whenever a fit frees both: the
parameter is parametrised as its lower one + d with d >= 0. Confidence
intervals come from the Jacobian at the optimum (Gauss-Newton covariance scaled by
the residual variance) and a cluster-robust one, whichever is wider. A parameter the
data do not excite (a direction of the Jacobian with no singular value, or an
interval as wide as the value) is reported as not identifiable, never given a value
with a falsely narrow interval.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from types import SimpleNamespace

import numpy as np

from ..errors import PendcError
from ..model.plant import PlantModel
from .shooting import ShootingProblem

# A plant constant a fit frees (``--free I,L,m``) stays within the bounds its plant file declares;
# one declared without finite bounds stays within this factor of its value (the optimiser's safety).
RIGID_SPAN = 10.0
NULL_SINGULAR = 1e-7     # singular values below this fraction of the largest span no direction
# Residuals within a segment are correlated, so the segments are the independent pieces of
# evidence; fewer than this many per parameter cannot support an interval (0.5 s of data is
# one segment: any two-parameter fit to it would be an invention).
SEGMENTS_PER_PARAMETER = 3


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
    unidentifiable: dict = None   # parameter -> why the data do not determine it (empty: all fine)
    notes: tuple = ()             # what the output weighting left out, one line each
    objective: str = "horizon"    # what was minimised: the horizon error, or the free run's
    objective_reason: str = ""    # why auto or a failed continuation kept the horizon
    horizons: tuple = ()          # the horizons (s) fitted in turn, the last the objective's
    covariance: np.ndarray | None = None   # of ``values`` (their order), the intervals' own

    def covariance_of(self, names) -> tuple:
        """``(names, matrix)``: the covariance of the fitted values among ``names`` that the data
        identify (what a fitted model file stores beside the intervals)."""
        keep = [p for p in names if p in self.values and p not in (self.unidentifiable or {})]
        if self.covariance is None or not keep:
            return (), np.zeros((0, 0))
        index = [list(self.values).index(p) for p in keep]
        return tuple(keep), self.covariance[np.ix_(index, index)]

    def refused(self) -> str:
        """One line naming the parameters the data do not determine, or '' when all are."""
        if not self.unidentifiable:
            return ""
        return "; ".join(f"{p}: {why}" for p, why in self.unidentifiable.items())


def parameter_bounds(model: PlantModel, name: str) -> tuple[float, float]:
    """Physical range of parameter ``name``: the catalogue's, the plant file's bounds of a
    constant, or within :data:`RIGID_SPAN` of a constant declared without finite bounds."""
    for effect in model.effects:
        for p in model.catalogue[effect].params:
            if p.name == name:
                return p.lo, p.hi
    if _bounded_constant(model, name):
        declared = model.definition.constants[name]
        return declared.lo, declared.hi
    value = abs(float(model.plant[name]))
    return value / RIGID_SPAN, value * RIGID_SPAN


def _bounded_constant(model: PlantModel, name: str) -> bool:
    """Whether ``name`` is a plant constant its file gives finite bounds."""
    declared = model.definition.constants.get(name)
    return declared is not None and np.isfinite(declared.lo) and np.isfinite(declared.hi)


def orderings(model: PlantModel, free: list) -> list:
    """``[(i, j), ...]``: free parameter ``free[i]`` is kept at least ``free[j]`` (the plant
    file's ``[identification] constraints`` whose two parameters are both free), lower ones
    first (a chain's substitutions then apply in order)."""
    notes = getattr(getattr(model, "definition", None), "notes", None)
    pairs = [(free.index(p), free.index(low)) for p, low, _ in getattr(notes, "constraints", ())
             if p in free and low in free]
    out = []
    while pairs:
        ready = [(i, j) for i, j in pairs if not any(k == j for k, _ in pairs)]
        if not ready:                              # a loop (the plant file's reader refuses one)
            raise PendcError("the declared parameter orderings form a loop")
        out += ready
        pairs = [q for q in pairs if q not in ready]
    return out


class _Transform:
    """Scaled optimiser variables <-> parameter values (with the declared orderings'
    substitution: a parameter kept at least another is its lower one + d, d >= 0)."""

    def __init__(self, model: PlantModel, free: list, start: np.ndarray):
        self.free = list(free)
        self.scale = np.maximum(np.abs(start), [self._typical(model, p) for p in self.free])
        self.orders = orderings(model, self.free)
        lo, hi = zip(*(parameter_bounds(model, p) for p in self.free)) if self.free else ((), ())
        self.lo, self.hi = np.array(lo, float), np.array(hi, float)
        for i, _ in self.orders:
            self.lo[i] = 0.0

    @staticmethod
    def _typical(model, name):
        for effect in model.effects:
            for p in model.catalogue[effect].params:
                if p.name == name:
                    return max(abs(p.default), (p.hi - p.lo) * 1e-2, 1e-6)
        return model.plant[name]   # a rigid-body constant: its own size

    def to_z(self, values: np.ndarray) -> np.ndarray:
        v = np.array(values, float)
        given = v.copy()
        for i, j in self.orders:
            v[i] = max(given[i] - given[j], 0.0)
        return v / self.scale

    def to_values(self, z: np.ndarray) -> np.ndarray:
        v = np.asarray(z, float) * self.scale
        if self.orders:
            v = v.copy()
            for i, j in self.orders:
                v[i] = v[i] + v[j]
        return v

    def jacobian(self) -> np.ndarray:
        """d values / d z (the map is linear): column k is :meth:`to_values` of unit vector k."""
        return np.column_stack([self.to_values(np.eye(len(self.free))[k]) for k in range(len(self.free))]) \
            if self.free else np.zeros((0, 0))

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
        if _bounded_constant(problem.model, tf.free[i]) and z[i] > 0:
            # a rigid-body constant is known to a factor of a few (it was measured or
            # computed); its physical range is for the optimiser's safety, not a search space
            a, b = max(a, z[i] / 4), min(b, z[i] * 4)
        if a >= 0 and b > 0:
            a = max(a, b * 1e-4)
            grid = np.geomspace(a, b, points) if b / a > 20 else np.linspace(a, b, points)
        else:
            grid = np.linspace(a, b, points)
        grid = np.unique(np.append(grid, z[i]))
        costs = [cost_at(i, g) for g in grid]
        best_x, best_cost = grid[int(np.argmin(costs))], min(costs)
        # refine between the neighbours of the best grid point (derivative-free: the cost may be
        # a staircase in this coordinate), and of the runner-up basin too: an unstable plant's
        # cost has a valley narrower than the grid's step (a maglev's sensor offset: 0.0014 at
        # -0.5 mm, 700 at 0, 500 at the grid's best, -2.25 mm)
        for k in _basins(costs)[:BASINS]:
            left, right = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
            if right > left:
                from scipy.optimize import minimize_scalar   # here: parameter_bounds' readers need no optimiser
                res = minimize_scalar(lambda g: cost_at(i, g), bounds=(left, right), method="bounded",
                                      options={"xatol": 1e-3 * max(abs(grid[k]), 1e-9) + 1e-12, "maxiter": 30})
                if res.fun < best_cost:
                    best_x, best_cost = res.x, res.fun
        z[i] = best_x
    return z


BASINS = 2      # grid minima refined: the best and the runner-up


def _basins(costs: list) -> list:
    """Indices of the grid's local minima (no lower neighbour), the lowest first."""
    n = len(costs)
    minima = [k for k in range(n) if (k == 0 or costs[k] <= costs[k - 1]) and (k == n - 1 or costs[k] <= costs[k + 1])]
    return sorted(minima, key=lambda k: costs[k])


OBJECTIVES = ("horizon", "free-run", "auto")
LONGER_HORIZONS = (2.0, 8.0)   # s: between the first horizon and the whole record, each fit starts from the last
WHOLE_RECORD = 1e9             # a horizon no record reaches: one simulation from the start (the free run)


def fit_parameters(model: PlantModel, datasets: list, free: list, start: dict | None = None,
                   dt: float = 1e-4, segment: float = 0.5, max_evaluations: int = 200,
                   search: bool = True, subset: str = "all", outputs=None, objective: str = "horizon") -> FitResult:
    """Fit ``free`` parameters of ``model`` to ``datasets`` (Measurements); others stay fixed.

    Each data set is simulated under its own experiment; ``outputs`` restricts the compared
    outputs. ``search`` runs a coarse grid search per parameter before the local optimiser.

    ``objective``: ``"horizon"`` minimises the error of simulations restarted every ``segment``
    seconds from the measured state (robust far from the answer); ``"free-run"`` then continues
    the fit to longer horizons (2 s, 8 s, the whole record), each from the last result, so the
    model is best over the run a HIL plant makes, not over half a second; ``"auto"`` does so
    only where the free run is reproducible on these data (the headline test of
    :mod:`pendc.ident.headline` on the horizon-fitted model), else keeps the horizon fit and
    says why in ``notes``. Intervals always come from the ``segment`` horizon's residuals at the
    final values (its segments are the independent pieces of the data)."""
    if objective not in OBJECTIVES:
        raise PendcError(f"--objective must be one of {', '.join(OBJECTIVES)}, got '{objective}'")
    first = _fit_horizon(model, datasets, free, start, dt, segment, max_evaluations, search, subset, outputs)
    if objective == "horizon" or not first.converged:
        return replace(first, horizons=(segment,))
    if objective == "auto":
        blocked = _free_run_blocked(first.model, datasets, dt, outputs)
        if blocked:
            return replace(first, horizons=(segment,), objective_reason=f"the free run is not reproducible ({blocked})")
    values, horizons, evaluations, reason = dict(first.values), [segment], first.evaluations, ""
    for horizon in [h for h in LONGER_HORIZONS if h > segment] + [WHOLE_RECORD]:
        stage = _fit_horizon(model, datasets, free, values, dt, horizon, max_evaluations, False, subset, outputs)
        evaluations += stage.evaluations
        if not stage.converged:   # keep what the shorter horizon found
            where = "the whole record" if horizon >= WHOLE_RECORD else f"the {horizon:g} s horizon"
            reason = (f"the fit on {where} did not converge in {max_evaluations} evaluations ({stage.message}); "
                      f"the {horizons[-1]:g} s horizon's values are kept")
            break
        values = dict(stage.values)
        horizons.append(horizon)
    final = _fit_horizon(model, datasets, free, values, dt, segment, 0, False, subset, outputs)  # intervals only
    return replace(final, cost_before=first.cost_before, evaluations=evaluations, converged=True,
                   message=first.message, notes=first.notes, horizons=tuple(horizons), objective_reason=reason,
                   objective="free-run" if horizons[-1] >= WHOLE_RECORD else "horizon")


def _free_run_blocked(model: PlantModel, datasets: list, dt: float, outputs) -> str:
    """Why the free run of ``model`` is not reproducible on one of ``datasets`` ('' when it is)."""
    from .compare import headline_of
    from .headline import FREE_RUN

    for data in datasets:
        head = headline_of(model, data, dt=dt, outputs=outputs)
        if head is not None and head.metric != FREE_RUN:
            return f"{data.source}: {head.reason}"
    return ""


def _fit_horizon(model, datasets, free, start, dt, segment, max_evaluations, search, subset, outputs) -> FitResult:
    """One least-squares fit of the ``segment`` horizon error (``max_evaluations=0``: none, the
    values and intervals at ``start``)."""
    if not free:
        raise PendcError("nothing to fit: no free parameters")
    problem = ShootingProblem(model, datasets, free, dt=dt, segment=segment, subset=subset, outputs=outputs)
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
    from scipy.optimize import least_squares
    try:
        with np.errstate(all="ignore"):
            sol = (least_squares(lambda z: problem.residual(tf.to_values(z)), z0, bounds=(lo, hi), method="trf",
                                 diff_step=1e-2, x_scale="jac", max_nfev=max_evaluations) if max_evaluations
                   else _at(problem, tf, z0))
    except (ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
        raise PendcError(f"fit failed to run: {exc}") from None
    values = tf.to_values(sol.x)
    ci, null, cov = _intervals(sol, tf, values, problem.segment_blocks())
    why = _unidentifiable(model, free, values, ci, null)
    segments = len(problem.segment_blocks())
    if segments < SEGMENTS_PER_PARAMETER * len(free):
        short = (f"only {segments} independent {segment:g} s segment(s) of data for {len(free)} parameter(s) "
                 f"(at least {SEGMENTS_PER_PARAMETER} per parameter are needed"
                 f"{_shorter_words(model, datasets, segment, SEGMENTS_PER_PARAMETER * len(free))})")
        why = {p: why.get(p, short) for p in free}
    fitted = model.with_params(dict(zip(free, values)))
    return FitResult(model=fitted, values=dict(zip(free, map(float, values))), ci95=ci,
                     cost_before=cost_before, cost_after=float(sol.cost), n_residuals=problem.size,
                     evaluations=int(sol.nfev), converged=bool(sol.status > 0), message=str(sol.message),
                     unidentifiable=why, notes=problem.notes, covariance=cov)


def _shorter_words(model: PlantModel, datasets: list, segment: float, need: int) -> str:
    """``; --horizon H gives N`` when a shorter horizon the plant and data allow (the automatic
    horizon's rule, :func:`pendc.ident.horizon.shorter_horizon`) gives ``need`` segments, aiming at
    the automatic horizon's eight; '' when none does (a slow plant, or data that barely move)."""
    from ..sim.signals import signals_of
    from .horizon import MIN_SEGMENTS, shorter_horizon

    if segment >= WHOLE_RECORD:
        return ""
    h, count = shorter_horizon(datasets, signals_of(model), model, segment, max(need, MIN_SEGMENTS))
    return f"; --horizon {h:g} gives {count}" if h is not None and count >= need else ""


def _at(problem: ShootingProblem, tf: "_Transform", z: np.ndarray) -> SimpleNamespace:
    """What least_squares reports, at ``z`` without a step: residual, forward-difference Jacobian
    (its step rule: 1e-2 of max(1, |z|))."""
    r = problem.residual(tf.to_values(z))
    jac = np.empty((r.size, z.size))
    for j in range(z.size):
        step = 1e-2 * max(1.0, abs(float(z[j])))
        zj = z.copy()
        zj[j] += step
        jac[:, j] = (problem.residual(tf.to_values(zj)) - r) / step
    return SimpleNamespace(x=z, fun=r, jac=jac, cost=0.5 * float(r @ r), nfev=z.size + 1, status=1,
                           message="evaluated at the given values")


BOUND_SHARE = 1e-6    # of a parameter's physical range: a fitted value this near a bound sits on it (zero excepted)
PINNED = "the data push it past its physical range"   # that reason's words (diagnose tells a pinned candidate by them)


def _unidentifiable(model: PlantModel, free: list, values: np.ndarray, ci: dict, null: set) -> dict:
    """Parameters the data do not determine, with the reason in words."""
    why = {}
    for p, v in zip(free, values):
        lo, hi = parameter_bounds(model, p)
        half = 0.5 * (ci[p][1] - ci[p][0])
        span = hi - lo if np.isfinite(hi - lo) else max(abs(v), 1.0)
        if p in null or not np.isfinite(half):
            why[p] = "the data do not excite it (the cost does not change when it moves)"
        elif v >= hi - BOUND_SHARE * span or (lo != 0 and v <= lo + BOUND_SHARE * span):
            side = "upper" if v >= hi - BOUND_SHARE * span else "lower"
            why[p] = (f"it sits at its {side} bound {hi if side == 'upper' else lo:.6g}: {PINNED} "
                      f"(an effect the model lacks, or data it cannot follow over the horizon)")
        elif lo >= 0 and half >= abs(v):
            why[p] = f"its 95 % interval [{ci[p][0]:.3g}, {ci[p][1]:.3g}] is wider than its value"
        elif lo < 0 and half > 0.1 * (hi - lo):
            why[p] = f"its 95 % interval [{ci[p][0]:.3g}, {ci[p][1]:.3g}] spans a tenth of its physical range"
    return why


def _intervals(sol, tf: _Transform, values: np.ndarray, blocks: list) -> tuple[dict, set, np.ndarray]:
    """95 % intervals, the parameters in the Jacobian's null space and the covariance of the values.

    The covariance is the wider of a cluster-robust (sandwich) one, one cluster per segment
    (residuals inside a segment are strongly correlated, so plain Gauss-Newton makes the
    intervals too narrow on long data), and the Gauss-Newton one (the sandwich degenerates
    with few segments: one segment gives a zero-width interval at any optimum). The covariance
    returned has those variances and the Gauss-Newton correlations (a valid covariance, unlike an
    element-wise maximum of two matrices)."""
    J, r = np.asarray(sol.jac, float), np.asarray(sol.fun, float)
    n, k = J.shape
    _, sv, vt = np.linalg.svd(J, full_matrices=False)
    live = sv > NULL_SINGULAR * max(float(sv[0]) if sv.size else 0.0, 1e-300)
    null = {tf.free[j] for i in np.flatnonzero(~live) for j in np.flatnonzero(np.abs(vt[i]) > 0.1)}
    inv_s2 = np.where(live, 1.0 / np.where(live, sv, 1.0) ** 2, 0.0)
    bread = (vt.T * inv_s2) @ vt                        # pseudo-inverse of J^T J on the live directions
    meat = np.zeros((k, k))
    for a, b in blocks:
        g = J[a:b].T @ r[a:b]
        meat += np.outer(g, g)
    n_clusters = max(len(blocks), 2)
    cov_sandwich = bread @ meat @ bread * n_clusters / (n_clusters - 1)
    cov_gn = bread * float(r @ r) / max(n - k, 1)
    # map the covariance of the scaled variables to the parameters (linear map)
    A = tf.jacobian()
    gn = A @ cov_gn @ A.T
    var = np.maximum(np.maximum(np.diag(A @ cov_sandwich @ A.T), np.diag(gn)), 0.0)
    half = 1.96 * np.sqrt(var)
    gn_sd = np.sqrt(np.maximum(np.diag(gn), 0.0))
    corr = np.divide(gn, np.outer(gn_sd, gn_sd), out=np.zeros_like(gn), where=np.outer(gn_sd, gn_sd) > 0)
    np.fill_diagonal(corr, 1.0)
    cov = np.clip(corr, -1.0, 1.0) * np.outer(np.sqrt(var), np.sqrt(var))
    ci = {}
    for p, v, h in zip(tf.free, values, half):
        ci[p] = [float("-inf"), float("inf")] if p in null else [float(v - h), float(v + h)]
    return ci, null, cov
