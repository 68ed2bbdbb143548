"""Encoder geometry (spec §4) and quantisation of float trajectories to ×4 counts.

The quadrature channels switch on an absolute band grid (bands fixed to the
mechanics, the grid origin at x = 0 and theta = 0), and a ×4 decoder counts every
edge of A and B, so one count is half a band. The real encoders start counting at
power-on, so a decoded position is the initial position plus counts times resolution.
"""

from __future__ import annotations

import math

import numpy as np

FEED = 5e-3                          # m per spindle revolution (ball screw 12 x 5)
CART_LINES = 500                     # lines per spindle revolution (emulated by the drive)
PEND_LINES = 5000                    # Heidenhain ROD 420
CART_BAND = 2 * math.pi / (2 * CART_LINES)    # rad of spindle angle per band (II.49)
PEND_BAND = 2 * math.pi / (2 * PEND_LINES)    # rad of pendulum angle per band (II.50)
X_COUNT = FEED / (4 * CART_LINES)             # 2.5 um of cart travel per ×4 count
THETA_COUNT = 2 * math.pi / (4 * PEND_LINES)  # 0.314 mrad per ×4 count


def counts(value: np.ndarray, resolution: float) -> np.ndarray:
    """×4 counts on the absolute grid, relative to the first sample."""
    grid = np.floor(np.asarray(value, dtype=np.float64) / resolution)
    return (grid - grid[0]).astype(np.int64)


def quantize(value, resolution: float) -> np.ndarray:
    """A position as a ×4 decoder with counts of ``resolution`` reports it (from its first sample)."""
    value = np.asarray(value, dtype=np.float64)
    return value[0] + counts(value, resolution) * resolution


def quantize_x(x: np.ndarray) -> np.ndarray:
    """Cart position as a ×4 decoder on the drive's emulated encoder reports it (m)."""
    return quantize(x, X_COUNT)


def quantize_theta(theta: np.ndarray) -> np.ndarray:
    """Pendulum angle as a ×4 decoder on the ROD 420 reports it (rad)."""
    return quantize(theta, THETA_COUNT)
