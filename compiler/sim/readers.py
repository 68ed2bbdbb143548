"""From a file to a :class:`~pendc.sim.measurements.Measurement`: formats, names, units, checks.

:func:`read_table` reads CSV-like text (a path, or ``-`` for standard input) or a
MATLAB .mat file into a :class:`~pendc.sim.table.Table`; :func:`build_measurement`
maps its names onto pendc's columns (``ReadOptions.columns``), converts units, fills
axes the experiment makes irrelevant, runs the plausibility checks
(:mod:`pendc.sim.read_checks`, with the rules of :mod:`pendc.sim.plausibility`), estimates the sensors' resolution and, when asked,
puts the samples on a uniform grid (:mod:`pendc.sim.resample`).
"""

from __future__ import annotations

import math
import sys

import numpy as np

from ..errors import PendcError, open_input
from . import plausibility as plaus
from .experiment_axes import held_experiment_of, irrelevant_axes, missing_hint
from .read_checks import check_columns
from .read_options import ReadOptions, unit_factor  # noqa: F401 (re-exported: how a file is read)
from .signals import TIME, PlantSignals
from .table import Table

TIME_NAMES = (TIME, "time", "tout")
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
            raise PendcError(f"{table.source}: --columns {name}={file_name}: " + (
                _text_hint(table, [file_name]) or f"no such column or signal (names found: {', '.join(table.names())})"))
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
    sig = options.signals
    axes = (*reversed(sig.positions), sig.input)   # the lab story logs an angle alone: it leads
    signals = [origin[n] for n in axes if n in origin]
    if "t" not in origin:
        own = [table.times[s] for s in signals if s in table.times]
        if own:
            columns["t"] = own[0]
            origin["t"] = f"the time of signal '{signals[0]}'"
        else:
            length = len(columns[next(iter(n for n in axes if n in origin))]) if signals else 0
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
    mapped = [n for n in (*axes, *sig.rates) if n in origin]
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


def _positive(text) -> float | None:
    """A metadata value as a positive number, or None."""
    try:
        value = float(text)
    except (TypeError, ValueError):
        return None
    return value if value > 0 and math.isfinite(value) else None


def convert_units(columns: dict, options: ReadOptions) -> None:
    """Scale to the interface's units (in place: s and the SI units the interface declares); a periodic
    position with its zero ``upright`` is shifted by half a period to the interface's zero."""
    sig = options.signals
    scale = {axis: unit_factor(axis, unit, sig) for axis, unit in options.units.items() if unit is not None}
    for name, sign in options.sign.items():
        scale[name] = scale.get(name, 1.0) * sign
    per_second = scale.get(TIME, 1.0)
    for position in sig.positions:
        rate = sig.rate(position)
        if rate is not None and rate not in options.units:
            scale[rate] = scale.get(position, 1.0) / per_second
    for name, factor in scale.items():
        if name in columns and factor != 1.0:
            columns[name] = columns[name] * factor
    for name, where in options.zero.items():
        if where == "upright" and name in columns:
            columns[name] = columns[name] + sig.period(name) / 2


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
    return irrelevant_axes(options.plant, experiment) | set(options.allow_missing)


