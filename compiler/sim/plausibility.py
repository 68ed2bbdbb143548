"""Plausibility checks on measured columns: say what looks wrong, in one line, by row.

The checks are per signal, by its unit as the plant interface gives it; the limits are
those of any laboratory rig, not of one plant (the figures below that justify them are a
typical bench rig's: a 750 mm track, a 0-10 V drive, an angle encoder designed for 8π rad/s):

- a position in metres lies within ``POSITION_LIMIT`` of its zero (a 750 mm track is
  ±0.375 m from its middle, so 1 m is generous), its plausible span ``POSITION_SPAN``:
  many rows beyond the limit mean a smaller unit (the one in which the values span no
  more than the span: centimetres or millimetres), a few rows an outlier;
- an input lies within ``INPUT_MARGIN`` times its full scale (the plant interface's; 100 V
  for a 10 V input): many rows beyond mean a smaller unit (millivolts), a few rows an
  outlier (outside the range the actuator takes, the interface's, is only a warning, as a
  clipped amplifier can show);
- rates stay below ``RATE_LIMIT`` of their unit, or twice what the plant file declares of them
  (a velocity bound or training rate: a reaction wheel's 250 rad/s);
- an angle (a periodic position in radians) turns at most about 8π ≈ 25 rad/s on a bench
  rig, so a sample that jumps away from both neighbours by more than ``ANGLE_SPIKE``
  (1 rad, 40 ms at top speed) while they agree with each other is an outlier; angles in
  degrees are caught by :func:`check_radians`;
- a swing lasts about a second, so sampling slower than ``MIN_RATE`` (10 Hz) cannot
  record one: a median time step of 0.1 or more is taken as milliseconds (or
  microseconds) rather than seconds, unless the plant's fastest mode is slow enough for it
  (ten samples a period: a heater's 0.002 Hz is recorded at 1 Hz) or ``--t-unit`` says seconds;
- whatever the unit, fewer than two samples a period of the plant's fastest oscillation (Nyquist:
  a buck converter's 3.4 kHz at 1 kHz) cannot be fitted and is refused; times that would sample
  it in milliseconds (a 100 kHz record with t in ms read as 100 Hz) are taken as milliseconds.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import PendcError
from ..model.interface import with_unit
from .table import Table

POSITION_LIMIT = {"m": 1.0}     # per unit: no rig position lies farther from its zero
POSITION_SPAN = {"m": 0.75}     # per unit: the longest travel (a 750 mm track)
INPUT_MARGIN = 10.0             # x full scale: beyond it, a unit mistake or an outlier
U_LIMIT = 100.0                 # V: INPUT_MARGIN x a 10 V input (the simulate command's check)
ANGLE_SPIKE = 1.0               # rad
LONE_SPIKE = 10.0               # x a position's own span: a sample that far from both neighbours is an outlier
MAX_RAD_RATE = 60.0             # rad/s; a bench rig's angle stays below ~8π ≈ 25 rad/s
MIN_RATE = 10.0                 # Hz
RATE_LIMIT = {"m/s": 10.0,      # a bench rig's carriage moves well below 1 m/s
              "rad/s": 200.0}
UNIT_FRACTION = 0.01   # more than this fraction of rows out of range -> a unit mistake
DECLARED_MARGIN = 2.0  # x the rate a plant file declares (velocity bound, training rate): still plausible
MODE_PERIODS = 10      # a record spans at least this many periods of the fastest mode (else it identifies nothing)
_SPELLED_T = {"ms": "milliseconds", "us": "microseconds"}
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


def written_by_pendc(table: Table) -> bool:
    """Whether ``table``'s header says pendc wrote it (``# generator: pendc ...``): seconds, radians."""
    return table.meta.get("generator", "").strip().startswith("pendc")


