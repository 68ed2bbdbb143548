"""What a fit left uncertain, as a fitted model file stores it: the ``[fit]`` table.

``pendc fit`` writes ``[fit] free = [...]``, ``[fit.intervals]`` (each fitted value's 95 %
interval) and ``[fit.covariance]`` (``names`` and the symmetric ``matrix`` of their
covariance, in the parameters' own units: what carries the correlation between two fitted
values, which intervals alone lose). :class:`FitUncertainty` is that distribution around the
file's values; prediction bands (:mod:`pendc.ident.prediction_band`) and sweeps sample it.
A file with intervals and no covariance (written before it was stored, or by hand) gives
independent parameters whose standard deviation is a quarter of each interval's width
(a 95 % interval spans 2 x 1.96 standard deviations).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

FIT_KEYS = ("free", "intervals", "covariance")
BAND_SAMPLES = 20      # parameter draws per prediction band: its 2.5 and 97.5 % points lie between the outermost
Z95 = 1.959963984540054          # the normal distribution's 97.5 % point
SYMMETRY_TOLERANCE = 1e-9        # relative; what a printed and re-read float keeps
PSD_TOLERANCE = 1e-9             # smallest eigenvalue allowed below zero, relative to the largest


class FitTableError(ValueError):
    """A malformed ``[fit]`` table; the message names the key (the reader adds the file)."""


@dataclass(frozen=True)
class FitUncertainty:
    """A normal distribution over fitted parameters: ``names``, their ``mean`` (the model file's
    values) and ``covariance`` (square, in the parameters' units). ``source`` says where it came
    from: ``"covariance"`` or ``"intervals"`` (independent, from the 95 % intervals)."""

    names: tuple
    mean: np.ndarray
    covariance: np.ndarray
    source: str = "covariance"

    @property
    def std(self) -> np.ndarray:
        """Each parameter's standard deviation."""
        return np.sqrt(np.maximum(np.diag(self.covariance), 0.0))

    def describe(self) -> str:
        """One line: the parameters and where their spread comes from."""
        spread = ", ".join(f"{n} {m:.4g} ± {1.96 * s:.2g}" for n, m, s in zip(self.names, self.mean, self.std))
        how = "the fit's covariance" if self.source == "covariance" else \
            "the fit's 95 % intervals, taken as independent (the file stores no covariance)"
        return f"{spread} (95 %, from {how})"

    def sample(self, count: int, seed: int = 0, bounds: dict | None = None) -> np.ndarray:
        """``count`` draws (rows, one column per name), reproducible for ``seed``; a draw outside a
        parameter's ``bounds`` (name -> (lo, hi): its physical range) is clipped to them."""
        rng = np.random.default_rng(seed)
        w, v = np.linalg.eigh(self.covariance)
        root = v * np.sqrt(np.maximum(w, 0.0))           # covariance = root @ root.T, any rank
        draws = self.mean + rng.standard_normal((count, len(self.names))) @ root.T
        for j, name in enumerate(self.names):
            lo, hi = (bounds or {}).get(name, (-math.inf, math.inf))
            draws[:, j] = np.clip(draws[:, j], lo, hi)
        return draws


def check_fit_table(fit) -> None:
    """Raise :class:`FitTableError` unless ``fit`` is a well-formed ``[fit]`` table."""
    if not isinstance(fit, dict) or set(fit) - set(FIT_KEYS):
        raise FitTableError("[fit] may only hold 'free = [...]', an [fit.intervals] and an [fit.covariance] table")
    free = fit.get("free", [])
    if not isinstance(free, list) or not all(isinstance(p, str) for p in free):
        raise FitTableError("[fit] free must be a list of parameter names")
    intervals = fit.get("intervals", {})
    if not isinstance(intervals, dict):
        raise FitTableError("[fit.intervals] must be a table of [low, high] pairs")
    for name, pair in intervals.items():
        if not isinstance(pair, list) or len(pair) != 2 or not all(map(_finite, pair)) or pair[0] > pair[1]:
            raise FitTableError(f"fit.intervals.{name} must be [low, high] (finite, low <= high), got {pair!r}")
    if "covariance" in fit:
        _check_covariance(fit["covariance"])


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _check_covariance(table) -> None:
    if not isinstance(table, dict) or set(table) != {"names", "matrix"}:
        raise FitTableError("[fit.covariance] must hold exactly 'names = [...]' and 'matrix = [[...], ...]'")
    names, matrix = table["names"], table["matrix"]
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names) \
            or len(set(names)) != len(names):
        raise FitTableError("fit.covariance.names must be a non-empty list of distinct parameter names")
    n = len(names)
    if not isinstance(matrix, list) or len(matrix) != n or not all(
            isinstance(row, list) and len(row) == n and all(map(_finite, row)) for row in matrix):
        raise FitTableError(f"fit.covariance.matrix must be {n} rows of {n} finite numbers (one per name)")
    m = np.array(matrix, dtype=np.float64)
    scale = max(float(np.max(np.abs(m))), 1e-300)
    if np.max(np.abs(m - m.T)) > SYMMETRY_TOLERANCE * scale:
        raise FitTableError("fit.covariance.matrix is not symmetric")
    if np.min(np.diag(m)) < 0 or np.min(np.linalg.eigvalsh(m)) < -PSD_TOLERANCE * scale:
        raise FitTableError("fit.covariance.matrix is not a covariance (it has a negative variance or eigenvalue)")


def uncertainty_of(fit: dict, values: dict) -> FitUncertainty | None:
    """The distribution a checked ``[fit]`` table describes around ``values`` (parameter -> the
    model's value), or None when the table has neither covariance nor intervals. Raises
    :class:`FitTableError` for a name that is not one of ``values``."""
    if "covariance" in fit:
        names = tuple(fit["covariance"]["names"])
        cov = np.array(fit["covariance"]["matrix"], dtype=np.float64)
        source = "covariance"
    elif fit.get("intervals"):
        names = tuple(fit["intervals"])
        cov = np.diag([((hi - lo) / (2 * Z95)) ** 2 for lo, hi in fit["intervals"].values()])
        source = "intervals"
    else:
        return None
    unknown = [n for n in names if n not in values]
    if unknown:
        raise FitTableError(f"[fit] names {', '.join(unknown)}, not a parameter of this model")
    return FitUncertainty(names=names, mean=np.array([float(values[n]) for n in names]), covariance=cov,
                          source=source)

