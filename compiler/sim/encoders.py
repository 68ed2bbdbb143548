"""Quantisation of float trajectories to ×4 encoder counts, for any encoder a plant declares,
and to the codes of its sampled converters (ADCs: absolute, clipped to their range).

Which encoder reads which position, and how far one count moves it, is the plant
interface's (:class:`~pendc.model.sensors.SensorSpec`: ``resolution``, one count after ×4
decoding); this module only counts. The quadrature channels switch on an absolute band grid
(bands fixed to the mechanics, the grid origin at the position's zero), and a ×4 decoder
counts every edge of A and B, so one count is half a band. The real encoders start counting
at power-on, so a decoded position is the initial position plus counts times resolution.
"""

from __future__ import annotations

import numpy as np

from ..errors import PendcError
from ..model.sensors import ConverterStep, converter_code, converter_reading
from .signals import signals_of


def counts(value: np.ndarray, resolution: float) -> np.ndarray:
    """×4 counts on the absolute grid, relative to the first sample."""
    grid = np.floor(np.asarray(value, dtype=np.float64) / resolution)
    return (grid - grid[0]).astype(np.int64)


def quantize(value, resolution: float) -> np.ndarray:
    """A position as a ×4 decoder with counts of ``resolution`` reports it (from its first sample);
    with a converter's step (:class:`~pendc.model.sensors.ConverterStep`, the ``resolution`` of
    an ADC sensor) the state as the converter reads it: absolute, clipped to its range, the middle
    of its code's step (:func:`convert`)."""
    if isinstance(resolution, ConverterStep):
        return convert(value, resolution)
    value = np.asarray(value, dtype=np.float64)
    return value[0] + counts(value, resolution) * resolution


def convert(value, step: ConverterStep) -> np.ndarray:
    """``value`` as a ``step.bits``-bit converter over ``[step.lo, step.hi]`` reads it: its code
    ``clamp(floor((value - lo) * 2**bits / (hi - lo)), 0, 2**bits - 1)``, reported as the middle of
    the code's step, ``lo + (code + 1/2) * LSB`` (quantised to its LSB, clipped to its range)."""
    code = converter_code(np.asarray(value, dtype=np.float64), step.lo, step.hi, step.bits)
    return np.asarray(converter_reading(code, step.lo, step.hi, step.bits), dtype=np.float64)


def sensor_reading(sensor, values) -> np.ndarray:
    """``values`` of the state ``sensor`` (a :class:`~pendc.model.sensors.SensorSpec`) reads, as
    it reports them: an encoder's ×4 counts from the first sample, a converter's code."""
    return quantize(values, sensor.resolution)


def encoder_resolution(plant, position: str) -> float:
    """One count of the encoder that reads ``position`` on ``plant`` (a model, interface or
    signals; None: the default model); a one-line :class:`PendcError` if no encoder reads it."""
    sig = signals_of(plant)
    step = sig.resolution(position)
    if step is None:
        sensed = ", ".join(s.state for s in sig.interface.sensors) or "none"
        raise PendcError(f"no encoder of plant '{sig.interface.name}' reads '{position}' (encoders read: {sensed})")
    return step


def encoder_reading(plant, position: str, values) -> np.ndarray:
    """``values`` of ``position`` as the plant's sensor of it reports them (an encoder's ×4 counts of
    its resolution, counted from the first sample; a converter's code, :func:`convert`). ``plant``
    as for :func:`encoder_resolution`."""
    return quantize(values, encoder_resolution(plant, position))
