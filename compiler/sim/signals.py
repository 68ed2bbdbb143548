"""The signals of a plant as measurement files, simulations and identification see them.

Everything in :mod:`pendc.sim` and :mod:`pendc.ident` that would otherwise spell a plant's
names (which columns a measurement file has, which states are positions a sensor reads,
which state is whose rate, where each sits in the simulator's state vector, the encoder
count of each position, which positions wrap) reads it here, off the model's
:class:`~pendc.model.interface.PlantInterface`. The file columns are
``t``, the input and the positions its interface names (their rates ``d<position>``
optional).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

from ..model.interface import PlantInterface, StateSpec

TIME = "t"
# Smaller units a file may be logged in, per SI unit of a signal: name -> size in the SI unit
UNIT_SCALES = {
    "s": {"s": 1.0, "ms": 1e-3, "us": 1e-6},
    "m": {"m": 1.0, "cm": 1e-2, "mm": 1e-3},
    "V": {"V": 1.0, "mV": 1e-3},
    "rad": {"rad": 1.0, "deg": math.pi / 180},
    "m/s": {"m/s": 1.0, "mm/s": 1e-3},
    "rad/s": {"rad/s": 1.0, "deg/s": math.pi / 180},
}
# Where an angle's zero is: the interface's zero (hanging) or half a period away (upright)
ZERO_NAMES = ("hanging", "upright")


@dataclass(frozen=True)
class PlantSignals:
    """A plant's measured signals, read off its interface (see the module docstring).

    ``positions`` are the reported states that are not the rate of another state (what a
    position sensor reads); :meth:`rate` names each one's rate; ``mechanical`` are the
    reported states in the simulator's state-vector order (the initial state a run takes).
    """

    interface: PlantInterface

    @property
    def input(self) -> str:
        """The input's name (the measurement file's column and the hardware's port)."""
        return self.interface.input.name

    @property
    def mechanical(self) -> tuple:
        """Reported states, in state-vector order: the initial state of a simulation."""
        return self.interface.outputs

    @property
    def positions(self) -> tuple:
        """Reported states that are no other state's rate (what the sensors read)."""
        return tuple(s.name for s in self.interface.states if s.output and s.derivative_of is None)

    def rate(self, position: str) -> str | None:
        """The state that is the rate of ``position`` (None if the plant has none)."""
        return next((s.name for s in self.interface.states if s.derivative_of == position), None)

    @property
    def rates(self) -> tuple:
        """The rates of the positions, in the positions' order (those that have one)."""
        return tuple(r for r in (self.rate(p) for p in self.positions) if r is not None)

    @property
    def columns(self) -> tuple:
        """Columns a measurement file must have: time, the input, each position."""
        return (TIME, self.input, *self.positions)

    @property
    def all_columns(self) -> tuple:
        """Every column pendc reads by name: time, input, positions, then their rates."""
        return (*self.columns, *self.rates)

    def index(self, state: str) -> int:
        """Position of ``state`` in the simulator's state vector."""
        return [s.name for s in self.interface.states].index(state)

    def spec(self, name: str) -> StateSpec:
        """The state called ``name``."""
        return self.interface.state(name)

    def unit(self, name: str) -> str:
        """The SI unit of a column (time, the input or a state)."""
        if name == TIME:
            return "s"
        if name == self.input:
            return self.interface.input.unit
        return self.interface.state(name).unit

    def resolution(self, position: str) -> float | None:
        """One count of the sensor reading ``position`` (None if no sensor reads it)."""
        sensor = self.interface.sensor_of(position)
        return None if sensor is None else sensor.resolution

    def period(self, name: str) -> float | None:
        """The period of a periodic position, else None."""
        return self.interface.state(name).period

    @property
    def periodic(self) -> tuple:
        """Positions that wrap (angles)."""
        return tuple(p for p in self.positions if self.period(p) is not None)

    def label(self, name: str) -> str:
        """What a signal is, in words ("pendulum angle"; the input's meaning)."""
        if name == self.input:
            return self.interface.input.meaning
        return self.interface.state(name).label

    def clamped(self) -> str | None:
        """The state the model's velocity clamp holds, if any."""
        return next((s.name for s in self.interface.states if s.velocity_bound is not None), None)

    def body_of(self, name: str) -> str:
        """The body a state belongs to ("cart"); the state's own name if the interface says none."""
        return self.interface.state(name).body or name


def signals_of(plant=None) -> PlantSignals:
    """The :class:`PlantSignals` of a model, an interface, signals, or (None) the default model."""
    if isinstance(plant, PlantSignals):
        return plant
    if isinstance(plant, PlantInterface):
        return PlantSignals(plant)
    if plant is None:
        return PlantSignals(default_interface())
    return PlantSignals(plant.interface)


@lru_cache(maxsize=1)
def default_interface() -> PlantInterface:
    """The interface of the shipped default model (what a file read without a model holds)."""
    from ..model.modelfile import load_model

    return load_model().interface


def unit_scale(si_unit: str, unit) -> float | None:
    """Size of one file ``unit`` in ``si_unit``: a name of :data:`UNIT_SCALES`, or a positive
    number; None if neither."""
    names = UNIT_SCALES.get(si_unit, {si_unit: 1.0})
    if unit in names:
        return names[unit]
    try:
        factor = float(unit)
    except (TypeError, ValueError):
        return None
    return factor if factor > 0 and math.isfinite(factor) else None
