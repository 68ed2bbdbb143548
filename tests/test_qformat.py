"""QFormat: text form, ranges, the thesis' integer-bit rule and the one requantize rule."""

import math
import random
from fractions import Fraction

import pytest

from pendc.ir.qformat import Overflow, QFormat, Rounding, bits_for, fit, requantize, shift_round, wrap
from pendc.passes.qformats import thesis_format

Q = QFormat.parse
T, N = Rounding.TRUNCATE, Rounding.NEAREST
W, S = Overflow.WRAP, Overflow.SATURATE


# -- text form -------------------------------------------------------------------------

@pytest.mark.parametrize("text, fmt", [
    ("FIX32_26", QFormat(True, 32, 26)),
    ("UFIX1_0", QFormat(False, 1, 0)),
    ("FIX32_24", QFormat(True, 32, 24)),
    ("UFIX12_6", QFormat(False, 12, 6)),
    ("FIX8_-2", QFormat(True, 8, -2)),      # fraction bits may be negative ...
    ("FIX16_70", QFormat(True, 16, 70)),    # ... or exceed the width
    ("FIX64_50", QFormat(True, 64, 50)),
])
def test_parse_and_str_round_trip(text, fmt):
    assert QFormat.parse(text) == fmt
    assert str(fmt) == text
    assert QFormat.parse(str(fmt)) == fmt


def test_parse_is_case_and_space_tolerant():
    assert Q(" fix32_26 ") == QFormat(True, 32, 26)
    assert Q("ufix1_0") == QFormat(False, 1, 0)


@pytest.mark.parametrize("bad", ["", "Q15", "FIX32", "FIX32_", "FIX_26", "FIXa_b", "FIX32_26_1", "XFIX8_2",
                                 "UFIX", "FIX0_0", "FIX65_3", "UFIX0_0"])
def test_parse_rejects_garbage(bad):
    with pytest.raises(ValueError):
        QFormat.parse(bad)


def test_width_is_checked_on_construction():
    with pytest.raises(ValueError):
        QFormat(True, 0, 0)
    with pytest.raises(ValueError):
        QFormat(False, 65, 0)
    QFormat(True, 1, 0)
    QFormat(False, 64, 0)


# -- ranges ----------------------------------------------------------------------------

def test_signed_ranges():
    f = Q("FIX8_3")
    assert (f.min_int, f.max_int) == (-128, 127)
    assert f.int_bits == 5
    assert f.lsb == 0.125
    assert f.max_value == 15.875 and f.min_value == -16.0
    assert f.contains(127) and f.contains(-128) and not f.contains(128) and not f.contains(-129)


def test_unsigned_ranges():
    f = Q("UFIX8_3")
    assert (f.min_int, f.max_int) == (0, 255)
    assert f.max_value == 31.875 and f.min_value == 0.0
    assert not f.contains(-1) and f.contains(255) and not f.contains(256)
    flag = Q("UFIX1_0")
    assert (flag.min_int, flag.max_int, flag.lsb) == (0, 1, 1.0)


def test_negative_and_large_fraction_ranges():
    coarse = Q("FIX8_-2")                  # LSB 4
    assert coarse.lsb == 4.0 and coarse.max_value == 127 * 4 and coarse.int_bits == 10
    fine = Q("FIX16_70")
    assert fine.lsb == 2.0**-70 and fine.max_value == (2**15 - 1) * 2.0**-70


def test_32_and_64_bit_extremes():
    f32, f64 = Q("FIX32_0"), Q("FIX64_0")
    assert f32.max_int == 2**31 - 1 and f32.min_int == -2**31
    assert f64.max_int == 2**63 - 1 and f64.min_int == -2**63
    assert Q("UFIX64_0").max_int == 2**64 - 1


def test_from_float_and_to_float():
    f = Q("FIX16_8")
    assert f.from_float(1.5) == 384 and f.to_float(384) == 1.5
    assert f.from_float(1.0 + 1 / 512) == 257            # half an LSB rounds up
    assert f.from_float(-1.0 - 1 / 512) == -256          # round half up, also for negatives
    assert f.from_float(1.0 + 1 / 512, rounding=T) == 256
    assert f.from_float(-1.0 - 1 / 1024, rounding=T) == -257   # floor
    assert f.from_float(1e9) == f.max_int                 # saturates by default
    assert f.from_float(-1e9) == f.min_int
    assert f.from_float(200.0, overflow=W) == wrap(200 * 256, f)
    assert Q("UFIX8_0").from_float(-3.0) == 0


# -- the thesis' integer-bit rule ------------------------------------------------------

def test_thesis_examples():
    """Spec §5: ddx max 18.39 -> FIX32_26, ddtheta max 83.21 -> FIX32_24."""
    assert thesis_format(18.39) == Q("FIX32_26")
    assert thesis_format(83.21) == Q("FIX32_24")
    assert bits_for(18.39) == 6 and bits_for(83.21) == 8
    assert thesis_format(18.39, width=16) == Q("FIX16_10")


def test_margin_bits_add_integer_bits():
    assert thesis_format(18.39, margin_bits=1) == Q("FIX32_25")
    assert thesis_format(18.39, margin_bits=3) == Q("FIX32_23")


@pytest.mark.parametrize("k", [-8, -1, 0, 1, 4, 6, 20])
def test_exact_powers_of_two_get_one_more_bit(k):
    p = 2.0**k
    below = math.nextafter(p, 0.0)
    assert bits_for(p) == bits_for(below) + 1
    assert bits_for(p, signed=False) == bits_for(below, signed=False) + 1
    assert bits_for(p) == k + 2                     # k+1 magnitude bits and a sign
    assert bits_for(p, signed=False) == k + 1
    fmt = thesis_format(p)
    assert fmt.max_value >= p                      # the power of two itself fits ...
    assert QFormat(True, 32, fmt.frac + 1).max_value < p   # ... and only just


