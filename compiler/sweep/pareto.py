"""The Pareto table of ``pendc explore``: step time against DSP multipliers and LUTs.

A row (design point) is Pareto-optimal when no other row is at least as good in all three (step
time, DSP blocks, LUTs) and better in one: the points worth choosing between, each the cheapest
for its speed. The step time is the routed one (``ii / Fmax``) where the target has an open
place-and-route that succeeded, else the scheduler's estimate, marked as such (``est.``): a
routed and an estimated figure are compared as they stand. A row that failed, has no step time,
or does not fit its part (too few multipliers, LUTs or block RAMs) takes no part.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

from ..atomic import write_atomic, write_bytes_atomic

COLUMNS = ("index", "target", "schedule", "ii", "fmax_mhz", "step_time_ns", "step_source", "step_ns",
           "estimated_step_ns", "dsp", "lut", "ff", "carry", "bram", "logic_depth", "pareto", "fits", "misfit",
           "fmax_bound", "real_time", "error", "build", "design_hash", "pnr_note")
OBJECTIVES = ("step_time_ns", "dsp", "lut")


def _comparable(row: dict) -> bool:
    # a design the part cannot hold is no choice, however fast its estimate
    return (not row.get("error") and row.get("fits") is not False
            and all(row.get(k) is not None for k in OBJECTIVES))


def dominates(a: dict, b: dict) -> bool:
    """``a`` is at least as good as ``b`` in every objective and better in one."""
    pairs = [(a[k], b[k]) for k in OBJECTIVES]
    return all(x <= y for x, y in pairs) and any(x < y for x, y in pairs)


def pareto_rows(rows: list) -> list:
    """Every row with ``pareto`` set (True for the non-dominated comparable rows), sorted: the
    comparable rows by step time, then DSP blocks, then LUTs, then the others by index."""
    comparable = [r for r in rows if _comparable(r)]
    out = [{**r, "pareto": _comparable(r) and not any(dominates(o, r) for o in comparable if o is not r)}
           for r in rows]
    return sorted(out, key=lambda r: (0, *(r[k] for k in OBJECTIVES), r["index"]) if _comparable(r)
                  else (1, 0, 0, 0, r["index"]))


def _cell(value, digits: int = 1) -> str:
    if value is None:
        return "-"
    return f"{value:.{digits}f}" if isinstance(value, float) else str(value)


def format_table(rows: list) -> str:
    """The text table: one line per design point, ``*`` on the Pareto-optimal ones, failures last."""
    head = f"{'':2s}{'target':12s} {'schedule':14s} {'ii':>4s} {'Fmax MHz':>9s} {'step ns':>12s} {'DSP':>5s} {'LUT':>7s} {'FF':>7s}"
    lines = [head]
    for r in rows:
        if r.get("error"):
            lines.append(f"{'':2s}{r['target']:12s} {r['schedule']:14s} failed: {r['error']}")
            continue
        step = _cell(r["step_time_ns"]) + (" est." if r["step_source"] == "estimated" else "     ")
        note = (f"  does not fit: {r.get('misfit')}" if r.get("fits") is False
                else "  Fmax an upper bound" if r.get("fmax_bound") == "upper" else "")
        lines.append(f"{'*' if r['pareto'] else ' ':2s}{r['target']:12s} {r['schedule']:14s} {_cell(r['ii']):>4s} "
                     f"{_cell(r['fmax_mhz']):>9s} {step:>12s} {_cell(r['dsp']):>5s} {_cell(r['lut']):>7s} "
                     f"{_cell(r['ff']):>7s}{note}")
    return "\n".join(lines) + "\n"


def write_table(folder: Path, rows: list, meta: dict) -> list:
    """``pareto.json`` (``meta`` and the rows), ``pareto.csv`` and, when pyarrow is installed,
    ``pareto.parquet``; the names written."""
    write_atomic(folder / "pareto.json", json.dumps({**meta, "rows": rows}, indent=1) + "\n")
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    write_atomic(folder / "pareto.csv", buf.getvalue())
    written = ["pareto.json", "pareto.csv"]
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:          # Parquet is optional: the JSON and CSV hold the same table
        return written
    table = pa.Table.from_pylist([{c: r.get(c) for c in COLUMNS} for r in rows], schema=_schema(pa))
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    write_bytes_atomic(folder / "pareto.parquet", sink.getvalue().to_pybytes())
    return written + ["pareto.parquet"]


def _schema(pa):
    """Typed columns, so a column that is empty in this sweep (no routed Fmax) still has its type."""
    types = {"index": pa.int64(), "ii": pa.int64(), "dsp": pa.int64(), "lut": pa.int64(), "ff": pa.int64(),
             "carry": pa.int64(), "logic_depth": pa.int64(), "pareto": pa.bool_(), "fmax_mhz": pa.float64(),
             "step_time_ns": pa.float64(), "step_ns": pa.float64(), "estimated_step_ns": pa.float64(),
             "bram": pa.float64(), "fits": pa.bool_(), "real_time": pa.bool_()}
    return pa.schema([(c, types.get(c, pa.string())) for c in COLUMNS])
