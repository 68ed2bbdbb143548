"""The derivative filters of identification: velocities (and accelerations) from measured positions.

One cubic Savitzky-Golay filter: every simulation that starts from the data (free run,
horizon segments, diagnose, fit) takes its velocities from :func:`estimate_velocities`, so
they all start from the same state; the equation-error evidence, which needs accelerations
too, uses the same filter over a longer window (:func:`velocity_and_acceleration`).
"""

from __future__ import annotations

import numpy as np

SAVGOL_WINDOW = 0.031   # s: smooths encoder quantisation, short against the pendulum period (~1 s)
# s: the equation-error evidence differentiates twice, which amplifies the quantisation more
ACCELERATION_WINDOW = 0.051


def savgol_window(t: np.ndarray, window: float = SAVGOL_WINDOW) -> int:
    """Odd number of samples (at least 5) spanning about ``window`` seconds of ``t``."""
    h = float(np.median(np.diff(t)))
    return max(5, int(round(window / h)) | 1)


def estimate_velocities(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """dy/dt by a cubic Savitzky-Golay filter over ~31 ms (uniform sampling assumed)."""
    from scipy.signal import savgol_filter     # here: importing scipy.signal takes 1.4 s

    n = savgol_window(t)
    if len(y) < n:
        return np.gradient(y, t)
    return savgol_filter(y, n, 3, deriv=1, delta=float(np.median(np.diff(t))))


def velocity_and_acceleration(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(dy/dt, d2y/dt2) by a cubic Savitzky-Golay filter over ~51 ms (at least 7 samples)."""
    from scipy.signal import savgol_filter

    h = float(np.median(np.diff(t)))
    n = max(7, savgol_window(t, ACCELERATION_WINDOW))
    if len(y) <= n:
        return np.gradient(y, t), np.gradient(np.gradient(y, t), t)
    return savgol_filter(y, n, 3, deriv=1, delta=h), savgol_filter(y, n, 3, deriv=2, delta=h)


def velocity_error_sd(t: np.ndarray, step: float) -> np.ndarray:
    """Per sample, the standard deviation of :func:`estimate_velocities`' error on positions
    quantised to ``step`` (each reading off by a uniform error of variance step^2 / 12,
    independent from sample to sample): the filter's coefficients' norm times that error. Near
    the ends the filter fits an off-centre window, whose coefficients are larger."""
    from scipy.signal import savgol_coeffs

    n = savgol_window(t)
    sd = step / np.sqrt(12.0)
    if len(t) < n:          # np.gradient: central differences
        return np.full(len(t), sd * np.sqrt(0.5) / float(np.median(np.diff(t))))
    h = float(np.median(np.diff(t)))
    out = np.full(len(t), sd * float(np.linalg.norm(savgol_coeffs(n, 3, deriv=1, delta=h))))
    for k in range(n // 2):
        edge = sd * float(np.linalg.norm(savgol_coeffs(n, 3, deriv=1, delta=h, pos=k, use="dot")))
        out[k], out[len(t) - 1 - k] = edge, edge
    return out
