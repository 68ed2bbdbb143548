"""Put measured columns on a uniform time grid, and say how.

Identification estimates velocities with a Savitzky-Golay filter and cuts the data
into segments by sample count, both of which assume a uniform grid, and it works best
at the hardware's 1 kHz. So (:func:`regrid`):

- a uniform file (every step within ``UNIFORM_TOLERANCE`` of the median) at or below
  ``DEFAULT_MAX_RATE`` is kept as it is;
- a faster one is brought to 1 kHz (or ``--rate``) by averaging, unless the plant's fastest
  mode (:func:`pendc.model.modes.fastest_mode_hz`) needs more: then to ``MODE_SAMPLES`` samples
  a period of that mode, or the file's own rate if that is not faster. For an integer ratio
  q, blocks of q samples, each mean placed at its block's centre; otherwise the
  average over each output interval of the linearly interpolated signal. A boxcar is
  the anti-aliasing filter (first null at the output rate): unlike an FIR low-pass
  (scipy.signal.decimate/resample_poly) it cannot overshoot on the input's steps or
  the encoders' counts, and it adds no delay;
- the plant's input (``held``) is not a sample but a level held from its time stamp to the
  next, and the simulator holds the resampled one the same way: its value at grid time c is
  the mean of the original held input over [c, c + h_out], so each output interval sees the
  same drive (impulse) as the plant did. A centred mean would apply it half an output
  interval late: 10 us at 50 kHz, 12 degrees of a buck converter's 3.4 kHz mode, which cost
  its exact model 9 points of fit;
- a non-uniform file is interpolated linearly onto a grid at its median step (or
  ``--rate``), unless a gap is longer than ``max(MAX_GAP_S, MAX_GAP_STEPS median
  steps)``: across 20 ms a linear interpolation of a 10 Hz cart step response is off
  by more than 5 %, so such a file is refused with the gap named;
- a slower target rate than the file's interpolates too (upsampling adds nothing,
  and the note says so).
"""

from __future__ import annotations

import numpy as np

from ..errors import PendcError

UNIFORM_TOLERANCE = 0.01
DEFAULT_MAX_RATE = 1000.0  # Hz, the HIL core's rate
MAX_GAP_S = 0.02
MAX_GAP_STEPS = 5
# Samples a period of the plant's fastest mode that decimation keeps. The boxcar takes
# 1 - sinc(pi/N) of that mode's amplitude: an exact buck model (3.4 kHz, damping 0.09, its
# ringing most of i_L) on its own 2 MHz response, averaged to N samples a period, scored i_L
# 97.4 % at 10, 98.7 % at 15, 99.3 % at 20, 99.6 % at 30: 20 keeps an exact model above 99 % for
# twice the samples of 10 (which a fit's time follows), not three times.
MODE_SAMPLES = 20


def hertz(rate: float) -> str:
    """'10 kHz', '1 kHz', '333.3 Hz'."""
    return f"{rate / 1000:.4g} kHz" if rate >= 999.5 else f"{rate:.4g} Hz"


