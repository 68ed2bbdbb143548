"""Fixed-point number formats and the exact integer arithmetic every consumer shares.

A value with format ``QFormat(signed, width, frac)`` is an integer ``v`` standing for
``v * 2**-frac``. The thesis writes ``FIX32_26`` for signed, 32 bits, 26 fraction bits
and ``UFIX1_0`` for a one-bit flag. :func:`requantize` is *the* definition of rounding
and overflow: the bit-accurate interpreter, the compiled golden model and the Verilog
backend all implement exactly this function.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum


class Rounding(Enum):
    """How dropped fraction bits are treated when a value narrows its fraction."""

    TRUNCATE = "trunc"   # floor (arithmetic shift right): cheapest, biased by -LSB/2
    NEAREST = "round"    # add half an LSB, then floor: round half up, unbiased on average


class Overflow(Enum):
    """What happens when a value leaves its format's range (the sticky flag is set either way)."""

    WRAP = "wrap"        # keep the low bits (two's complement wrap-around)
    SATURATE = "sat"     # clamp to the largest/smallest representable value


@dataclass(frozen=True, order=True)
class QFormat:
    """Signedness, total width in bits and number of fraction bits (may exceed width or be negative)."""

    signed: bool
    width: int
    frac: int

    def __post_init__(self):
        if not 1 <= self.width <= 64:
            raise ValueError(f"width must be 1..64 bits, got {self.width}")

    @property
    def int_bits(self) -> int:
        """Integer bits, sign bit included for signed formats."""
        return self.width - self.frac

    @property
    def lsb(self) -> float:
        return math.ldexp(1.0, -self.frac)

    @property
    def min_int(self) -> int:
        return -(1 << (self.width - 1)) if self.signed else 0

    @property
    def max_int(self) -> int:
        return (1 << (self.width - 1)) - 1 if self.signed else (1 << self.width) - 1

    @property
    def max_value(self) -> float:
        return math.ldexp(self.max_int, -self.frac)

    @property
    def min_value(self) -> float:
        return math.ldexp(self.min_int, -self.frac)

    def __str__(self) -> str:
        return f"{'FIX' if self.signed else 'UFIX'}{self.width}_{self.frac}"

    @classmethod
    def parse(cls, text: str) -> "QFormat":
        """Inverse of ``str``: ``FIX32_26`` or ``UFIX1_0``."""
        t = text.strip().upper()
        signed = not t.startswith("UFIX")
        body = t[4:] if not signed else t[3:] if t.startswith("FIX") else None
        try:
            width, frac = (int(p) for p in body.split("_"))
            return cls(signed, width, frac)
        except (AttributeError, ValueError):
            raise ValueError(f"not a Q-format: {text!r} (expected e.g. FIX32_26 or UFIX1_0)") from None

    def contains(self, v: int) -> bool:
        return self.min_int <= v <= self.max_int

    def from_float(self, value: float, rounding: Rounding = Rounding.NEAREST,
                   overflow: Overflow = Overflow.SATURATE) -> int:
        """Quantise a real number into this format (used for constants, inputs and tables)."""
        scaled = math.ldexp(value, self.frac)
        v = math.floor(scaled + 0.5) if rounding is Rounding.NEAREST else math.floor(scaled)
        return fit(v, self, overflow)[0]

    def to_float(self, v: int) -> float:
        return math.ldexp(v, -self.frac)


def wrap(v: int, fmt: QFormat) -> int:
    """Two's-complement (or modulo for unsigned) wrap of ``v`` into ``fmt.width`` bits."""
    mask = (1 << fmt.width) - 1
    v &= mask
    if fmt.signed and v >> (fmt.width - 1):
        v -= 1 << fmt.width
    return v


def fit(v: int, fmt: QFormat, overflow: Overflow) -> tuple[int, bool]:
    """Bring an integer already at ``fmt.frac`` into range; returns (value, overflowed)."""
    if fmt.min_int <= v <= fmt.max_int:
        return v, False
    if overflow is Overflow.SATURATE:
        return (fmt.max_int if v > fmt.max_int else fmt.min_int), True
    return wrap(v, fmt), True


def shift_round(v: int, shift: int, rounding: Rounding) -> int:
    """``v * 2**-shift`` as an integer: exact for shift <= 0, rounded per ``rounding`` otherwise."""
    if shift <= 0:
        return v << -shift
    if rounding is Rounding.NEAREST:
        v += 1 << (shift - 1)
    return v >> shift


def requantize(v: int, frac: int, fmt: QFormat, rounding: Rounding, overflow: Overflow) -> tuple[int, bool]:
    """Re-express ``v * 2**-frac`` in ``fmt``: align the fraction, round, then fit the range."""
    return fit(shift_round(v, frac - fmt.frac, rounding), fmt, overflow)


def bits_for(max_abs: float, signed: bool = True) -> int:
    """Integer bits that hold ``max_abs`` by the thesis' rule i = ceil(log2(max|v|)), +1 if signed.

    An exact power of two needs one bit more than the ceil gives, so that value itself fits.
    """
    if max_abs <= 0 or not math.isfinite(max_abs):
        return 1 if signed else 0
    i = math.ceil(math.log2(max_abs))
    if math.ldexp(1.0, i) <= max_abs:
        i += 1
    return i + (1 if signed else 0)