def check_time_unit(table: Table, t: np.ndarray, given: bool, fastest=None) -> None:
    """Refuse times that cannot be seconds. ``fastest()`` is the plant's fastest eigenvalue (1/s,
    complex; when a model is known). Sampling slower than MIN_RATE, and slower than ten samples a
    period of that mode, is taken as another unit unless the user gave one (``given``); sampling
    below Nyquist for its oscillation is refused even then (see :func:`check_nyquist`)."""
    if len(t) < 3:
        return
    stride = max(1, len(t) // 1_000_000)
    step = float(np.median(np.diff(t[::stride]))) / stride  # spread over the run, no full-length copy
    lam = complex(fastest()) if fastest is not None else 0j
    ours = written_by_pendc(table)    # pendc writes seconds
    mode = abs(lam) / (2 * math.pi)
    need = MIN_RATE if not mode > 0 else min(MIN_RATE, 10.0 * mode)
    if not (given or ours) and step >= 1.0 / need:    # a slow plant (a heater's minutes) is recorded slowly
        unit = "milliseconds" if step * 1e-3 < 1.0 / MIN_RATE else "microseconds"
        why = (f"ten samples a period of the plant's fastest mode, {mode:.3g} Hz, need {need:.3g} Hz" if mode > 0
               else f"sampling slower than {MIN_RATE:g} Hz cannot record a swing")
        raise PendcError(f"{table.source}: t looks like {unit} (median step {step:g}, last t = {float(t[-1]):g}; "
                         f"{why}): use --t-unit {'ms' if unit == 'milliseconds' else 'us'}, or --t-unit s if it is "
                         f"seconds")
    check_nyquist(table, t, step, given, lam, ours)


def _round_up(hz: float) -> str:
    """``hz`` rounded up to two significant digits, as a --rate to type (7349 -> 7400)."""
    scale = 10.0 ** (math.floor(math.log10(hz)) - 1)
    return f"{math.ceil(hz / scale) * scale:g}"


def check_nyquist(table: Table, t: np.ndarray, step: float, given: bool, lam: complex, ours: bool = False) -> None:
    """Fewer than two samples a period of the fastest mode's oscillation (eigenvalue ``lam``): it
    aliases, and no model can be fitted; a real pole has no period (a motor's 2 kHz electrical
    corner is recorded at 1 kHz as an instant). When milliseconds or microseconds would sample
    it and still span ``MODE_PERIODS`` periods, the times are taken for that unit, unless given."""
    from .resample import hertz

    ring = abs(lam.imag) / (2 * math.pi)
    if not 2.0 * ring * step > 1.0:
        return
    span = float(t[-1] - t[0])
    unit = next((u for u, f in (("ms", 1e-3), ("us", 1e-6)) if 2.0 * ring * step * f <= 1.0 and
                 span * f * ring >= MODE_PERIODS), None)
    mode = (f"fewer than 2 samples a period of the plant's fastest mode, a {ring:.4g} Hz oscillation (Nyquist "
            f"{hertz(2 * ring)}, ten samples a period {hertz(10 * ring)})")
    if ours:      # a file pendc wrote is in seconds: its rows are its input's (pendc simulate)
        raise PendcError(f"{table.source}: t is sampled at {hertz(1 / step)} (pendc wrote it: seconds), {mode}: "
                         f"record faster: pendc simulate writes one row per input row, so give it an input "
                         f"sampled at {hertz(10 * ring)} or more (pendc stimulus --rate {_round_up(10 * ring)})")
    if unit is not None and not given:
        raise PendcError(f"{table.source}: t looks like {_SPELLED_T[unit]} (median step {step:g}, last t = "
                         f"{float(t[-1]):g}; in seconds it is sampled at {hertz(1 / step)}, {mode}): use --t-unit "
                         f"{unit}, or a faster record if it is seconds")
    fix = "check --t-unit, or record faster" if given else "record faster, or give --t-unit ms if t is in milliseconds"
    raise PendcError(f"{table.source}: t is sampled at {hertz(1 / step)} (median step {step:g} s"
                     f"{', with the --t-unit given' if given else ''}), {mode}: {fix}")


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
                         f"{with_unit(f'{limit:g}', unit)}, max |{name}| = {peak:.6g}; {why}): {fix[1]}")
    k = int(np.argmax(out))
    raise PendcError(f"{table.source}: {table.where(k)}: {name} = {float(values[k]):.6g} is an outlier "
                     f"(|{name}| > {with_unit(f'{limit:g}', unit)}: {why}; {count} such row(s))")


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


def check_lone_spikes(table: Table, name: str, values: np.ndarray, unit: str, resolution: float | None) -> None:
    """A sample that leaves both neighbours, which agree, by more than ``LONE_SPIKE`` times the
    column's own span (its 0.5th to 99.5th percentile, so a few wild rows do not widen it) or
    than ``LONE_SPIKE`` steps of its sensor (``resolution``: a still position's one-code flicker):
    an outlier in a position of any unit (a temperature of 1e6 K among 350 K ones, a wheel angle
    of 1e30 rad). The positions whose unit a rig's limits know are checked by those limits too."""
    if len(values) < 3 or not np.all(np.isfinite(values)):
        return
    low, high = np.percentile(values, [0.5, 99.5])
    scale = max(float(high - low), resolution or 0.0, float(np.max(np.abs([low, high]))) * 1e-6, 1e-300)
    check_spikes(table, name, values, LONE_SPIKE * scale, unit)


