"""What a constant the advice names would do, measured before it is proposed.

When no catalogue effect explains the error, diagnose reads the unexplained acceleration's
correlations and names constants the model has (the plant file's hints: a swing's period points
at the inertia or the length). A name is a guess; :func:`try_parameters` frees each named
constant alone in a short fit of the horizon error (the fit diagnose's candidates get) and
reports how much of the error it removes and where it moves to, so the advice after a fit
(``--free I`` was done; what else sets the period: L?) comes with its evidence.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import PendcError
from ..model.plant import PlantModel
from .fit import fit_parameters

TRIAL_EVALUATIONS = 40     # a short fit: enough to see whether freeing the constant helps


@dataclass(frozen=True)
class ParameterTrial:
    """``parameter`` freed alone: its ``start`` and fitted ``value``, and ``reduction``, the share
    of the horizon cost removed (0 when the fit failed; ``message`` says why)."""

    parameter: str
    start: float
    value: float
    reduction: float
    message: str = ""

    def to_json(self) -> dict:
        return {"parameter": self.parameter, "start": self.start, "value": self.value,
                "cost_reduction": self.reduction, **({"message": self.message} if self.message else {})}

    def words(self) -> str:
        if self.message:
            return f"{self.parameter}: not tested ({self.message})"
        return (f"{self.parameter} {self.start:.5g} -> {self.value:.5g} removes {100 * self.reduction:.0f} % "
                f"of the error")


def try_parameters(model: PlantModel, datasets: list, names, dt: float = 1e-4, segment: float = 0.5,
                   outputs=None) -> list:
    """Each of ``names`` freed alone in a short horizon fit (no grid search: the constants are
    known to a few per cent); :class:`ParameterTrial` rows, most helpful first."""
    rows = []
    values = model.parameter_values()
    for name in names:
        try:
            r = fit_parameters(model, datasets, [name], dt=dt, segment=segment, max_evaluations=TRIAL_EVALUATIONS,
                               search=False, outputs=outputs)
            reduction = 1.0 - r.cost_after / r.cost_before if r.cost_before > 0 else 0.0
            rows.append(ParameterTrial(name, float(values[name]), r.values[name], max(reduction, 0.0)))
        except PendcError as exc:
            rows.append(ParameterTrial(name, float(values[name]), float(values[name]), 0.0, str(exc)))
    return sorted(rows, key=lambda row: -row.reduction)
