"""Measurement files (spec §6): reading a :class:`Measurement` (:mod:`.measured_run`), writing CSV.

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

import numpy as np

from ..atomic import write_atomic
from ..errors import PendcError
from .csvread import read_csv_table
from .measured_run import FIT_WINDOW, Measurement  # noqa: F401 (re-exported: the public name's home)
from .readers import ReadOptions, build_measurement, read_table

REQUIRED = None   # the plant's time, input and positions (as its interface names them)
_KEY = r"[A-Za-z_][\w.\-]*"


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
