"""Signals and file layouts shared by the reader tests (test_readers.py, test_matread.py)."""

import math

import numpy as np

from pendc.sim.readers import ReadOptions

Q_THETA = 2 * math.pi / 20000   # the SCT's encoder steps (spec section 5)
Q_X = 2.5e-6


def truth(rate=1000.0, duration=3.0):
    """Smooth, physically plausible signals: a swing, a cart motion, an input around 5 V."""
    t = np.arange(int(round(duration * rate))) / rate
    theta = 0.8 * np.sin(2 * np.pi * 0.9 * t) * np.exp(-0.2 * t)
    x = 0.1 * np.sin(2 * np.pi * 0.5 * t)
    u = 5.0 + 2.0 * np.sin(2 * np.pi * 0.5 * t)
    return t, theta, x, u


def opts(**kw):
    """ReadOptions(**kw), short."""
    return ReadOptions(**kw)


def simulink_struct(t, values, label="", block="rig/To Workspace", time=True):
    """A To Workspace 'Structure with time' (or 'Structure' with time=False) as MATLAB saves it."""
    values = np.asarray(values)
    width = 1 if values.ndim == 1 else values.shape[1]
    signals = {"values": values if values.ndim == 2 else values[:, None], "dimensions": float(width),
               "label": label, "blockName": block}
    return {"time": t[:, None] if time else np.zeros((0, 0)), "signals": signals}
