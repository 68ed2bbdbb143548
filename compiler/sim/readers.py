"""From a file to a :class:`~pendc.sim.measurements.Measurement`: formats, names, units, checks.

:func:`read_table` reads CSV-like text (a path, or ``-`` for standard input) or a
MATLAB .mat file into a :class:`~pendc.sim.table.Table`; :func:`build_measurement`
maps its names onto pendc's columns (``ReadOptions.columns``), converts units, fills
axes the experiment makes irrelevant, runs the plausibility checks
(:mod:`pendc.sim.plausibility`), estimates the sensors' resolution and, when asked,
puts the samples on a uniform grid (:mod:`pendc.sim.resample`).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field

import numpy as np

from ..errors import PendcError, open_input
from . import plausibility as plaus
from .table import Table

UNITS = {
    "t": {"s": 1.0, "ms": 1e-3, "us": 1e-6},
    "x": {"m": 1.0, "cm": 1e-2, "mm": 1e-3},
    "u": {"V": 1.0, "mV": 1e-3},
    "theta": {"rad": 1.0, "deg": math.pi / 180},
}
THETA_ZERO = ("hanging", "upright")
AXES = ("x", "u", "theta")
RESOLUTION_COLUMNS = ("x", "theta", "u")
TIME_NAMES = ("t", "time", "tout")


@dataclass(frozen=True)
class ReadOptions:
    """How to read another lab's file (every field has a ``--option`` of the same name).

    ``columns`` maps a pendc name (t, u, x, theta, dx, dtheta) to the file's name;
    ``separator`` and ``decimal`` are characters (None: whitespace) or ``...`` to
    detect them. Units are a name of ``UNITS`` or a number (the SI value of one file
    unit), None for pendc's own (s, V, m, rad): then the unit checks' hints name the
    option to use. ``theta_zero='upright'`` with ``theta_sign`` s
    gives theta = s * theta_file + pi. ``allow_missing`` axes (besides those the
    experiment makes irrelevant) are filled with zeros, ``u`` with ``u_value``.
    ``uniform`` puts the samples on a uniform grid (at ``rate`` Hz, else see
    :func:`pendc.sim.resample.regrid`) and ``plausible`` checks the values against the
    rig's limits (:mod:`pendc.sim.plausibility`); both are off by default, so a library
    read is faithful (a simulation may drive the cart off the track), and on for the
    identification commands.
    """

    columns: dict = field(default_factory=dict)
    separator: object = ...
    decimal: object = ...
    encoding: str = "utf-8"
    t_unit: str | None = None
    x_unit: str | None = None
    u_unit: str | None = None
    theta_unit: str | None = None
    theta_zero: str = "hanging"
    theta_sign: float = 1.0
    experiment: str | None = None
    resolution: dict = field(default_factory=dict)
    allow_missing: tuple = ()
    u_value: float = 0.0
    sample_time: float | None = None
    rate: float | None = None
    uniform: bool = False
    plausible: bool = False

    def __post_init__(self):
        for axis, unit in (("t", self.t_unit), ("x", self.x_unit), ("u", self.u_unit), ("theta", self.theta_unit)):
            if unit is not None:
                unit_factor(axis, unit)
        if self.theta_zero not in THETA_ZERO:
            raise PendcError(f"--theta-zero {self.theta_zero!r}: use hanging or upright")
        if self.theta_sign not in (1.0, -1.0):
            raise PendcError(f"--theta-sign {self.theta_sign!r}: use 1 or -1")
        bad = [a for a in self.allow_missing if a not in AXES]
        if bad:
            raise PendcError(f"--missing {','.join(bad)}: only x, u and theta can be missing")


def read_table(path: str, options: ReadOptions = ReadOptions()) -> Table:
    """Read a CSV-like or .mat file (``-``: CSV text from standard input)."""
    from .csvread import read_csv_table
    from .matread import is_mat_file, read_mat_table

    if str(path) == "-":
        return read_csv_table(sys.stdin.buffer, "<stdin>", options.separator, options.decimal,
                              options.encoding)
    with open_input(path, "measurement file") as f:
        try:
            head = f.peek(128)[:128] if hasattr(f, "peek") else b""
            if is_mat_file(head, str(path)):
                f.close()
                return read_mat_table(str(path))
            return read_csv_table(f, str(path), options.separator, options.decimal, options.encoding)
        except IsADirectoryError:
            raise PendcError(f"{path}: is a folder, not a measurement file") from None
        except OSError as exc:
            raise PendcError(f"{path}: cannot read measurement file ({exc.strerror or exc})") from None


def map_columns(table: Table, options: ReadOptions, wanted: tuple) -> tuple[dict, dict]:
    """``(columns, file_names)``: pendc name -> array (and -> the file's name) for ``wanted``
    names found, then the file's other columns under their own names."""
    chosen, origin = {}, {}
    for name, file_name in options.columns.items():
        key = table.lookup(file_name)
        if key is None:
            raise PendcError(f"{table.source}: --columns {name}={file_name}: no such column or signal "
                             f"(names found: {', '.join(table.names())})")
        chosen[name], origin[name] = table.columns[key], key
    for name in wanted:
        if name not in chosen:
            key = table.lookup(name)
            if key is not None and key not in origin.values():
                chosen[name], origin[name] = table.columns[key], key
    used = set(origin.values())
    for name, values in table.columns.items():
        if name not in used and name not in chosen:
            chosen[name] = values
    return chosen, origin


def resolve_time(table: Table, columns: dict, origin: dict, options: ReadOptions) -> list:
    """Give ``columns`` a ``t`` (in place): mapped, a time variable, a signal's own time, or
    ``sample_time``; signals with other time vectors are interpolated onto it. Returns notes."""
    notes = []
    signals = [origin[n] for n in ("theta", "x", "u") if n in origin]
    if "t" not in origin:
        own = [table.times[s] for s in signals if s in table.times]
        if own:
            columns["t"] = own[0]
            origin["t"] = f"the time of signal '{signals[0]}'"
        else:
            length = len(columns[next(iter(n for n in ("theta", "x", "u") if n in origin))]) if signals else 0
            found = [n for n in table.names() if n.lower() in TIME_NAMES or n.lower().endswith(".time")]
            found = [n for n in found if len(table.columns[table.lookup(n)]) == length]
            if found:
                columns["t"] = table.columns[table.lookup(found[0])]
                origin["t"] = found[0]
            elif options.sample_time or _positive(table.meta.get("Ts")):
                step = options.sample_time or _positive(table.meta.get("Ts"))
                columns["t"] = step * np.arange(length)
                origin["t"] = f"sample time {step:g} s"
                notes.append(f"{table.source}: no time vector: t = k * {step:g} s")
    t = columns.get("t")
    if t is None:
        raise PendcError(f"{table.source}: no time column (names found: {', '.join(table.names())}): map one with "
                         f"--columns t=NAME, or give --sample-time S")
    t = np.asarray(t, dtype=np.float64)
    mapped = [n for n in ("theta", "x", "u", "dx", "dtheta") if n in origin]
    others = [n for n in mapped if origin[n] in table.times and not np.array_equal(table.times[origin[n]], t)]
    if others:  # keep only the time span every signal covers: no extrapolation
        lo = max(float(table.times[origin[n]][0]) for n in others)
        hi = min(float(table.times[origin[n]][-1]) for n in others)
        keep = (t >= lo) & (t <= hi)
        if not keep.all():
            for n in [m for m in mapped if m not in others and len(columns[m]) == len(t)]:
                columns[n] = columns[n][keep]
            t = t[keep]
    for name in mapped:
        src = origin[name]
        if name in others:
            columns[name] = np.interp(t, table.times[src], columns[name])
            notes.append(f"{table.source}: '{src}' has its own time vector: interpolated onto t")
        elif len(columns[name]) != len(t):
            raise PendcError(f"{table.source}: '{src}' has {len(columns[name])} samples but the time "
                             f"({origin['t']}) has {len(t)}")
    columns["t"] = t
    return notes


def unit_factor(axis: str, unit: str) -> float:
    """SI value of one file unit: a name of ``UNITS[axis]``, or a positive number (e.g. the
    radians of one encoder count, 2*pi/20000 = 3.14159e-4, for angles logged in counts)."""
    if unit in UNITS[axis]:
        return UNITS[axis][unit]
    try:
        factor = float(unit)
    except (TypeError, ValueError):
        factor = -1.0
    if not (factor > 0 and math.isfinite(factor)):
        raise PendcError(f"--{axis}-unit {unit!r}: use one of {', '.join(UNITS[axis])}, or the size of one file "
                         f"unit in {next(iter(UNITS[axis]))} (a positive number)")
    return factor


def _positive(text) -> float | None:
    """A metadata value as a positive number, or None."""
    try:
        value = float(text)
    except (TypeError, ValueError):
        return None
    return value if value > 0 and math.isfinite(value) else None


def convert_units(columns: dict, options: ReadOptions) -> None:
    """Scale to s, m, V, rad (in place); theta from upright is shifted to pendc's hanging zero."""
    scale = {axis: unit_factor(axis, unit) for axis, unit in (("t", options.t_unit), ("x", options.x_unit),
             ("u", options.u_unit), ("theta", options.theta_unit)) if unit is not None}
    scale["theta"] = scale.get("theta", 1.0) * options.theta_sign
    rates = {"dx": scale.get("x", 1.0) / scale.get("t", 1.0), "dtheta": scale["theta"] / scale.get("t", 1.0)}
    for name, factor in {**scale, **rates}.items():
        if name in columns and factor != 1.0:
            columns[name] = columns[name] * factor
    if options.theta_zero == "upright" and "theta" in columns:
        columns["theta"] = columns["theta"] + math.pi


def estimate_resolution(values: np.ndarray, max_samples: int = 500_000) -> float | None:
    """The quantisation step of ``values``, or None when they do not look quantised.

    The smallest nonzero jump between samples is a candidate step q; it is accepted
    when 99 % of all nonzero jumps are whole multiples of q (within 1 % of q) and q
    is not below 1e-9 of the values' scale (floating-point noise). q is refined as
    the least-squares step over the jumps. Only the first ``max_samples`` are used.
    """
    v = np.asarray(values[:max_samples], dtype=np.float64)
    if len(v) < 10:
        return None
    jumps = np.abs(np.diff(v))
    scale = float(np.max(np.abs(v))) or 1.0
    jumps = jumps[jumps > 1e-9 * scale]
    if len(jumps) < 5:
        return None
    for q in (float(jumps.min()), float(np.percentile(jumps, 1))):
        counts = np.round(jumps / q)
        ok = np.abs(jumps / q - counts) < 0.01
        if np.mean(ok) >= 0.99 and np.median(counts) < 1e5:
            return float(np.sum(jumps[ok]) / np.sum(counts[ok]))
    return None


def missing_allowed(experiment: str, options: ReadOptions) -> set:
    """Axes that may be absent from the file: the experiment's irrelevant ones and the user's."""
    from ..model.experiments import EXPERIMENTS

    irrelevant = {"cart_held": {"x", "u"}, "pendulum_removed": {"theta"}}
    if experiment not in EXPERIMENTS:
        raise PendcError(f"unknown experiment '{experiment}' (known: {', '.join(EXPERIMENTS)})")
    return irrelevant.get(experiment, set()) | set(options.allow_missing)


def build_measurement(table: Table, options: ReadOptions = ReadOptions(), required=("t", "u", "x", "theta")):
    """Map, convert, check and (if ``options.uniform``) regrid a table (see the module docstring)."""
    from .measurements import Measurement

    experiment = (options.experiment or table.meta.get("experiment") or "free").strip()
    try:
        allowed = missing_allowed(experiment, options)
    except PendcError as exc:
        raise PendcError(f"{table.source}: {exc}") from None
    if table.headerless and not options.columns:
        raise PendcError(f"{table.source}: line {table.first_line}: no header row (this line looks like data): add "
                         f"one (t,u,x,theta), or map the columns by number, e.g. --columns t=1,u=2,x=3,theta=4")
    wanted = tuple(dict.fromkeys(("t", "u", *required, "x", "theta", "dx", "dtheta")))
    columns, origin = map_columns(table, options, wanted)
    need = [n for n in dict.fromkeys(("u", *required)) if n != "t"]
    absent = [n for n in need if n not in columns]
    refused = [n for n in absent if n not in allowed]
    if refused:
        _missing_error(table, refused, options)
    notes = list(table.notes)
    if "t" not in origin or table.times:
        notes += resolve_time(table, columns, origin, options)
    for name, values in list(columns.items()):
        if name in origin:
            plaus.check_finite(table, name, np.asarray(values))
    convert_units(columns, options)
    _check(table, columns, options, notes)
    resolution = {n: estimate_resolution(columns[n]) for n in RESOLUTION_COLUMNS if n in columns}
    resolution = {n: q for n, q in resolution.items() if q is not None}
    resolution.update(options.resolution)
    warnings = plaus.voltage_warning(table.source, columns["u"]) if "u" in columns else []
    missing = tuple(n for n in ("x", "u", "theta") if n in absent)
    for n in missing:
        columns[n] = np.full(len(columns["t"]), options.u_value if n == "u" else 0.0)
    if missing:
        notes.append(f"{table.source}: no {', '.join(missing)} in the file ({experiment} experiment): filled with "
                     + ", ".join(f"{n} = {options.u_value if n == 'u' else 0.0:g}" for n in missing))
    first_line = table.first_line
    if options.uniform:
        t = columns.pop("t")
        numeric = {n: v for n, v in columns.items() if n in origin or n in missing}
        t, regridded, note = _regrid(table, t, numeric, options)
        if note:
            notes.append(note)
            first_line = 0
            columns = {n: regridded[n] for n in numeric}  # other columns are dropped with the old grid
        columns = {"t": t, **columns}
    else:
        columns = {"t": columns.pop("t"), **columns}
    ordered = {n: _frozen(columns[n]) for n in dict.fromkeys((*[n for n in ("t", "u", "x", "theta") if n in columns],
                                                              *columns))}
    return Measurement(t=ordered["t"], u=ordered.get("u"), columns=ordered, meta=dict(table.meta),
                       source=table.source, warnings=tuple(warnings), first_line=first_line,
                       experiment=experiment, resolution=resolution, missing=missing, notes=tuple(notes))


def _regrid(table: Table, t, columns: dict, options: ReadOptions):
    from .resample import regrid

    return regrid(t, columns, table.source, table.where, options.rate)


def _frozen(values) -> np.ndarray:
    arr = np.ascontiguousarray(values, dtype=np.float64)
    arr.setflags(write=False)
    return arr


def _missing_error(table: Table, refused: list, options: ReadOptions) -> None:
    names = table.names()
    degrees = plaus.degrees_suspected(names)
    if "theta" in refused and degrees:
        raise PendcError(f"{table.source}: the angle column looks like degrees ({', '.join(degrees)}): map it with "
                         f"--columns theta={degrees[0]} --theta-unit deg")
    hints = {"x": "a clamped cart: --experiment cart_held", "u": "a free swing: --experiment cart_held or --missing u",
             "theta": "the cart alone: --experiment pendulum_removed"}
    found = [n for n in AXES if n not in refused]
    why = f", or for {'; for '.join(hints[n] for n in refused)}" if found else ""
    if table.unreadable:
        why += f" (not readable here: {', '.join(table.unreadable)}: MATLAB objects or malformed structs)"
    raise PendcError(f"{table.source}: missing column(s) {', '.join(refused)} (columns: {', '.join(names)}); map "
                     f"with --columns NAME=FILE_NAME{why}")


def _check(table: Table, columns: dict, options: ReadOptions, notes: list) -> None:
    """The checks, in the order that gives the most telling message (appends notes).

    Always: time order, wrapped angles, degrees. With ``options.plausible`` (reading a
    recording for identification) also the rig's physical limits: outliers and unit
    mistakes in x, u, theta and t; a simulation's output may leave the track on purpose.
    """
    t = columns["t"]
    plaus.check_time(table, t)
    if "theta" in columns:  # unwrap first: a wrapped angle balancing at +-pi jumps a turn and back
        unwrapped, wraps = plaus.unwrap_if_wrapped(columns["theta"])
        if wraps:
            columns["theta"] = unwrapped
            notes.append(f"{table.source}: theta was wrapped to one turn ({wraps} jumps of a whole turn between "
                         f"samples, which the pendulum cannot make): unwrapped")
        if options.plausible:
            plaus.check_spikes(table, "theta", columns["theta"], plaus.THETA_SPIKE, "rad")
    if options.plausible:
        _check_limits(table, columns, options)
    if "theta" in columns:
        plaus.check_radians(table, t, columns["theta"], options.theta_unit is not None)
    if options.plausible and ("x" in columns or "theta" in columns):  # an input alone may be sparse steps
        plaus.check_time_unit(table, t, options.t_unit is not None)


def _check_limits(table: Table, columns: dict, options: ReadOptions) -> None:
    """x, u and the velocities within the rig's limits: a few rows beyond are outliers, many a unit."""
    if "u" in columns:
        plaus.check_bounded(table, "u", columns["u"], plaus.U_LIMIT, "V", "the drive takes 0-10 V",
                            ("millivolts", "check --u-unit" if options.u_unit else "use --u-unit mV"))
    if "x" in columns:
        # In centimetres no position reaches 75 (the track's length): beyond that, millimetres.
        x = columns["x"]
        mm = float(x.max()) > plaus.X_LIMIT or float(x.min()) < -plaus.X_LIMIT  # then, only, look closer
        mm = mm and float(np.percentile(np.abs(x), 99)) > 75.0
        plaus.check_bounded(table, "x", x, plaus.X_LIMIT, "m", "the track is 0.75 m long",
                            ("millimetres" if mm else "centimetres",
                             "check --x-unit" if options.x_unit else f"use --x-unit {'mm' if mm else 'cm'}"))
    for name, limit in (("dx", plaus.DX_LIMIT), ("dtheta", plaus.DTHETA_LIMIT)):
        if name in columns:
            plaus.check_bounded(table, name, columns[name], limit, "per s", "faster than the rig can move",
                                ("a unit mistake", "check its unit"))
