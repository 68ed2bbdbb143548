"""Plausibility checks on measured columns: say what looks wrong, in one line, by row.

The limits are physical, from the rig (spec §1, thesis II.56):

- the track is 750 mm long (x = ±0.375 m from its middle), so no position, wherever
  its zero is, lies ``X_LIMIT`` = 1 m from it: many rows beyond it mean millimetres or
  centimetres, a few rows an outlier;
- the drive takes 0-10 V: many rows beyond ``U_LIMIT`` = 100 V mean millivolts, a few
  rows an outlier (between 10 V and 100 V is only a warning, as a clipped amplifier
  can show);
- the pendulum turns at most about 8π ≈ 25 rad/s, so a sample that jumps away from
  both neighbours by more than ``THETA_SPIKE`` (1 rad, 40 ms at top speed) while they
  agree with each other is an outlier; angles in degrees are caught by
  :func:`check_radians`;
- a swing lasts about a second, so sampling slower than ``MIN_RATE`` (10 Hz) cannot
  record one: a median time step of 0.1 or more is taken as milliseconds (or
  microseconds) rather than seconds.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import PendcError
from .table import Table

X_LIMIT = 1.0          # m
U_LIMIT = 100.0        # V
THETA_SPIKE = 1.0      # rad
MAX_RAD_RATE = 60.0    # rad/s; the pendulum never exceeds ~8π ≈ 25 rad/s (II.56)
MIN_RATE = 10.0        # Hz
DX_LIMIT = 10.0        # m/s: the cart is clamped at 0.55 m/s
DTHETA_LIMIT = 200.0   # rad/s
UNIT_FRACTION = 0.01   # more than this fraction of rows out of range -> a unit mistake
_DEG_UNITS = {"deg", "degree", "degrees", "°"}


def check_finite(table: Table, name: str, values: np.ndarray) -> None:
    """NaN or inf in a column that is used: an error naming the first row."""
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        k = int(bad[0])
        raise PendcError(f"{table.source}: {table.where(k)}: column '{name}' is {values[k]} ({bad.size} non-finite "
                         f"value(s); NaN and inf are not allowed)")


def check_time(table: Table, t: np.ndarray, label: str = "t") -> None:
    """t strictly increasing; a lone huge time value is named as an outlier."""
    step = np.diff(t)
    bad = np.flatnonzero(step <= 0.0)
    if not bad.size:
        typical = float(np.median(step[:: max(1, len(step) // 1_000_000)])) if len(step) else 0.0
        k = int(np.argmax(step)) if len(step) else 0
        if len(step) > 2 and step[k] > max(1.0, 1000 * typical):  # one run has no hour-long hole
            raise PendcError(f"{table.source}: {table.where(k + 1)}: {label} jumps from {float(t[k])!r} to "
                             f"{float(t[k + 1])!r} ({float(step[k]) / typical:.3g} median steps): an outlier, or "
                             f"two recordings in one file")
        return
    k = int(bad[0]) + 1
    a, b = float(t[k - 1]), float(t[k])
    typical = float(np.median(np.abs(step))) or 1.0
    if k >= 2 and a - t[k - 2] > 1000 * typical and (k + 1 >= len(t) or t[k + 1] > t[k - 2]):
        raise PendcError(f"{table.source}: {table.where(k - 1)}: {label} = {a!r} is an outlier (it jumps ahead "
                         f"of its neighbours {float(t[k - 2])!r} and {b!r})")
    kind = f"duplicate time {label} = {b!r}" if a == b else f"time decreases from {a!r} to {b!r}"
    raise PendcError(f"{table.source}: {table.where(k)}: {kind}; {label} must be strictly increasing")


def check_time_unit(table: Table, t: np.ndarray, given: bool) -> None:
    """Sampling slower than MIN_RATE: the times are not in seconds."""
    if len(t) < 3:
        return
    stride = max(1, len(t) // 1_000_000)
    step = float(np.median(np.diff(t[::stride]))) / stride  # spread over the run, no full-length copy
    if step < 1.0 / MIN_RATE:
        return
    unit = "milliseconds" if step * 1e-3 < 1.0 / MIN_RATE else "microseconds"
    fix = "check --t-unit" if given else f"use --t-unit {'ms' if unit == 'milliseconds' else 'us'}"
    raise PendcError(f"{table.source}: t looks like {unit} (median step {step:g}, last t = {float(t[-1]):g}; "
                     f"sampling slower than {MIN_RATE:g} Hz cannot record a swing): {fix}")


def check_bounded(table: Table, name: str, values: np.ndarray, limit: float, unit: str, why: str,
                  fix: str) -> None:
    """Values beyond ``limit``: in a few rows an outlier (named), in many a unit mistake."""
    if float(values.max()) <= limit and float(values.min()) >= -limit:  # no full-length temporaries
        return
    out = np.abs(values) > limit
    count = int(np.count_nonzero(out))
    if count > UNIT_FRACTION * len(values):
        peak = float(np.abs(values).max())
        raise PendcError(f"{table.source}: column '{name}' looks like {fix[0]} ({count} of {len(values)} values beyond "
                         f"{limit:g} {unit}, max |{name}| = {peak:.6g}; {why}): {fix[1]}")
    k = int(np.argmax(out))
    raise PendcError(f"{table.source}: {table.where(k)}: {name} = {float(values[k]):.6g} is an outlier "
                     f"(|{name}| > {limit:g} {unit}: {why}; {count} such row(s))")


def check_spikes(table: Table, name: str, values: np.ndarray, limit: float, unit: str) -> None:
    """A sample that leaves both neighbours by more than ``limit`` while they agree: an outlier."""
    block = 1 << 20  # in blocks, so a 1e7-row file needs no full-length temporaries
    for start in range(0, max(len(values) - 2, 0), block):
        v = values[start:start + block + 2]
        with np.errstate(invalid="ignore", over="ignore"):
            before = np.abs(v[1:-1] - v[:-2])
            after = np.abs(v[1:-1] - v[2:])
            jump = np.minimum(before, after)
            spike = (jump > limit) & (np.abs(v[2:] - v[:-2]) < 0.5 * jump)
        if spike.any():
            _spike_error(table, name, values, start + int(np.argmax(spike)) + 1, limit, unit)


def _spike_error(table: Table, name: str, values: np.ndarray, k: int, limit: float, unit: str) -> None:
    raise PendcError(f"{table.source}: {table.where(k)}: {name} = {float(values[k]):.6g} is an outlier (it jumps "
                     f"more than {limit:g} {unit} away from both neighbours, "
                     f"{float(values[k - 1]):.6g} and {float(values[k + 1]):.6g})")


def unwrap_if_wrapped(theta: np.ndarray) -> tuple[np.ndarray, int]:
    """``(theta, count)``: an angle recorded modulo one turn, unwrapped, and its number of wraps.

    A jump of more than pi between samples is a wrap when it is within 0.5 rad of one
    turn (the pendulum moves at most ~25 rad/s, 0.25 rad per sample at 100 Hz);
    angles in degrees jump by 360 and are left for :func:`check_radians`.
    """
    d = np.diff(theta)
    jumps = (d > math.pi) | (d < -math.pi)
    if not jumps.any():
        return theta, 0
    if np.any(np.abs(np.abs(d[jumps]) - 2 * math.pi) > 0.5):  # a wrap is one turn, never several
        return theta, 0
    return np.unwrap(theta), int(jumps.sum())


def degrees_suspected(names: list) -> list:
    """Column names that announce degrees (theta_deg, 'theta (deg)', ...)."""
    import re

    pattern = re.compile(r"theta\W*_?\W*deg(rees?)?\W*$", re.IGNORECASE)
    return [n for n in names if pattern.match(n)]


def check_radians(table: Table, t: np.ndarray, theta: np.ndarray, given: bool) -> None:
    """Reject angles that look like degrees.

    theta is unwrapped radians from hanging-down, and the pendulum turns at most about
    8π rad/s (II.56). So a swing beyond ±2π that also moves faster than ``MAX_RAD_RATE``
    (60 rad/s) between consecutive samples, or any |theta| > 200, is taken as degrees
    (a full turn is 360, and 180°/s is already 3.1 rad/s). A ``theta_unit: deg``
    metadata entry is refused unless the unit was given (``--theta-unit``).
    """
    unit = table.meta.get("theta_unit", "").strip().lower()
    peak = max(float(theta.max()), -float(theta.min()))
    rate, block = 0.0, 1 << 20  # in blocks: no full-length temporaries on a 1e7-row file
    for start in range(0, len(t) - 1, block):
        th, tt = theta[start:start + block + 1], t[start:start + block + 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            rate = max(rate, float(np.abs(np.diff(th) / np.diff(tt)).max()))
    if unit in _DEG_UNITS and not given:
        why = f"metadata theta_unit: {unit}"
    elif peak > 200.0 or (peak > 2 * math.pi and rate > MAX_RAD_RATE):
        why = f"max |theta| = {peak:.4g}, max |dtheta/dt| = {rate:.4g} between samples"
    else:
        return
    fix = "check --theta-unit" if given else "convert the angles to radians, or give --theta-unit deg"
    raise PendcError(f"{table.source}: column 'theta' looks like degrees ({why}): {fix}")


def voltage_warning(source: str, u: np.ndarray) -> list:
    """A warning when some inputs lie outside the drive's 0-10 V."""
    outside = (u < 0.0) | (u > 10.0)
    if not outside.any():
        return []
    return [f"{source}: u outside 0-10 V in {int(outside.sum())} of {len(u)} samples "
            f"(min {u.min():g} V, max {u.max():g} V)"]
