"""Measurement files (spec §6): the :class:`Measurement`, reading it, writing CSV.

pendc's own format is UTF-8 text: optional leading ``#`` comment lines, one header
row naming the columns, then comma-separated numeric rows (blank lines only at the
end). Comment lines shaped ``# key: value`` (key without spaces) become metadata;
other comments are free-form and ignored. Other labs' files (other names,
separators, units, MATLAB .mat, other sample rates) are read through
:class:`~pendc.sim.readers.ReadOptions` (see :mod:`pendc.sim.readers`). Every
problem is reported as one-line :class:`~pendc.errors.PendcError` naming the file
and, where possible, the line and the column.
"""

from __future__ import annotations

import io
import os
import re
from dataclasses import dataclass, field

import numpy as np

from ..atomic import write_atomic
from ..errors import PendcError
from .csvread import read_csv_table
from .readers import ReadOptions, build_measurement, read_table
from .signals import PlantSignals, signals_of

REQUIRED = None   # the plant's time, input and positions (as its interface names them)
_KEY = r"[A-Za-z_][\w.\-]*"
FIT_WINDOW = 0.010  # s, for initial_state's velocity estimate


@dataclass(frozen=True, eq=False)
class Measurement:
    """One measured run; arrays are float64 and read-only (``columns`` holds them all).

    ``experiment`` says what was held or removed (the simulation honours it);
    ``resolution`` maps a column to its measurement step (the encoder count or the
    quantisation, given or estimated; absent when unknown); ``missing`` lists the axes
    the file did not have, which hold a constant; ``notes`` say what the reader did
    (resampling, filling, unwrapping), one line each.
    """

    t: np.ndarray
    u: np.ndarray
    columns: dict
    meta: dict
    source: str = "<string>"
    warnings: tuple = ()
    first_line: int = field(default=0, repr=False)  # file line of row 0, for messages
    experiment: str = "free"    # a name of pendc.model.experiments.EXPERIMENTS
    resolution: dict = field(default_factory=dict)  # column -> quantisation step (given or estimated)
    missing: tuple = ()         # axes absent from the file, filled with a constant
    notes: tuple = ()           # what was done to the data (resampling, filling), one line each
    signals: PlantSignals = None  # the plant whose signals the columns are (None: the default model)

    @property
    def plant(self) -> PlantSignals:
        """The signals of the plant the file was read for."""
        return signals_of(self.signals)

    def column(self, name: str) -> np.ndarray:
        """The column called ``name``; PendcError if it is absent or not finite."""
        if name not in self.columns:
            raise PendcError(f"{self.source}: no column '{name}' (columns: {', '.join(self.columns)})")
        values = self.columns[name]
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            k = int(bad[0])
            where = f"line {self.first_line + k}" if self.first_line else f"row {k}"
            raise PendcError(f"{self.source}: {where}: column '{name}' is {values[k]} ({bad.size} non-finite "
                             f"value(s); NaN and inf are not allowed)")
        return values

    def __getattr__(self, name: str):
        """A plant signal by name (``m.<position>``): its column, or None when the file has none."""
        if name.startswith("_") or name in ("columns", "signals"):
            raise AttributeError(name)
        if name in self.columns:
            return self.columns[name]
        if name in self.plant.all_columns:
            return None
        raise AttributeError(f"'Measurement' has no attribute or signal '{name}'")

    def initial_state(self) -> tuple:
        """The plant's reported state at ``t[0]`` (each position and its rate, in the
        interface's order), for starting a simulation from the data.

        Positions come from the first row; an absent position column counts as 0 (the
        spec's default initial state). Velocities come from their rate columns
        (``d<position>``) when present; otherwise they are the slope of a least-squares line
        through the samples of the first ``FIT_WINDOW`` (10 ms) of the position, and at
        least 3 samples, which averages out the encoder quantisation that a plain
        first difference would amplify. With fewer than 2 samples the velocity is 0.
        """
        t = self.t
        n = max(3, int(np.searchsorted(t, t[0] + FIT_WINDOW, side="right")))
        sig = self.plant
        state = dict.fromkeys(sig.mechanical, 0.0)
        for pos in sig.positions:
            vel = sig.rate(pos)
            p = self.columns.get(pos)
            v = self.columns.get(vel) if vel is not None else None
            state[pos] = float(p[0]) if p is not None else 0.0
            if vel is None:
                continue
            if v is not None:
                state[vel] = float(v[0])
            elif p is not None and len(t) >= 2:
                state[vel] = float(np.polyfit(t[:n] - t[0], p[:n], 1)[0])
        return tuple(state.values())


def read_measurements(path: str | os.PathLike, required=REQUIRED, options: ReadOptions | None = None) -> Measurement:
    """Read and check a measurement file: CSV-like text, ``-`` for standard input, or .mat.

    ``options`` (:class:`~pendc.sim.readers.ReadOptions`) maps other names, units,
    experiments and sample rates; without it the file must be in pendc's own format
    and is read faithfully (no resampling). See :func:`parse_measurements` for the checks.
    """
    return build_measurement(read_table(path, options or ReadOptions()), options or ReadOptions(), required)


def parse_measurements(text: str, source: str = "<string>", required=REQUIRED,
                       options: ReadOptions | None = None) -> Measurement:
    """Parse measurement-file text and check it.

    ``t`` and ``u`` are always required, plus the names in ``required`` (unless the
    experiment or ``options.allow_missing`` lets an axis be absent: it is then filled
    and listed in ``missing``). Errors: malformed rows, missing or duplicate columns,
    NaN/inf in a known column (``required``, time, input, positions and rates), time not
    strictly increasing or jumping by an outlier, angles in degrees, and with
    ``options.plausible`` the rig's limits (:mod:`pendc.sim.plausibility`: outliers,
    milliseconds, millimetres, millivolts). Voltages outside 0-10 V only add an entry
    to ``warnings``.
    """
    options = options or ReadOptions()
    table = read_csv_table(io.BytesIO(text.encode("utf-8")), source, options.separator, options.decimal)  # str: utf-8
    return build_measurement(table, options, required)


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
