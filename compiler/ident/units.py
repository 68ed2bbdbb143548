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
    """A value of ``unit`` for a report: metres in mm, radians in mrad, volts in mV below one
    of the unit, and in the unit itself from one on (1.77 V, not 1.77e+03 mV)."""
    if value is None or not math.isfinite(value):
        return "n/a"
    factor, shown = small_scale(unit, value)
    return with_unit(f"{value * factor:.3g}", shown)


def small_scale(unit: str, largest=None) -> tuple:
    """``(factor, unit)`` for printing small values (residuals, rms errors) of ``unit``: the
    small unit (mm, mrad, mV) unless ``largest``, the largest value to print, is one of the unit
    or more."""
    if largest is not None and math.isfinite(largest) and abs(largest) >= 1.0:
        return 1.0, unit
    return SMALL.get(unit, (1.0, unit))


def table_digits(values, unit: str) -> int:
    """Decimals a table row of ``values`` in ``unit`` is printed with: none for whole turns, two
    for percentages and values of one or more, else as many as three significant digits of the
    largest need (a duty cycle's rms error of 0.0031 is 0.00310, not 0.00)."""
    if unit == "turns":
        return 0
    sizes = [abs(v) for v in values if v is not None and math.isfinite(v) and v != 0]
    if unit == "%" or not sizes:
        return 2
    return min(8, max(2, 2 - math.floor(math.log10(max(sizes)))))


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
