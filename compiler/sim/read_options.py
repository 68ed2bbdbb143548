"""How to read a file: :class:`ReadOptions` (names, units, zeros, experiment, plant) and the
unit of each signal.

Every setting that concerns one signal is keyed by the signal's name as the plant interface
spells it, so the options read any plant's files; the keywords ``<signal>_unit``,
``<signal>_zero`` and ``<signal>_sign`` set them one signal at a time (a script writes
``<angle>_unit="deg"``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, fields

from ..errors import PendcError
from ..model.interface import is_dimensionless
from .signals import UNIT_SCALES, ZERO_NAMES, PlantSignals, signals_of, unit_scale

# Per-signal keywords of ReadOptions, ``<signal>_unit``, ``<signal>_zero`` and ``<signal>_sign``:
# the suffix -> (the field it fills, the value that means "as pendc has it")
SIGNAL_SETTINGS = {"unit": ("units", None), "zero": ("zero", "hanging"), "sign": ("sign", 1.0)}
SIGNAL_SETTING = re.compile(r"(\w+)_(" + "|".join(SIGNAL_SETTINGS) + r")")


@dataclass(frozen=True)
class _ReadFields:
    """The fields of :class:`ReadOptions` (which adds the per-signal keywords)."""

    columns: dict = field(default_factory=dict)
    separator: object = ...
    decimal: object = ...
    encoding: str = "utf-8"
    experiment: str | None = None
    resolution: dict = field(default_factory=dict)
    allow_missing: tuple = ()
    u_value: float = 0.0
    sample_time: float | None = None
    rate: float | None = None
    uniform: bool = False
    plausible: bool = False
    units: dict = field(default_factory=dict)
    zero: dict = field(default_factory=dict)
    sign: dict = field(default_factory=dict)
    plant: object = None


class ReadOptions(_ReadFields):
    """How to read another lab's file (every field has a ``--option`` of the same name).

    ``plant`` is the model (or its plant interface) whose signals the file holds (None:
    the default model): its interface names the columns (time, the input, each position,
    optionally their rates) and their units. ``columns`` maps such a name to the file's name;
    ``separator`` and ``decimal`` are characters (None: whitespace) or ``...`` to
    detect them. ``units`` maps a signal to its unit in the file: a name of
    :data:`~pendc.sim.signals.UNIT_SCALES` for the signal's SI unit, or a number (the SI
    value of one file unit); an absent signal is in its interface unit (s, V, m, rad...),
    and the unit checks' hints name the option to use. ``zero`` maps a periodic position
    to where the file's zero is (``upright``: half a period from the interface's zero) and
    ``sign`` to -1 when the file counts it the other way: angle = sign * file + half a
    period. The same settings are taken as keywords ``<signal>_unit``, ``<signal>_zero`` and
    ``<signal>_sign`` for any signal (e.g. ``<angle>_unit="deg"``, ``<angle>_zero="upright"``,
    ``t_unit="ms"``), as the ``--<signal>-unit`` options do.
    ``allow_missing`` axes (besides those the experiment makes irrelevant) are filled with
    zeros, the input with ``u_value``.
    ``uniform`` puts the samples on a uniform grid (at ``rate`` Hz, else see
    :func:`pendc.sim.resample.regrid`) and ``plausible`` checks the values against the
    rig's limits (:mod:`pendc.sim.plausibility`); both are off by default, so a library
    read is faithful (a simulation may drive a body off its travel), and on for the
    identification commands.
    """

    def __init__(self, **settings):
        per_signal = {"units": dict(settings.pop("units", None) or {}), "zero": dict(settings.pop("zero", None) or {}),
                      "sign": dict(settings.pop("sign", None) or {})}
        known = {f.name for f in fields(_ReadFields)}
        for key in [k for k in settings if k not in known]:
            match = SIGNAL_SETTING.fullmatch(key)
            if match is None:
                raise TypeError(f"ReadOptions got an unexpected keyword argument '{key}'")
            value = settings.pop(key)
            kind, neutral = SIGNAL_SETTINGS[match.group(2)]
            if value is not None and value != neutral:
                per_signal[kind].setdefault(match.group(1), value)
        super().__init__(**settings, **per_signal)
        self._validate()

    def _validate(self) -> None:
        """One-line errors for settings the plant cannot take (zero, sign, units, names)."""
        for name, where in self.zero.items():
            if where not in ZERO_NAMES:
                raise PendcError(f"--{name}-zero {where!r}: use {' or '.join(ZERO_NAMES)}")
        for name, sign in self.sign.items():
            if sign not in (1.0, -1.0):
                raise PendcError(f"--{name}-sign {sign!r}: use 1 or -1")
        if self.units or self.zero or self.sign or self.allow_missing or self.columns or self.resolution:
            self._check_names()

    @property
    def signals(self) -> PlantSignals:
        """The signals of the plant the file is read for (see ``plant``)."""
        return signals_of(self.plant)

    def _check_names(self) -> None:
        sig = self.signals
        known = (*sig.all_columns,)
        for option, names in (("--columns", self.columns), ("--resolution", self.resolution)):
            bad = [n for n in names if n not in known]
            if bad:
                raise PendcError(f"{option} {bad[0]}=...: '{bad[0]}' is not a signal of this plant "
                                 f"({', '.join(known)})")
        for name, unit in self.units.items():
            unit_factor(name, unit, sig)
        for kind, values in (("zero", self.zero), ("sign", self.sign)):
            bad = [n for n in values if n not in sig.periodic]
            if bad:
                raise PendcError(f"--{bad[0]}-{kind}: only a periodic position has a {kind} to set "
                                 f"({', '.join(sig.periodic) or 'this plant has none'})")
        axes = (sig.input, *sig.positions)
        bad = [a for a in self.allow_missing if a not in axes]
        if bad:
            raise PendcError(f"--missing {','.join(bad)}: only {', '.join(axes)} can be missing")


def unit_factor(axis: str, unit: str, plant=None) -> float:
    """SI value of one file unit of signal ``axis`` (of ``plant``'s signals, default the default
    model's): a unit name of its SI unit (:data:`~pendc.sim.signals.UNIT_SCALES`), or a positive
    number (e.g. the radians of one encoder count, 2*pi/20000 = 3.14159e-4, for angles logged
    in counts)."""
    sig = signals_of(plant)
    if axis not in sig.all_columns:
        raise PendcError(f"--{axis}-unit: '{axis}' is not a signal of this plant ({', '.join(sig.all_columns)})")
    si = sig.unit(axis)
    factor = unit_scale(si, unit)
    if factor is None and is_dimensionless(si):
        raise PendcError(f"--{axis}-unit {unit!r}: {axis} is dimensionless: give the size of one file unit, a "
                         "positive number (0.01 for percent)")
    if factor is None:
        names = UNIT_SCALES.get(si, {si: 1.0})
        raise PendcError(f"--{axis}-unit {unit!r}: use one of {', '.join(names)}, or the size of one file "
                         f"unit in {si} (a positive number)")
    return factor
