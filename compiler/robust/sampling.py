"""Which plants a sweep runs: a sample plan over the parameters a model leaves uncertain.

A :class:`SamplePlan` is pure data (names, ranges, the fit's distribution, method, seed, count);
its rows are a function of the plan alone, so every worker, the resume and the replay of one run
see the same parameters. The design is a Latin hypercube or a scrambled Sobol sequence in the unit
cube; a dimension given as a range (``--vary NAME=LO:HI`` or the default ranges) maps uniformly onto
it, the dimensions of a fit's normal distribution map through the normal quantile and the
covariance's square root (correlations kept), and every value is clipped to the parameter's
physical bounds. Imports numpy, scipy and pendc's model and fit modules.
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import PendcError

METHODS = ("lhs", "sobol")
CONSTANT_SPAN = 0.05     # default: a plant constant (a mass, a length) known to +-5 %
EFFECT_SPAN = 0.20       # default: an effect's parameter (friction, drive gain) known to +-20 %
_EDGE = 1e-12            # keeps the normal quantile finite at a design point on the cube's face


@dataclass(frozen=True)
class SamplePlan:
    """``count`` plants around ``nominal``: ``ranges`` (name, lo, hi) drawn uniformly, the
    ``fit_names`` drawn from N(``fit_mean``, ``fit_covariance``), each clipped to ``bounds``."""

    nominal: dict
    ranges: tuple = ()
    fit_names: tuple = ()
    fit_mean: tuple = ()
    fit_covariance: tuple = ()
    bounds: dict = field(default_factory=dict)
    method: str = "lhs"
    seed: int = 0
    count: int = 100
    origin: str = ""

    @property
    def names(self) -> tuple:
        """The varied parameters, in column order: the ranges', then the fit's."""
        return tuple(n for n, _, _ in self.ranges) + tuple(self.fit_names)

    def unit_design(self) -> np.ndarray:
        """``count`` x dimensions points in [0, 1), the same for the same plan."""
        d = len(self.names)
        if self.method == "sobol":
            from scipy.stats import qmc
            with warnings.catch_warnings():   # a count that is not a power of two loses balance, not validity
                warnings.simplefilter("ignore")
                return qmc.Sobol(d, scramble=True, seed=self.seed).random(self.count)
        from scipy.stats import qmc
        return qmc.LatinHypercube(d, seed=self.seed).random(self.count)

    def design(self) -> np.ndarray:
        """The parameter values of every run: ``count`` rows, one column per :attr:`names`."""
        unit = self.unit_design()
        k = len(self.ranges)
        out = np.empty_like(unit)
        for j, (_, lo, hi) in enumerate(self.ranges):
            out[:, j] = lo + unit[:, j] * (hi - lo)
        if self.fit_names:
            from scipy.stats import norm
            cov = np.asarray(self.fit_covariance, dtype=float)
            w, v = np.linalg.eigh(cov)
            root = v * np.sqrt(np.maximum(w, 0.0))
            z = norm.ppf(np.clip(unit[:, k:], _EDGE, 1 - _EDGE))
            out[:, k:] = np.asarray(self.fit_mean) + z @ root.T
        for j, name in enumerate(self.names):
            lo, hi = self.bounds.get(name, (-math.inf, math.inf))
            out[:, j] = np.clip(out[:, j], lo, hi)
        return out

    def params_of(self, index: int, design: np.ndarray | None = None) -> dict:
        """{name: value} of run ``index`` (0-based)."""
        if not 0 <= index < self.count:
            raise PendcError(f"run {index} is not in this sweep (runs 0..{self.count - 1})")
        row = (self.design() if design is None else design)[index]
        return {n: float(v) for n, v in zip(self.names, row)}

    def without(self, names: set, note: str) -> "SamplePlan":
        """The plan with the ranges of ``names`` dropped (held at their nominal values), ``note`` added
        to its origin."""
        from dataclasses import replace
        keep = tuple(r for r in self.ranges if r[0] not in names)
        kept = {r[0] for r in keep} | set(self.fit_names)
        return replace(self, ranges=keep, nominal={k: v for k, v in self.nominal.items() if k in kept},
                       bounds={k: v for k, v in self.bounds.items() if k in kept}, origin=f"{self.origin}; {note}")

    def describe(self) -> list:
        """One line per varied parameter: its nominal value and how it is drawn."""
        lines = [f"{n} {self.nominal[n]:.6g}: uniform on [{lo:.6g}, {hi:.6g}]" for n, lo, hi in self.ranges]
        std = np.sqrt(np.maximum(np.diag(np.asarray(self.fit_covariance, dtype=float)), 0.0)) if self.fit_names else []
        lines += [f"{n} {m:.6g}: normal, 95 % +-{1.96 * s:.3g} (the fit's covariance)"
                  for n, m, s in zip(self.fit_names, self.fit_mean, std)]
        return lines


def parse_vary(text: str) -> tuple:
    """``NAME=LO:HI`` -> (name, lo, hi); a malformed one is a one-line error."""
    m = re.fullmatch(r"\s*([A-Za-z_]\w*)\s*=\s*([^:]+):(.+)", text)
    if not m:
        raise PendcError(f"--vary {text!r}: expected NAME=LO:HI (e.g. alpha=240:280)")
    try:
        lo, hi = float(m.group(2)), float(m.group(3))
    except ValueError:
        raise PendcError(f"--vary {text!r}: LO and HI must be numbers") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise PendcError(f"--vary {text!r}: needs finite LO < HI")
    return m.group(1), lo, hi


def default_ranges(model) -> tuple:
    """What a model without a fit leaves uncertain, by the documented rule: each plant constant
    +-5 % and each effect parameter +-20 %, within its physical bounds; a parameter at 0 (a
    switch, an exact test) and one whose bounds leave no room stay fixed."""
    from ..ident.fit import parameter_bounds

    constants = set(model.definition.constants)
    out = []
    for name, value in model.parameter_values().items():
        if value == 0.0:
            continue
        span = CONSTANT_SPAN if name in constants else EFFECT_SPAN
        lo_b, hi_b = parameter_bounds(model, name)
        lo, hi = sorted((value * (1 - span), value * (1 + span)))
        lo, hi = max(lo, lo_b), min(hi, hi_b)
        if lo < hi:
            out.append((name, lo, hi))
    return tuple(out)


def plan_for(model, uncertainty, vary: list, method: str, seed: int, count: int) -> SamplePlan:
    """The plan of a sweep on ``model``: ``vary`` ranges (name, lo, hi) first; the fit's
    distribution ``uncertainty`` (a :class:`~pendc.model.fit_uncertainty.FitUncertainty` or
    None) for its other parameters; the default ranges when neither gives anything."""
    from ..ident.fit import parameter_bounds

    if method not in METHODS:
        raise PendcError(f"unknown sampling method {method!r} (choose {', '.join(METHODS)})")
    if count < 1:
        raise PendcError(f"--samples must be at least 1, got {count}")
    values = model.parameter_values()
    seen = set()
    for name, _, _ in vary:
        if name not in values:
            raise PendcError(f"--vary {name}: not a parameter of the model (it has {', '.join(values)})")
        if name in seen:
            raise PendcError(f"--vary {name}: given twice")
        seen.add(name)
    ranges = tuple(vary)
    fit_names, mean, cov, origin = (), (), (), "--vary ranges"
    if uncertainty is not None:
        keep = [i for i, n in enumerate(uncertainty.names) if n not in seen]
        fit_names = tuple(uncertainty.names[i] for i in keep)
        mean = tuple(float(uncertainty.mean[i]) for i in keep)
        cov = tuple(tuple(float(uncertainty.covariance[i, j]) for j in keep) for i in keep)
        origin = f"the fit's {uncertainty.source}" + (" and --vary ranges" if vary else "")
    if not ranges and not fit_names:
        ranges = default_ranges(model)
        origin = (f"default ranges (no [fit] intervals or covariance in the file, no --vary): each plant "
                  f"constant +-{CONSTANT_SPAN:.0%}, each effect parameter +-{EFFECT_SPAN:.0%}, within its bounds")
    if not ranges and not fit_names:
        raise PendcError("nothing to vary: the model file holds no fit's intervals or covariance and every "
                         "parameter is fixed; give --vary NAME=LO:HI")
    names = [n for n, _, _ in ranges] + list(fit_names)
    bounds = {n: tuple(float(b) for b in parameter_bounds(model, n)) for n in names}
    return SamplePlan(nominal={n: float(values[n]) for n in names}, ranges=ranges, fit_names=fit_names,
                      fit_mean=mean, fit_covariance=cov, bounds=bounds, method=method, seed=int(seed),
                      count=int(count), origin=origin)


def plan_to_dict(plan: SamplePlan) -> dict:
    """The plan as JSON-able data (the sweep's manifest), read back by :func:`plan_from_dict`."""
    return {"nominal": plan.nominal, "ranges": [list(r) for r in plan.ranges], "fit_names": list(plan.fit_names),
            "fit_mean": list(plan.fit_mean), "fit_covariance": [list(r) for r in plan.fit_covariance],
            "bounds": {k: list(v) for k, v in plan.bounds.items()}, "method": plan.method, "seed": plan.seed,
            "count": plan.count, "origin": plan.origin}


def plan_from_dict(data: dict) -> SamplePlan:
    """The plan :func:`plan_to_dict` wrote."""
    return SamplePlan(nominal=dict(data["nominal"]), ranges=tuple(tuple(r) for r in data["ranges"]),
                      fit_names=tuple(data["fit_names"]), fit_mean=tuple(data["fit_mean"]),
                      fit_covariance=tuple(tuple(r) for r in data["fit_covariance"]),
                      bounds={k: tuple(v) for k, v in data["bounds"].items()}, method=data["method"],
                      seed=int(data["seed"]), count=int(data["count"]), origin=data.get("origin", ""))
