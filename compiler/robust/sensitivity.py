"""Which parameter breaks the controller: a global sensitivity ranking of a sweep's outcome.

SALib's RBD-FAST first-order indices (``SALib.analyze.rbd_fast``), which take any space-filling
sample (the sweep's Latin hypercube or Sobol points, or a fit's normal draws), not a special
Saltelli design. The outcome ranked is the failure indicator (1 failed, 0 passed): its first-order
index of a parameter is the share of the variance of failure explained by that parameter alone,
i.e. how much the chance of failing moves along it. With fewer than ``MIN_EACH`` failures (or
passes) the indicator carries too little (a handful of failures among 17 parameters ranks noise),
and the scenario's continuous criterion figure is ranked instead (the ranking says which). Imports numpy and SALib.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

MIN_RUNS = 8          # fewer finished runs give no meaningful index
MIN_EACH = 10         # failures (and passes) below which the indicator says too little: the figure is ranked


@dataclass(frozen=True)
class Ranking:
    """Parameters by first-order index, largest first: ``(name, S1, 95 % half-width)``; ``outcome``
    says what was ranked."""

    entries: tuple
    outcome: str

    @property
    def top(self) -> str | None:
        return self.entries[0][0] if self.entries else None


def rank_parameters(names: list, X: np.ndarray, failed: np.ndarray, figure: np.ndarray | None,
                    figure_name: str, seed: int = 0) -> Ranking | None:
    """The ranking of ``names`` (columns of ``X``) by the failure indicator ``failed``, or by
    ``figure`` when failure does not vary; None with too few runs or nothing varying."""
    from SALib.analyze import rbd_fast

    X = np.asarray(X, dtype=float)
    if X.shape[0] < MIN_RUNS or not names:
        return None
    failed = np.asarray(failed, dtype=bool)
    y, outcome = failed.astype(float), "failure (1 failed, 0 passed)"
    few = min(int(failed.sum()), int((~failed).sum()))
    if few < MIN_EACH:
        if figure is None and few == 0:
            return None
        if figure is not None:
            y = np.asarray(figure, dtype=float)
            keep = np.isfinite(y)
            X, y = X[keep], y[keep]
            outcome = (f"{figure_name} (every run {'failed' if failed.all() else 'passed'})" if few == 0 else
                       f"{figure_name} ({int(failed.sum())} of {failed.size} runs failed: too few to rank failure)")
        if X.shape[0] < MIN_RUNS or np.ptp(y) == 0:
            return None
    # RBD-FAST's harmonics: 10 by default, fewer for a small sweep (its bootstrap resamples half
    # the runs and needs more than 2 M of them)
    harmonics = int(max(1, min(10, (X.shape[0] - 1) // 5)))
    problem = {"num_vars": len(names), "names": list(names),
               "bounds": [[float(X[:, j].min()), float(X[:, j].max()) + 1e-300] for j in range(len(names))]}
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")      # a bootstrap resample without variance gives a NaN half-width
        try:
            result = rbd_fast.analyze(problem, X, y, M=harmonics, num_resamples=100, seed=seed)
        except (ZeroDivisionError, ValueError):    # too few distinct runs for the estimator
            return None
    s1 = np.nan_to_num(np.asarray(result["S1"], dtype=float))
    conf = np.nan_to_num(np.asarray(result["S1_conf"], dtype=float))
    order = np.argsort(-s1, kind="stable")
    return Ranking(tuple((names[j], float(s1[j]), float(conf[j])) for j in order), outcome)