def _spike_error(table: Table, name: str, values: np.ndarray, k: int, limit: float, unit: str) -> None:
    raise PendcError(f"{table.source}: {table.where(k)}: {name} = {float(values[k]):.6g} is an outlier (it jumps "
                     f"more than {with_unit(f'{limit:g}', unit)} away from both neighbours, "
                     f"{float(values[k - 1]):.6g} and {float(values[k + 1]):.6g})")


def unwrap_if_wrapped(angle: np.ndarray, period: float = 2 * math.pi) -> tuple[np.ndarray, int]:
    """``(angle, count)``: a position recorded modulo one ``period``, unwrapped, and its number
    of wraps.

    A jump of more than half a period between samples is a wrap when it is within 0.5 rad
    (for a 2π period) of one turn (a bench rig's angle moves at most ~25 rad/s, 0.25 rad per sample
    at 100 Hz); angles in degrees jump by 360 and are left for :func:`check_radians`.
    """
    d = np.diff(angle)
    half = period / 2
    jumps = (d > half) | (d < -half)
    if not jumps.any():
        return angle, 0
    if np.any(np.abs(np.abs(d[jumps]) - period) > 0.5 * period / (2 * math.pi)):  # one turn, never several
        return angle, 0
    return np.unwrap(angle, period=period), int(jumps.sum())


def degrees_suspected(names: list, angle: str) -> list:
    """Column names that announce ``angle`` in degrees (``<angle>_deg``, '<angle> (deg)', ...)."""
    import re

    pattern = re.compile(re.escape(angle) + r"\W*_?\W*deg(rees?)?\W*$", re.IGNORECASE)
    return [n for n in names if pattern.match(n)]


def check_radians(table: Table, t: np.ndarray, angle: np.ndarray, given: bool, name: str,
                  declared: float = 0.0) -> None:
    """Reject angles (column ``name``) that look like degrees.

    An angle is unwrapped radians, and a bench rig's angle turns at most about 8π rad/s.
    So a swing beyond ±2π that also moves faster than ``MAX_RAD_RATE`` (60 rad/s) between
    consecutive samples, or any |angle| > 200, is taken as degrees (a full turn is 360, and
    180°/s is already 3.1 rad/s). A plant file that declares its angle faster (``declared``, its
    rate's velocity bound or training rate: a reaction wheel's 250 rad/s) raises the rate limit
    to ``DECLARED_MARGIN`` times that rate, and an angle that turns that fast may be any size (a
    wheel's thousands of radians). A ``<name>_unit: deg``
    metadata entry is refused unless the unit was given (``--<name>-unit``). A file pendc wrote
    (``# generator: pendc ...``) is in radians.
    """
    rate_limit = max(MAX_RAD_RATE, DECLARED_MARGIN * declared)
    unit = table.meta.get(f"{name}_unit", "").strip().lower()
    peak = max(float(angle.max()), -float(angle.min()))
    rate, block = 0.0, 1 << 20  # in blocks: no full-length temporaries on a 1e7-row file
    for start in range(0, len(t) - 1, block):
        th, tt = angle[start:start + block + 1], t[start:start + block + 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            rate = max(rate, float(np.abs(np.diff(th) / np.diff(tt)).max()))
    # a large angle that turns faster than a bench rig, within what the file declares, is a
    # spinning wheel's, not degrees: its magnitude follows from its speed
    spinning = MAX_RAD_RATE < rate <= rate_limit
    # pendc writes radians: its own simulation of a link that whirls is not a unit mistake
    ours = written_by_pendc(table)
    if unit in _DEG_UNITS and not given:
        why = f"metadata {name}_unit: {unit}"
    elif not ours and ((peak > 200.0 and not spinning) or (peak > 2 * math.pi and rate > rate_limit)):
        why = f"max |{name}| = {peak:.4g}, max |d{name}/dt| = {rate:.4g} between samples"
    else:
        return
    fix = (f"check --{name}-unit" if given else
           f"convert the angles to radians, or give --{name}-unit deg (--{name}-unit rad if they are radians)")
    raise PendcError(f"{table.source}: column '{name}' looks like degrees ({why}): {fix}")


def input_warning(source: str, name: str, values: np.ndarray, low: float, high: float, unit: str) -> list:
    """A warning when some inputs lie outside the range ``low``-``high`` the actuator takes."""
    outside = (values < low) | (values > high)
    if not outside.any():
        return []
    return [f"{source}: {name} outside {with_unit(f'{low:g}-{high:g}', unit)} in {int(outside.sum())} of {len(values)} "
            f"samples (min {with_unit(f'{values.min():g}', unit)}, max {with_unit(f'{values.max():g}', unit)})"]
