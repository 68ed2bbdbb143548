"""What a controller sees each control period, and the helpers every controller uses on it.

A controller is any object with ``reset()`` and ``step(measurement) -> volts``; it sees
only what the rig's controller sees, a :class:`Measurement` (time, the ×4 encoder
counts and the converters' codes, also converted to positions). An optional ``mode`` attribute (a short word)
is logged per period. Velocities come from a filtered difference of the positions
(:class:`FilteredDifference`); :func:`wrap_upright` measures an angle from the upright.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

VELOCITY_TAU = 0.004           # s, time constant of the velocity filter


@dataclass(frozen=True)
class Measurement:
    """What a controller gets each period: time, each encoder's ×4 count since reset and each
    sampled converter's (ADC's) code.

    ``counts`` are ``(encoder, count)`` pairs and ``encoders`` the encoders' descriptions
    (:class:`~pendc.hil.plants.core_ports.EncoderPorts`: the state each reads, its resolution);
    ``codes`` are ``(converter, code)`` pairs and ``adcs`` the converters' descriptions
    (:class:`~pendc.hil.plants.core_ports.AdcPorts`), all in the plant interface's order.
    :meth:`position` converts a count or a code to its state's unit; a sensor's name reads as
    its count or code and a measured state's name as its position (``meas.<state>``), so a
    controller names the plant's states as its interface does."""

    t: float
    counts: tuple
    encoders: tuple = ()
    codes: tuple = ()
    adcs: tuple = ()

    @classmethod
    def of(cls, t: float, state, ports, count_origin: dict | None = None) -> "Measurement":
        """The measurement of a plant state (:class:`~pendc.hil.plants.plant.PlantState`) at time ``t``;
        ``count_origin`` ({encoder: count}) is added to the counts since reset (encoders homed
        to their grid's zero when the plant starts elsewhere: :func:`pendc.hil.plants.plant.start_counts`)."""
        origin = count_origin or {}
        adcs = tuple(getattr(ports, "adcs", ()))
        return cls(t=t, counts=tuple((e.name, int(state.count(e.name)) + origin.get(e.name, 0))
                                     for e in ports.encoders),
                   encoders=ports.encoders, codes=tuple((a.name, int(state.code(a.name))) for a in adcs), adcs=adcs)

    def count(self, encoder: str) -> int:
        """The ×4 count since reset of the encoder called ``encoder``."""
        return dict(self.counts)[encoder]

    def code(self, adc: str) -> int:
        """The code of the converter called ``adc``."""
        return dict(self.codes)[adc]

    def position(self, state: str) -> float:
        """The measured position of ``state``: its encoder's count times the encoder's resolution,
        or what its converter's code stands for (:meth:`~pendc.hil.plants.core_ports.AdcPorts.reading`)."""
        for e in self.encoders:
            if e.state == state:
                return self.count(e.name) * e.resolution
        for a in self.adcs:
            if a.state == state:
                return a.reading(self.code(a.name))
        raise KeyError(f"no sensor reads '{state}'")

    def __getattr__(self, name: str):
        # only reached when ordinary lookup fails: a sensor's count or code, a measured state's position
        d = self.__dict__
        for e in d.get("encoders", ()):
            if e.name == name:
                return self.count(name)
            if e.state == name:
                return self.position(name)
        for a in d.get("adcs", ()):
            if a.name == name:
                return self.code(name)
            if a.state == name:
                return self.position(name)
        raise AttributeError(f"the measurement has no '{name}'")


def wrap_upright(angle: float, period: float = 2 * math.pi) -> float:
    """Angle from the upright, in (-period/2, period/2]: 0 at half a period from hanging down
    (pi, 3 pi, -pi ... for radians)."""
    half = 0.5 * period
    return half - (half - (angle - half)) % period


class FilteredDifference:
    """Velocity of a quantised position: first difference through a first-order low-pass."""

    def __init__(self, period: float, tau: float = VELOCITY_TAU):
        self.period = period
        self.gain = period / (tau + period)
        self.reset()

    def reset(self) -> None:
        """Forget the history (the next sample gives velocity 0)."""
        self.last = None
        self.value = 0.0

    def update(self, position: float) -> float:
        """Feed one sample, return the filtered velocity."""
        if self.last is not None:
            self.value += self.gain * ((position - self.last) / self.period - self.value)
        self.last = position
        return self.value