def test_bits_for_degenerate_inputs():
    assert bits_for(0.0) == 1 and bits_for(0.0, signed=False) == 0
    assert bits_for(float("inf")) == 1 and bits_for(float("nan")) == 1


def test_thesis_format_is_minimal_and_sufficient():
    rng = random.Random(7)
    for _ in range(2000):
        m = math.ldexp(rng.uniform(0.5, 1.0), rng.randint(-30, 30))
        fmt = thesis_format(m)
        assert fmt.width == 32 and fmt.signed
        assert fmt.max_value >= m * (1 - 2.0**-30)   # holds the maximum (to within rounding)
        assert fmt.min_value <= -m
        assert QFormat(True, 32, fmt.frac + 1).max_value < m   # one integer bit fewer would not


# -- requantize ------------------------------------------------------------------------

@pytest.mark.parametrize("v, trunc, nearest", [
    (5, 1, 1),      # 1.25
    (6, 1, 2),      # 1.5: half rounds up
    (7, 1, 2),      # 1.75
    (-5, -2, -1),   # -1.25: truncation is floor, not toward zero
    (-6, -2, -1),   # -1.5: half rounds up (toward +inf)
    (-7, -2, -2),   # -1.75
    (8, 2, 2),      # exact
])
def test_truncate_vs_nearest(v, trunc, nearest):
    fmt = Q("FIX8_0")
    assert requantize(v, 2, fmt, T, W) == (trunc, False)
    assert requantize(v, 2, fmt, N, W) == (nearest, False)


def test_left_shift_is_exact():
    assert requantize(3, 0, Q("FIX8_2"), T, W) == (12, False)
    assert requantize(-3, 1, Q("FIX16_5"), N, S) == (-48, False)
    assert shift_round(-3, -4, N) == -48
    assert requantize(1, 0, Q("FIX8_-2"), N, W) == (0, False)       # 1 in LSBs of 4: nearest is 0
    assert requantize(2, 0, Q("FIX8_-2"), N, W) == (1, False)       # 2 is half of 4: rounds up
    assert requantize(2, 0, Q("FIX8_-2"), T, W) == (0, False)


@pytest.mark.parametrize("v, wrapped, saturated", [
    (127, 127, 127), (128, -128, 127), (130, -126, 127), (255, -1, 127), (256, 0, 127),
    (-128, -128, -128), (-129, 127, -128), (-300, -44, -128),
])
def test_signed_wrap_vs_saturate(v, wrapped, saturated):
    fmt = Q("FIX8_0")
    inside = fmt.contains(v)
    assert requantize(v, 0, fmt, N, W) == (wrapped, not inside)
    assert requantize(v, 0, fmt, N, S) == (saturated, not inside)


@pytest.mark.parametrize("v, wrapped, saturated", [
    (0, 0, 0), (255, 255, 255), (256, 0, 255), (300, 44, 255), (-1, 255, 0), (-256, 0, 0),
])
def test_unsigned_wrap_vs_saturate(v, wrapped, saturated):
    fmt = Q("UFIX8_0")
    inside = fmt.contains(v)
    assert requantize(v, 0, fmt, T, W) == (wrapped, not inside)
    assert requantize(v, 0, fmt, T, S) == (saturated, not inside)


def test_rounding_can_overflow():
    fmt = Q("FIX8_0")
    assert requantize(255, 1, fmt, N, W) == (-128, True)     # 127.5 rounds to 128
    assert requantize(255, 1, fmt, N, S) == (127, True)
    assert requantize(255, 1, fmt, T, W) == (127, False)     # truncation stays inside
    assert requantize(-257, 1, fmt, T, S) == (-128, True)    # floor(-128.5) = -129


def test_one_bit_flag_format():
    flag = Q("UFIX1_0")
    assert requantize(1, 0, flag, N, W) == (1, False)
    assert requantize(2, 0, flag, N, W) == (0, True)
    assert requantize(3, 1, flag, N, S) == (1, True)    # 1.5 -> 2, saturated to 1


def test_fit_leaves_values_in_range_alone():
    for fmt in (Q("FIX8_3"), Q("UFIX4_0"), Q("FIX64_10")):
        for v in (fmt.min_int, fmt.max_int, 0):
            assert fit(v, fmt, W) == (v, False) == fit(v, fmt, S)


def _reference(v, frac, fmt, rounding, overflow):
    """requantize from first principles: exact rationals, floor, then the range rule."""
    scaled = Fraction(v) * Fraction(2) ** (fmt.frac - frac)
    r = math.floor(scaled + Fraction(1, 2)) if rounding is N else math.floor(scaled)
    if fmt.min_int <= r <= fmt.max_int:
        return r, False
    if overflow is S:
        return (fmt.max_int if r > fmt.max_int else fmt.min_int), True
    m = r % (1 << fmt.width)
    if fmt.signed and m >= 1 << (fmt.width - 1):
        m -= 1 << fmt.width
    return m, True


def test_requantize_matches_exact_arithmetic():
    rng = random.Random(2024)
    for _ in range(20000):
        fmt = QFormat(rng.random() < 0.7, rng.randint(1, 64), rng.randint(-8, 70))
        frac = rng.randint(-8, 80)
        v = rng.randint(-(1 << rng.randint(0, 70)), 1 << rng.randint(0, 70))
        for rounding in (T, N):
            for overflow in (W, S):
                got = requantize(v, frac, fmt, rounding, overflow)
                assert got == _reference(v, frac, fmt, rounding, overflow), (v, frac, fmt, rounding, overflow)
                assert fmt.contains(got[0])
