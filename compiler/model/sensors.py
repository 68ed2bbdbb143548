"""Sensors of a plant: quadrature encoders and sampled converters (ADCs), and the converter code rule.

Part of the plant interface (:mod:`pendc.model.interface`): which state each sensor reads, its
resolution and the hardware ports it drives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


ENCODER = "quadrature_encoder"
ADC = "adc"
SENSOR_KINDS = (ENCODER, ADC)
MAX_ADC_BITS = 24          # the widest sampled converter a plant file may declare


class ConverterStep(float):
    """One LSB of a sampled converter (a float, what every user of a sensor's resolution takes),
    which also knows the converter's range and bits, so a reader given only "the resolution"
    (:func:`pendc.sim.encoders.quantize`) reads the state as the converter does: absolute,
    clipped to the range, not counted from the first sample as an encoder is."""

    lo: float
    hi: float
    bits: int

    def __new__(cls, lo: float, hi: float, bits: int):
        step = super().__new__(cls, (hi - lo) / (1 << bits))
        step.lo, step.hi, step.bits = float(lo), float(hi), int(bits)
        return step

    def __reduce__(self):
        return (ConverterStep, (self.lo, self.hi, self.bits))


def converter_code(value, lo: float, hi: float, bits: int):
    """The code of a ``bits``-bit converter over ``[lo, hi]`` reading ``value`` (scalar or array):
    ``clamp(floor((value - lo) * 2**bits / (hi - lo)), 0, 2**bits - 1)``."""
    import numpy as np

    v = np.asarray(value, dtype=np.float64)
    code = np.floor((v - lo) * float(1 << bits) / (hi - lo))
    code = np.clip(code, 0, (1 << bits) - 1).astype(np.int64)
    return code if code.ndim else int(code)


def converter_reading(code, lo: float, hi: float, bits: int):
    """The state a converter's ``code`` stands for: the middle of its step,
    ``lo + (code + 1/2) * (hi - lo) / 2**bits``."""
    import numpy as np

    c = np.asarray(code, dtype=np.float64)
    out = lo + (c + 0.5) * ((hi - lo) / (1 << bits))
    return out if out.ndim else float(out)


@dataclass(frozen=True)
class SensorSpec:
    """A sensor reading state ``state``: a quadrature encoder (``kind`` ``"quadrature_encoder"``,
    the default) or a sampled converter (``kind`` ``"adc"``).

    An encoder: ``band`` is the motion (in the state's unit) of one light or dark band of the
    disk; ``lines`` and ``bands_per_rev`` are the disk's, for the record. ×4 quadrature
    decoding of the two channels gives two counts per band, so :attr:`resolution` is
    ``band / 2``. The hardware emits the two channel levels (:attr:`channels`).

    A converter (ADC): ``bits`` and the range ``lo`` .. ``hi`` (the state's unit) it spans; its
    code is ``clamp(floor((s - lo) * 2**bits / (hi - lo)), 0, 2**bits - 1)``
    (:meth:`code`), :attr:`resolution` one LSB ``(hi - lo) / 2**bits``. The hardware emits the
    code on one port (:attr:`code_port`).
    """

    # the plant file's SensorDecl (pendc.model.definition) with the body the state moves: the
    # declaration stays what the file says, this is what the compiler and the testbench use
    name: str
    state: str
    body: str
    band: float = 0.0
    lines: int = 0
    bands_per_rev: int = 0
    kind: str = ENCODER
    bits: int = 0
    lo: float = 0.0
    hi: float = 0.0

    def __post_init__(self):
        if self.kind not in SENSOR_KINDS:
            raise ValueError(f"sensor '{self.name}': unknown kind '{self.kind}' (known: {', '.join(SENSOR_KINDS)})")
        if self.is_adc:
            if not (isinstance(self.bits, int) and 1 <= self.bits <= MAX_ADC_BITS):
                raise ValueError(f"sensor '{self.name}': bits must be 1..{MAX_ADC_BITS}, got {self.bits!r}")
            if not (math.isfinite(self.lo) and math.isfinite(self.hi) and self.lo < self.hi):
                raise ValueError(f"sensor '{self.name}': range must be finite with low < high, "
                                 f"got [{self.lo!r}, {self.hi!r}]")
        elif not (math.isfinite(self.band) and self.band > 0):
            raise ValueError(f"sensor '{self.name}': band must be positive, got {self.band!r}")

    @property
    def is_adc(self) -> bool:
        """Whether this is a sampled converter (else a quadrature encoder)."""
        return self.kind == ADC

    @property
    def resolution(self) -> float:
        """Motion of one count after ×4 decoding (an encoder), or one LSB of the converter (a
        :class:`ConverterStep`, which also carries its range); state units."""
        if self.is_adc:
            return ConverterStep(self.lo, self.hi, self.bits)
        return self.band / 2.0

    @property
    def counts_per_unit(self) -> float:
        """Counts per unit of the state after ×4 decoding (an encoder); codes per unit (a converter)."""
        if self.is_adc:
            return (1 << self.bits) / (self.hi - self.lo)
        return 2.0 / self.band

    @property
    def codes(self) -> int:
        """How many codes the converter has (``2**bits``); 0 for an encoder."""
        return (1 << self.bits) if self.is_adc else 0

    @property
    def channels(self) -> tuple:
        """Names of the channel-level outputs of the hardware (A leads when the state grows);
        none for a converter."""
        return () if self.is_adc else (f"{self.name}_a", f"{self.name}_b")

    @property
    def code_port(self) -> str | None:
        """The hardware's output port of a converter's code (``NAME_code``); None for an encoder."""
        return f"{self.name}_code" if self.is_adc else None

    @property
    def ports(self) -> tuple:
        """Every output port of the hardware for this sensor: the channels, or the code port."""
        return (self.code_port,) if self.is_adc else self.channels

    def code(self, value):
        """The converter's code for state ``value`` (scalar or array), by the rule above."""
        return converter_code(value, self.lo, self.hi, self.bits)

    def reading(self, code):
        """The state a code stands for: the middle of its step (scalar or array)."""
        return converter_reading(code, self.lo, self.hi, self.bits)

    def describe(self) -> str:
        """One line: ``enc_x: x, 1000 lines, 20000 counts per unit`` or
        ``adc_x: x, 12-bit converter over [-0.2, 0.2], 10240 codes per unit``."""
        if self.is_adc:
            return (f"{self.name}: {self.state}, {self.bits}-bit converter over [{self.lo:g}, {self.hi:g}], "
                    f"{self.counts_per_unit:g} codes per unit")
        return f"{self.name}: {self.state}, {self.lines} lines, {self.counts_per_unit:g} counts per unit"