def build_measurement(table: Table, options: ReadOptions = ReadOptions(), required=None):
    """Map, convert, check and (if ``options.uniform``) regrid a table (see the module docstring).
    ``required`` names the columns the file must have (default: the plant's time, input and
    positions)."""
    from .measured_run import Measurement

    sig = options.signals
    required = sig.columns if required is None else tuple(required)
    experiment = (options.experiment or table.meta.get("experiment") or "free").strip()
    try:
        allowed = missing_allowed(experiment, options)
    except PendcError as exc:
        raise PendcError(f"{table.source}: {exc}") from None
    if table.headerless and not options.columns:
        example = ",".join(f"{n}={k}" for k, n in enumerate(sig.columns, 1))
        raise PendcError(f"{table.source}: line {table.first_line}: no header row (this line looks like data): add "
                         f"one ({','.join(sig.columns)}), or map the columns by number, e.g. --columns {example}")
    wanted = tuple(dict.fromkeys((TIME, sig.input, *required, *sig.all_columns)))
    columns, origin = map_columns(table, options, wanted)
    need = [n for n in dict.fromkeys((sig.input, *required)) if n != TIME]
    absent = [n for n in need if n not in columns]
    refused = [n for n in absent if n not in allowed]
    if refused:
        _missing_error(table, refused, options)
    notes = list(table.notes)
    if TIME not in origin or table.times:
        notes += resolve_time(table, columns, origin, options)
    for name, values in list(columns.items()):
        if name in origin:
            plaus.check_finite(table, name, np.asarray(values))
    convert_units(columns, options)
    check_columns(table, columns, options, notes, lambda: _fastest_eigenvalue(options.plant))
    resolution = {n: estimate_resolution(columns[n]) for n in (*sig.positions, sig.input) if n in columns}
    resolution = {n: q for n, q in resolution.items() if q is not None}
    resolution.update(options.resolution)
    warnings = _input_warning(table.source, sig, columns)
    if not options.experiment and not table.meta.get("experiment"):
        held = held_experiment_of(options.plant, columns, resolution)
        if held is not None:    # the simulation then holds what the data show held
            experiment = held
            notes.append(f"{table.source}: {', '.join(sorted(irrelevant_axes(options.plant, held) & set(sig.positions)))}"
                         f" does not move: read as experiment {held} (give --experiment free to compare it moving)")
    missing = tuple(n for n in (*sig.positions, sig.input) if n in absent)
    fill = {n: options.u_value if n == sig.input else 0.0 for n in missing}
    for n in missing:
        columns[n] = np.full(len(columns[TIME]), fill[n])
    if missing:
        notes.append(f"{table.source}: no {', '.join(missing)} in the file ({experiment} experiment): filled with "
                     + ", ".join(f"{n} = {fill[n]:g}" for n in missing))
    first_line = table.first_line
    if options.uniform:
        t = columns.pop(TIME)
        numeric = {n: v for n, v in columns.items() if n in origin or n in missing}
        t, regridded, note = _regrid(table, t, numeric, options)
        if note:
            notes.append(note)
            first_line = 0
            columns = {n: regridded[n] for n in numeric}  # other columns are dropped with the old grid
        columns = {TIME: t, **columns}
    else:
        columns = {TIME: columns.pop(TIME), **columns}
    ordered = {n: _frozen(columns[n]) for n in dict.fromkeys((*[n for n in sig.columns if n in columns],
                                                              *columns))}
    return Measurement(t=ordered[TIME], u=ordered.get(sig.input), columns=ordered, meta=dict(table.meta),
                       source=table.source, warnings=tuple(warnings), first_line=first_line,
                       experiment=experiment, resolution=resolution, missing=missing, notes=tuple(notes),
                       signals=sig)


def _input_warning(source: str, sig: PlantSignals, columns: dict) -> list:
    """Inputs outside the range the interface's actuator takes: a warning (a clipped amplifier
    can show it)."""
    if sig.input not in columns:
        return []
    drive = sig.interface.input.range
    return plaus.input_warning(source, sig.input, columns[sig.input], drive.lo, drive.hi, drive.unit)


def _regrid(table: Table, t, columns: dict, options: ReadOptions):
    from .resample import regrid

    return regrid(t, columns, table.source, table.where, options.rate, fastest=lambda: _fastest_mode(options.plant),
                  held=(options.signals.input,))


def _fastest_mode(plant) -> float:
    """The fastest mode (Hz) of ``plant`` if it is a model (an interface alone has no equations)."""
    return abs(_fastest_eigenvalue(plant)) / (2 * math.pi)


def _fastest_eigenvalue(plant) -> complex:
    """The fastest eigenvalue (1/s) of ``plant`` if it is a model, else 0."""
    from ..model.modes import fastest_eigenvalue
    from ..model.plant import PlantModel

    return complex(fastest_eigenvalue(plant)) if isinstance(plant, PlantModel) else 0j


def _frozen(values) -> np.ndarray:
    arr = np.ascontiguousarray(values, dtype=np.float64)
    arr.setflags(write=False)
    return arr


def _text_hint(table: Table, names: list) -> str:
    """For the ``names`` that are columns of text the reader skipped: which, with their first
    value and its line ('' when none is)."""
    text = [(k, *table.text_columns[k]) for n in names for k in table.text_columns if k.lower() == n.lower()]
    return "; ".join(f"column '{k}' holds text ({value!r} on line {line}), not numbers" for k, line, value in text)


def _missing_error(table: Table, refused: list, options: ReadOptions) -> None:

    names = table.names()
    sig = options.signals
    for angle in sig.periodic:
        degrees = plaus.degrees_suspected(names, angle)
        if angle in refused and degrees:
            raise PendcError(f"{table.source}: the angle column looks like degrees ({', '.join(degrees)}): map it with "
                             f"--columns {angle}={degrees[0]} --{angle}-unit deg")
    found = [n for n in (*sig.positions, sig.input) if n not in refused]
    hints = [missing_hint(options.plant, n) for n in refused]
    why = f", or for {'; for '.join(hints)}" if found and all(hints) else ""
    if table.unreadable:
        why += f" (not readable here: {', '.join(table.unreadable)}: MATLAB objects or malformed structs)"
    text = _text_hint(table, refused)
    if text:   # the column is there, but as words: say so rather than that it is missing
        raise PendcError(f"{table.source}: missing column(s) {', '.join(refused)}: {text}")
    raise PendcError(f"{table.source}: missing column(s) {', '.join(refused)} (columns: {', '.join(names)}); map "
                     f"with --columns NAME=FILE_NAME{why}")
