"""Measurement files (spec §6): CSV in, CSV out.

A file is UTF-8 text: optional leading ``#`` comment lines, one header row naming
the columns, then comma-separated numeric rows (blank lines only at the end).
Comment lines shaped ``# key: value`` (key without spaces) become metadata; other
comments are free-form and ignored. Every problem is reported as one-line
:class:`~pendc.errors.PendcError` naming the file and, where possible, the line
and the column.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from ..errors import PendcError

REQUIRED = ("t", "u", "x", "theta")
_KEY = r"[A-Za-z_][\w.\-]*"  # one word, so prose like '# Run 3 on rig B: ok' is not metadata
_META = re.compile(rf"#\s*({_KEY})\s*:\s*(.*?)\s*$")
_DEG_NAME = re.compile(r"theta\W*_?\W*deg(rees?)?\W*$", re.IGNORECASE)
_DEG_UNITS = {"deg", "degree", "degrees", "°"}
FIT_WINDOW = 0.010  # s, for initial_state's velocity estimate
MAX_RAD_RATE = 60.0  # rad/s; the pendulum never exceeds ~8π ≈ 25 rad/s (II.56)


@dataclass(frozen=True, eq=False)
class Measurement:
    """One measured run; arrays are float64 and read-only (``columns`` holds them all)."""

    t: np.ndarray
    u: np.ndarray
    columns: dict
    meta: dict
    source: str = "<string>"
    warnings: tuple = ()
    first_line: int = field(default=0, repr=False)  # file line of row 0, for messages

    def column(self, name: str) -> np.ndarray:
        """The column called ``name``; PendcError if it is absent or not finite."""
        if name not in self.columns:
            raise PendcError(f"{self.source}: no column '{name}' (columns: {', '.join(self.columns)})")
        values = self.columns[name]
        _check_finite(self.source, name, values, self.first_line)
        return values

    # Optional columns: the array, or None when the file has no such column.
    x = property(lambda self: self.columns.get("x"), doc="Cart position (m) or None.")
    theta = property(lambda self: self.columns.get("theta"), doc="Pendulum angle (rad) or None.")
    dx = property(lambda self: self.columns.get("dx"), doc="Cart velocity (m/s) or None.")
    dtheta = property(lambda self: self.columns.get("dtheta"), doc="Angular velocity (rad/s) or None.")

    def initial_state(self) -> tuple[float, float, float, float]:
        """``(x, dx, theta, dtheta)`` at ``t[0]``, for starting a simulation from the data.

        Positions come from the first row; an absent position column counts as 0 (the
        spec's default initial state). Velocities come from their ``dx``/``dtheta``
        columns when present; otherwise they are the slope of a least-squares line
        through the samples of the first ``FIT_WINDOW`` (10 ms) of the position, and at
        least 3 samples, which averages out the encoder quantisation that a plain
        first difference would amplify. With fewer than 2 samples the velocity is 0.
        """
        t = self.t
        n = max(3, int(np.searchsorted(t, t[0] + FIT_WINDOW, side="right")))
        state = []
        for pos, vel in (("x", "dx"), ("theta", "dtheta")):
            p = self.columns.get(pos)
            v = self.columns.get(vel)
            state.append(float(p[0]) if p is not None else 0.0)
            if v is not None:
                state.append(float(v[0]))
            elif p is None or len(t) < 2:
                state.append(0.0)
            else:
                state.append(float(np.polyfit(t[:n] - t[0], p[:n], 1)[0]))
        return tuple(state)


def read_measurements(path: str | os.PathLike, required=REQUIRED) -> Measurement:
    """Read and check a measurement file (see :func:`parse_measurements`)."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise PendcError(f"{path}: measurement file not found") from None
    except IsADirectoryError:
        raise PendcError(f"{path}: is a folder, not a measurement file") from None
    except OSError as exc:
        raise PendcError(f"{path}: cannot read measurement file ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise PendcError(f"{path}: line {line}: not UTF-8 text (byte 0x{raw[exc.start]:02x})") from None
    return parse_measurements(text, source=str(path), required=required)


def parse_measurements(text: str, source: str = "<string>", required=REQUIRED) -> Measurement:
    """Parse measurement-file text and check it.

    ``t`` and ``u`` are always required, plus the names in ``required``. Errors:
    malformed rows, missing or duplicate columns, NaN/inf in a known column
    (``required``, t, u, x, theta, dx, dtheta), time not strictly increasing, and
    angles that look like degrees (see :func:`_check_radians`). Voltages outside
    0-10 V only add an entry to ``warnings``.
    """
    lines = [ln.rstrip("\r") for ln in text.split("\n")]
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise PendcError(f"{source}: file is empty")
    meta, i = {}, 0
    while i < len(lines) and (lines[i].startswith("#") or not lines[i].strip()):
        m = _META.match(lines[i])
        if m:
            meta[m.group(1)] = m.group(2)
        i += 1
    if i == len(lines):
        raise PendcError(f"{source}: no header row (only comments)")
    names = [n.strip() for n in lines[i].split(",")]
    _check_header(source, names, i + 1)
    data = lines[i + 1 :]
    first = i + 2
    if not data:
        raise PendcError(f"{source}: no data rows after the header (line {i + 1})")
    values = _parse_rows(source, data, names, first)
    columns = {n: values[:, k].copy() for k, n in enumerate(names)}
    for arr in columns.values():
        arr.setflags(write=False)

    need = tuple(dict.fromkeys(("t", "u", *required)))
    missing = [n for n in need if n not in columns]
    if missing:
        if "theta" in missing and any(_DEG_NAME.match(n) for n in names):
            raise PendcError(f"{source}: the angle column looks like degrees ({', '.join(n for n in names if _DEG_NAME.match(n))}): convert it to radians and name it 'theta'")
        raise PendcError(f"{source}: missing column(s) {', '.join(missing)} (columns: {', '.join(names)})")
    for n in dict.fromkeys((*need, "x", "theta", "dx", "dtheta")):
        if n in columns:
            _check_finite(source, n, columns[n], first)
    t, u = columns["t"], columns["u"]
    _check_time(source, t, first)
    if "theta" in columns:
        _check_radians(source, t, columns["theta"], meta)

    warnings = []
    outside = (u < 0.0) | (u > 10.0)
    if outside.any():
        warnings.append(f"{source}: u outside 0-10 V in {int(outside.sum())} of {len(u)} samples (min {u.min():g} V, max {u.max():g} V)")
    return Measurement(t=t, u=u, columns=columns, meta=meta, source=source, warnings=tuple(warnings), first_line=first)


def format_csv(columns: dict, meta: dict | None = None) -> str:
    """Measurement-file text: ``# key: value`` lines, the header, then one row per sample.

    Floats are written with ``repr`` (shortest text that reads back bit for bit), so
    the output is deterministic and lossless. Metadata keys must be single words and
    values single lines; surrounding whitespace of values is not kept.
    """
    if not columns:
        raise PendcError("format_csv: no columns to write")
    out = []
    for key, value in (meta or {}).items():
        value = str(value)
        if not re.fullmatch(_KEY, str(key)) or "\n" in value or "\r" in value:
            raise PendcError(f"format_csv: metadata {key!r}: {value!r} cannot be written as a '# key: value' line")
        out.append(f"# {key}: {value.strip()}")
    names = [str(n) for n in columns]
    for n in names:
        if not n.strip() or n != n.strip() or any(c in n for c in ",\r\n") or n.startswith("#"):
            raise PendcError(f"format_csv: column name {n!r} cannot be written in a CSV header")
    arrays = [np.asarray(columns[n], dtype=np.float64) for n in names]
    for n, a in zip(names, arrays):
        if a.ndim != 1 or len(a) != len(arrays[0]):
            raise PendcError(f"format_csv: column '{n}' has shape {a.shape}, expected ({len(arrays[0])},)")
    out.append(",".join(names))
    text_cols = [map(repr, a.tolist()) for a in arrays]
    out.extend(",".join(row) for row in zip(*text_cols))
    return "\n".join(out) + "\n"


def write_csv(path: str | os.PathLike, columns: dict, meta: dict | None = None) -> None:
    """Write a measurement file atomically (see :func:`format_csv`)."""
    write_atomic(path, format_csv(columns, meta))


def _check_header(source: str, names: list, line: int) -> None:
    if all(_is_number(n) for n in names):
        raise PendcError(f"{source}: line {line}: no header row (this line looks like data)")
    if any(not n for n in names):
        raise PendcError(f"{source}: line {line}: header has an empty column name")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise PendcError(f"{source}: line {line}: duplicate column name(s) {', '.join(dup)}")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _parse_rows(source: str, data: list, names: list, first: int) -> np.ndarray:
    commas = np.fromiter((ln.count(",") for ln in data), dtype=np.int64, count=len(data))
    bad = np.flatnonzero(commas != len(names) - 1)
    if bad.size:
        k = int(bad[0])
        if data[k].startswith("#"):
            raise PendcError(f"{source}: line {first + k}: comment line among the data; comments must come before the header")
        what = "blank line" if not data[k].strip() else f"{commas[k] + 1} fields"
        raise PendcError(f"{source}: line {first + k}: {what}, expected {len(names)} fields ({', '.join(names)})")
    try:
        return np.loadtxt(data, delimiter=",", dtype=np.float64, comments=None, ndmin=2)
    except ValueError as exc:
        # loadtxt's message has no file line or column name: find the culprit ourselves.
        for k, ln in enumerate(data):
            for name, field_ in zip(names, ln.split(",")):
                if not _is_number(field_):
                    raise PendcError(f"{source}: line {first + k}: column '{name}': not a number: {field_.strip()!r}") from None
        raise PendcError(f"{source}: cannot parse the data rows ({str(exc).splitlines()[0]})") from None


def _check_finite(source: str, name: str, values: np.ndarray, first: int) -> None:
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        k = int(bad[0])
        where = f"line {first + k}" if first else f"row {k}"
        raise PendcError(f"{source}: {where}: column '{name}' is {values[k]} ({bad.size} non-finite value(s); NaN and inf are not allowed)")


def _check_time(source: str, t: np.ndarray, first: int) -> None:
    bad = np.flatnonzero(np.diff(t) <= 0.0)
    if bad.size:
        k = int(bad[0]) + 1
        a, b = float(t[k - 1]), float(t[k])
        kind = f"duplicate time t = {b!r}" if a == b else f"time decreases from {a!r} to {b!r}"
        raise PendcError(f"{source}: line {first + k}: {kind}; t must be strictly increasing")


def _check_radians(source: str, t: np.ndarray, theta: np.ndarray, meta: dict) -> None:
    """Reject angles that look like degrees.

    theta is unwrapped radians from hanging-down, and the pendulum turns at most about
    8π rad/s (II.56). So a swing beyond ±2π that also moves faster than ``MAX_RAD_RATE``
    (60 rad/s) between consecutive samples, or any |theta| > 200, is taken as degrees
    (a full turn is 360, and 180°/s is already 3.1 rad/s). A ``theta_unit: deg``
    metadata entry is refused outright.
    """
    unit = meta.get("theta_unit", "").strip().lower()
    peak = float(np.abs(theta).max())
    rate = float(np.abs(np.diff(theta) / np.diff(t)).max()) if len(t) > 1 else 0.0
    if unit in _DEG_UNITS:
        why = f"metadata theta_unit: {unit}"
    elif peak > 200.0 or (peak > 2 * math.pi and rate > MAX_RAD_RATE):
        why = f"max |theta| = {peak:.4g}, max |dtheta/dt| = {rate:.4g} between samples"
    else:
        return
    raise PendcError(f"{source}: column 'theta' looks like degrees ({why}): convert the angles to radians")