def median_step(steps: np.ndarray, most: int = 1_000_000) -> float:
    """The median of ``steps``, from at most ``most`` evenly spread of them (no full-length copy)."""
    stride = max(1, len(steps) // most)
    return float(np.median(steps[::stride]))


def regrid(t: np.ndarray, columns: dict, source: str, where, rate: float | None = None, fastest=None,
           held=()):
    """``(t, columns, note)`` on a uniform grid (see the module docstring); note is None
    when nothing was done. ``where(k)`` names row k in messages; ``fastest()`` is the plant's
    fastest mode in Hz (asked only of a file faster than 1 kHz); ``held`` names the columns
    that are zero-order-hold inputs."""
    if len(t) < 3:
        return t, columns, None
    steps = np.diff(t)
    h = median_step(steps)
    uniform = max(float(steps.max()) - h, h - float(steps.min())) <= UNIFORM_TOLERANCE * h
    if not uniform:
        k = int(np.argmax(steps))
        limit = max(MAX_GAP_S, MAX_GAP_STEPS * h)
        if steps[k] > limit * (1 + 1e-9):  # a gap of exactly the limit, give or take rounding, is allowed
            raise PendcError(f"{source}: {where(k + 1)}: a gap of {steps[k]:.6g} s in t (from {float(t[k])!r} to "
                             f"{float(t[k + 1])!r}, {steps[k] / h:.3g} median steps): too long to interpolate "
                             f"across (limit {limit:.3g} s = max({MAX_GAP_S:g} s, {MAX_GAP_STEPS} median steps)); "
                             f"cut the file there")
    if rate is not None:
        h_out = 1.0 / rate
    elif 1.0 / h > DEFAULT_MAX_RATE * (1 + UNIFORM_TOLERANCE):
        needed = MODE_SAMPLES * (fastest() if fastest is not None else 0.0)
        h_out = 1.0 / DEFAULT_MAX_RATE
        if needed > DEFAULT_MAX_RATE:
            h_out = max(h, 1.0 / needed)
            if uniform:                 # whole blocks of samples: no interpolation between them
                h_out = h * max(1, int(np.floor(h_out / h * (1 + 1e-9))))
            if abs(h_out - h) <= UNIFORM_TOLERANCE * h:
                return t, columns, (f"{source}: kept at {hertz(1 / h)}: the plant's fastest mode "
                                    f"({needed / MODE_SAMPLES:.4g} Hz where it starts) needs {MODE_SAMPLES} samples a "
                                    f"period (--rate decimates)")
    else:
        h_out = h
    if uniform and abs(h_out - h) <= UNIFORM_TOLERANCE * h:
        return t, columns, None
    inputs = [n for n in columns if n in held]
    held_words = f"; {', '.join(inputs)}, held from each time to the next, averaged over the interval it is held on"
    held_words = held_words if inputs else ""
    if h_out > h * (1 + UNIFORM_TOLERANCE):
        q = h_out / h
        sampled = {n: v for n, v in columns.items() if n not in held}
        if uniform and abs(q - round(q)) < 1e-6:
            new_t, new_cols = _block_means(t, sampled, int(round(q)))
            how = f"by averaging blocks of {int(round(q))} samples"
        else:
            new_t, new_cols = _interval_means(t, sampled, h_out)
            how = "by averaging the linearly interpolated signal over each output interval"
        new_cols = _with_held(t, columns, held, new_t, h_out, new_cols)
        what = "decimated" if uniform else "non-uniform sampling"
        frm = f"from {hertz(1 / h)}" if uniform else f"(median step {h:.3g} s, longest {float(steps.max()):.3g} s)"
        note = (f"{source}: {what} {frm}: resampled to a uniform {hertz(1 / h_out)} grid {how} (a boxcar "
                f"anti-aliasing filter: no overshoot on input steps or encoder counts; each mean sits at the "
                f"centre of its interval{held_words}), {len(t)} -> {len(new_t)} samples")
        return new_t, new_cols, note
    new_t = t[0] + h_out * np.arange(int(np.floor((t[-1] - t[0]) / h_out * (1 + 1e-12))) + 1)
    new_cols = {n: np.interp(new_t, t, v) for n, v in columns.items() if n not in held}
    new_cols = _with_held(t, columns, held, new_t, h_out, new_cols)
    if uniform:
        note = (f"{source}: upsampled from {hertz(1 / h)} to {hertz(1 / h_out)} by linear interpolation "
                f"(adds no information{held_words})")
    else:
        note = (f"{source}: non-uniform sampling (steps {float(steps.min()):.3g} s to {float(steps.max()):.3g} s, "
                f"median {h:.3g} s): resampled onto a uniform {hertz(1 / h_out)} grid by linear interpolation"
                f"{f' ({held_words[2:]})' if held_words else ''}, {len(t)} -> {len(new_t)} samples")
    return new_t, new_cols, note


def _block_means(t: np.ndarray, columns: dict, q: int):
    n = (len(t) // q) * q
    new_t = t[:n].reshape(-1, q).mean(axis=1)
    return new_t, {name: v[:n].reshape(-1, q).mean(axis=1) for name, v in columns.items()}


def _interval_means(t: np.ndarray, columns: dict, h_out: float):
    """Mean of each column over [c - h/2, c + h/2] for centres c, from its trapezoid integral."""
    count = int(np.floor((t[-1] - t[0]) / h_out * (1 + 1e-12)))
    edges = t[0] + h_out * np.arange(count + 1)
    centres = edges[:-1] + 0.5 * h_out
    steps = np.diff(t)
    out = {}
    for name, v in columns.items():
        offset = float(v[0])  # integrate v - v[0], so the running integral stays small
        area = np.concatenate(([0.0], np.cumsum((0.5 * (v[1:] + v[:-1]) - offset) * steps)))
        out[name] = np.diff(_integral_at(edges, t, v - offset, area)) / h_out + offset
    return centres, out


def _integral_at(points: np.ndarray, t: np.ndarray, v: np.ndarray, area: np.ndarray) -> np.ndarray:
    """The exact integral of the piecewise-linear v from t[0] to each point."""
    k = np.clip(np.searchsorted(t, points, side="right") - 1, 0, len(t) - 2)
    dt = points - t[k]
    slope = (v[k + 1] - v[k]) / (t[k + 1] - t[k])
    return area[k] + v[k] * dt + 0.5 * slope * dt * dt


def _with_held(t: np.ndarray, columns: dict, held, new_t: np.ndarray, h_out: float, resampled: dict) -> dict:
    """``resampled`` with the held columns added, in ``columns``' order."""
    return {n: _held_means(t, v, new_t, h_out) if n in held else resampled[n] for n, v in columns.items()}


def _held_means(t: np.ndarray, v: np.ndarray, starts: np.ndarray, h_out: float) -> np.ndarray:
    """Mean over [c, c + h_out], for each c in ``starts``, of v held from each t[k] to t[k + 1]
    (the last value on past t[-1], as the record's last interval has no end)."""
    offset = float(v[0])    # integrate v - v[0], so the running integral stays small
    w = v - offset
    area = np.concatenate(([0.0], np.cumsum(w[:-1] * np.diff(t))))

    def integral(points):
        k = np.clip(np.searchsorted(t, points, side="right") - 1, 0, len(t) - 1)
        return area[k] + w[k] * (points - t[k])

    return (integral(starts + h_out) - integral(starts)) / h_out + offset
