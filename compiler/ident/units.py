"""How reports print a signal's values: in the unit its size reads best in, from the plant
interface's unit (metres as mm, radians as mrad, or rad above one radian).

Reports never ask which state a signal is, only what unit the interface gives it.
"""

from __future__ import annotations

import math

from ..model.interface import is_dimensionless, unit_name, with_unit
from ..sim.signals import signals_of

# SI unit -> (factor, unit) a small value (a residual, an error) is printed in
SMALL = {"m": (1e3, "mm"), "rad": (1e3, "mrad"), "V": (1e3, "mV")}
# SI unit -> (factor, unit) a plotted trajectory is drawn in
TRAJECTORY = {"m": (1e3, "mm"), "rad": (1.0, "rad")}


def unit_of(plant, name: str) -> str:
    """The interface unit of signal ``name`` of ``plant`` (a model, interface or signals)."""
    return signals_of(plant).unit(name)


def amount_in(unit: str, value) -> str:
    """A value of ``unit`` for a report: metres in mm, radians in mrad below 1 rad and in rad above."""
    if value is None or not math.isfinite(value):
        return "n/a"
    if unit == "rad" and abs(value) >= 1.0:
        return f"{value:.3g} rad"
    factor, shown = SMALL.get(unit, (1.0, unit))
    return with_unit(f"{value * factor:.3g}", shown)


def small_scale(unit: str) -> tuple:
    """``(factor, unit)`` for printing small values (residuals, rms errors) of ``unit``."""
    return SMALL.get(unit, (1.0, unit))


def trajectory_scale(unit: str) -> tuple:
    """``(factor, unit)`` for plotting values of ``unit``."""
    return TRAJECTORY.get(unit, (1.0, unit))


def labelled(name: str, unit: str) -> str:
    """A table's row label: ``name (unit)``, ``name`` alone for a dimensionless unit (not
    ``name (-)``)."""
    return name if is_dimensionless(unit) else f"{name} ({unit})"


def axis_label(name: str, unit: str) -> str:
    """A plot axis's label: ``name (unit)``, ``name (dimensionless)`` for no unit (not ``name (-)``)."""
    return f"{name} ({unit_name(unit)})"
