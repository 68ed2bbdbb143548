"""Semantics of LUT nodes: a function of one variable sampled on a uniform grid.

Params of a LUT node:
  ``expr``        the function as sympy text in the variable ``v`` (real units in and out)
  ``lo``, ``hi``  the domain in the input's real units; for ``periodic`` tables the
                  period is ``hi - lo`` and must be a power of two times the input LSB
  ``periodic``    address wraps around (angles in turns) instead of clamping
  ``addr_bits``   a: the table has 2**a segments
  ``interpolate`` linear interpolation between entries (2**a + 1 entries, else 2**a)
  ``table``       entries as integers in the node's output format (filled by
                  ``tabulate_luts`` once the input's format is known)

Addressing, with the input integer ``v`` in format ``fin``: the grid step is
``2**s`` input LSBs where ``s = grid_shift(...)``; ``d = v - lo_int``; the index is
``d >> s`` and the interpolation fraction ``d & (2**s - 1)``. A non-periodic input
outside the grid is clamped to the first/last entry and raises the overflow flag;
once tables are filled, ``hi`` is the last grid point, so "outside the grid" and
"outside [lo, hi]" are the same thing for the float and the fixed semantics.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .qformat import QFormat, Rounding, shift_round


@lru_cache(maxsize=256)
def lut_function(expr: str):
    """numpy-callable of the LUT's expression in ``v`` (parsed once per distinct text)."""
    import sympy as sp      # here, not above: the HDL backend reads this module without tabulating
    v = sp.Symbol("v", real=True)
    return sp.lambdify(v, sp.sympify(expr, locals={"v": v}), "numpy")


def evaluate(expr: str, values) -> np.ndarray:
    """``expr`` at ``values``; where it is not finite (an Arrhenius rate exp(-E/T) at T = 0) it
    gives inf or nan without numpy's warning: the caller decides what that means."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        out = lut_function(expr)(np.asarray(values, dtype=np.float64))
    return np.broadcast_to(np.asarray(out, dtype=np.float64), np.shape(values)).copy()


def lo_int(lo: float, fin: QFormat) -> int:
    return math.floor(math.ldexp(lo, fin.frac) + 0.5)


def grid_shift(lo: float, hi: float, addr_bits: int, fin: QFormat) -> int:
    """log2 of the grid step in input LSBs: the smallest step whose 2**a segments cover [lo, hi]."""
    span_lsb = math.ldexp(hi - lo, fin.frac)
    segments = 1 << addr_bits
    s = max(0, math.ceil(math.log2(max(span_lsb / segments, 1.0))))
    return s


def grid_points(lo: float, addr_bits: int, shift: int, fin: QFormat, interpolate: bool) -> np.ndarray:
    """Real input values at the table entries."""
    n = (1 << addr_bits) + (1 if interpolate else 0)
    base = lo_int(lo, fin)
    return np.array([math.ldexp(base + (j << shift), -fin.frac) for j in range(n)])


def fill_table(expr: str, lo: float, addr_bits: int, shift: int, fin: QFormat, fout: QFormat,
               interpolate: bool, periodic: bool) -> tuple:
    """Table entries quantised (to nearest) into ``fout``; a periodic table's last entry repeats the first."""
    xs = grid_points(lo, addr_bits, shift, fin, interpolate)
    ys = evaluate(expr, xs)
    if periodic and interpolate:
        ys[-1] = ys[0]
    return tuple(fout.from_float(float(y)) for y in ys)


def lookup(v: int, fin: QFormat, fout: QFormat, lo: float, addr_bits: int, shift: int, table: tuple,
           interpolate: bool, periodic: bool, rounding: Rounding) -> tuple[int, bool]:
    """Bit-accurate table lookup: (output integer in fout, input-out-of-domain flag)."""
    d = v - lo_int(lo, fin)
    segments = 1 << addr_bits
    idx = d >> shift
    f = d & ((1 << shift) - 1)
    outside = False
    if periodic:
        idx &= segments - 1
    elif idx < 0:
        idx, f, outside = 0, 0, True
    elif idx >= segments:
        if interpolate and idx == segments and f == 0:
            pass  # exactly the last grid point: still inside
        else:
            outside = True
        idx, f = (segments, 0) if interpolate else (segments - 1, 0)
    if not interpolate or f == 0:
        return table[idx], outside
    y0, y1 = table[idx], table[idx + 1]
    # lies between two in-range entries (rounding can reach y1 at most): no range check needed
    return y0 + shift_round((y1 - y0) * f, shift, rounding), outside
