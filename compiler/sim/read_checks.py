"""The checks a reader runs on a file's mapped columns (:func:`check_columns`), in the order that
gives the most telling message: time order, wrapped angles, degrees, and for a recording read for
identification a rig's limits, lone outliers in any unit and the time unit. The rules themselves
(limits, spikes, Nyquist) are :mod:`pendc.sim.plausibility`'s; this module decides which signal
each applies to, from the plant interface's units."""

from __future__ import annotations

import numpy as np

from ..model.interface import is_dimensionless, with_unit
from . import plausibility as plaus
from .read_options import ReadOptions
from .signals import TIME, UNIT_SCALES
from .table import Table


def check_columns(table: Table, columns: dict, options: ReadOptions, notes: list, fastest) -> None:
    """The checks, in the order that gives the most telling message (appends notes).

    Always: time order, wrapped angles, degrees. With ``options.plausible`` (reading a
    recording for identification) also the rig's physical limits: outliers and unit
    mistakes in the positions, the input, the rates and t; a simulation's output may leave
    the track on purpose. Each check applies to the signals whose interface unit it knows.
    ``fastest()`` gives the plant's fastest eigenvalue (asked only when the time unit is checked).
    """
    sig = options.signals
    t = columns[TIME]
    plaus.check_time(table, t)
    angles = [a for a in sig.positions if a in columns and sig.unit(a) == "rad"]   # periodic or not
    for name in [p for p in sig.periodic if p in columns]:
        # unwrap first: a wrapped angle balancing at +-pi jumps a turn and back
        unwrapped, wraps = plaus.unwrap_if_wrapped(columns[name], sig.period(name))
        if wraps:
            columns[name] = unwrapped
            notes.append(f"{table.source}: {name} was wrapped to one turn ({wraps} jumps of a whole turn between "
                         f"samples, which the {sig.body_of(name)} cannot make): unwrapped")
        if options.plausible and name in angles:
            plaus.check_spikes(table, name, columns[name], plaus.ANGLE_SPIKE, "rad")
    if options.plausible:
        _check_limits(table, columns, options)
    for name in angles:
        if name not in options.units:     # a unit given for the column is taken at its word
            plaus.check_radians(table, t, columns[name], False, name, declared_rate(sig, sig.rate(name)))
    if options.plausible and any(p in columns for p in sig.positions):  # an input alone may be sparse steps
        plaus.check_time_unit(table, t, TIME in options.units, fastest)


def _unit_hint(options: ReadOptions, name: str, suggestion: str) -> str:
    return f"check --{name}-unit" if name in options.units else f"use --{name}-unit {suggestion}"


def _check_limits(table: Table, columns: dict, options: ReadOptions) -> None:
    """The input, positions and rates within a rig's limits (by unit; a few rows beyond are
    outliers, many a unit mistake), and a lone spike in a position of any unit."""
    sig = options.signals
    spec = sig.interface.input
    if spec.name in columns:
        smaller = _smaller_units(spec.unit)
        if is_dimensionless(spec.unit):   # no unit to name: a percentage is the likely slip
            mistake = ("a percentage or another scale", _unit_hint(options, spec.name, "0.01") +
                       ("" if spec.name in options.units else " if it is in percent"))
        else:
            mistake = (_spelled(smaller[-1]) if smaller else "a unit mistake",
                       _unit_hint(options, spec.name, smaller[-1] if smaller else "..."))
        plaus.check_bounded(table, spec.name, columns[spec.name], plaus.INPUT_MARGIN * spec.full_scale, spec.unit,
                            f"the {spec.meaning.split(' (')[0]} spans {spec.range.describe()}", mistake)
    for name in [p for p in sig.positions if p in columns and sig.unit(p) in plaus.POSITION_LIMIT]:
        unit = sig.unit(name)
        limit, span = plaus.POSITION_LIMIT[unit], plaus.POSITION_SPAN[unit]
        values = columns[name]
        smaller = _smaller_units(unit)
        guess = smaller[0] if smaller else "..."
        if float(values.max()) > limit or float(values.min()) < -limit:   # then, only, look closer
            # the largest smaller unit in which the values span no more than the rig's travel
            typical = float(np.percentile(np.abs(values), 99))
            fitting = [u for u in smaller if typical * UNIT_SCALES[unit][u] <= span]
            guess = fitting[0] if fitting else smaller[-1] if smaller else guess
        plaus.check_bounded(table, name, values, limit, unit,
                            f"the {sig.label(name)} spans {with_unit(f'{span:g}', unit)} at most",
                            (_spelled(guess), _unit_hint(options, name, guess)))
    for name in [p for p in sig.positions if p in columns and p not in sig.periodic]:
        plaus.check_lone_spikes(table, name, columns[name], sig.unit(name), sig.resolution(name))
    for name in [r for r in sig.rates if r in columns and sig.unit(r) in plaus.RATE_LIMIT]:
        limit = max(plaus.RATE_LIMIT[sig.unit(name)], plaus.DECLARED_MARGIN * declared_rate(sig, name))
        plaus.check_bounded(table, name, columns[name], limit, "per s",
                            "faster than the rig can move", ("a unit mistake", "check its unit"))


def declared_rate(sig, rate: str | None) -> float:
    """How fast the plant file says rate state ``rate`` goes (its velocity bound, else its
    training rate; 0 if it says nothing): a reaction wheel's 250 rad/s is no unit mistake."""
    if rate is None:
        return 0.0
    spec = sig.spec(rate)
    return float(spec.velocity_bound or spec.training_rate or 0.0)


def _smaller_units(si_unit: str) -> list:
    """Unit names smaller than ``si_unit``, the largest first (cm before mm)."""
    scales = UNIT_SCALES.get(si_unit, {})
    return sorted((u for u, f in scales.items() if f < 1.0), key=lambda u: -scales[u])


_SPELLED = {"mm": "millimetres", "cm": "centimetres", "mV": "millivolts", "ms": "milliseconds",
            "us": "microseconds", "deg": "degrees"}


def _spelled(unit: str) -> str:
    return _SPELLED.get(unit, unit)
