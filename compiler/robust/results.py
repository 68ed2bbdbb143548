"""What a sweep leaves: the rows (Parquet through pyarrow, CSV beside it), the summary JSON and the
worst runs with the command that replays each alone.

Rows are sorted by index and their columns fixed (index, the varied parameters, passed, failures,
error, the scenario's figures), so the same sweep writes the same files whatever ran it. The
success rate's 95 % interval is Wilson's score interval (right at 0 and 1, unlike the normal
approximation). Every file is written whole through a temporary file and a rename. Imports
pyarrow, numpy and the robust package.
"""

from __future__ import annotations

import io
import json
import math
import shlex
from pathlib import Path

import numpy as np

from ..atomic import write_atomic, write_bytes_atomic
from .sampling import SamplePlan
from .scenario_runner import CRITERION_FIGURE, FIGURES, SweepSpec

Z95 = 1.959963984540054
WORST_SHOWN = 5
ROW_FILES = ("rows.parquet", "rows.csv")
LIMIT_RATIO = "closeness to the limits (max of worst |angle - pi| / 0.05 rad and max travel / 0.3; 1 = at a limit)"


def wilson_interval(successes: int, trials: int, z: float = Z95) -> tuple:
    """Wilson's score interval of a binomial proportion ((nan, nan) for no trials)."""
    if trials == 0:
        return (math.nan, math.nan)
    p = successes / trials
    centre = (p + z * z / (2 * trials)) / (1 + z * z / trials)
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / (1 + z * z / trials)
    # at 0 and n successes the bound is exactly 0 (1); rounding would leave 1e-17 of it
    return (0.0 if successes == 0 else max(0.0, centre - half), 1.0 if successes == trials else min(1.0, centre + half))


def columns_of(rows: list, plan: SamplePlan) -> list:
    """The fixed column order: index, parameters, outcome, the figures, then every max |state|."""
    extra = sorted({k for r in rows for k in r if k.startswith("max_abs_")})
    return ["index", *plan.names, "passed", "failures", "error", *FIGURES, *extra]


def rows_table(rows: list, plan: SamplePlan):
    """The rows as a pyarrow Table, sorted by index, in :func:`columns_of` order."""
    import pyarrow as pa

    rows = sorted(rows, key=lambda r: r["index"])
    cols = columns_of(rows, plan)
    types = {"index": pa.int64(), "passed": pa.bool_(), "failures": pa.string(), "error": pa.string(),
             "switches": pa.int64()}
    arrays = {c: pa.array([r.get(c) for r in rows], type=types.get(c, pa.float64())) for c in cols}
    return pa.table(arrays)


def write_rows(folder: Path, rows: list, plan: SamplePlan) -> None:
    """``rows.parquet`` and ``rows.csv`` in ``folder``."""
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    table = rows_table(rows, plan)
    buf = io.BytesIO()
    pq.write_table(table, buf)
    write_bytes_atomic(folder / "rows.parquet", buf.getvalue())
    buf = io.BytesIO()
    pacsv.write_csv(table, buf)
    write_bytes_atomic(folder / "rows.csv", buf.getvalue())


def replay_command(folder, index: int) -> str:
    """The command that runs ``index`` alone and writes its full record."""
    return f"pendc robust --resume {shlex.quote(str(folder))} --replay {index}"


def badness(row: dict, figure: str) -> tuple:
    """Sort key, worst first: a run that raised, then a failed one, each by its criterion figure."""
    value = row.get(figure)
    value = math.inf if value is None else float(value)
    return (0 if row.get("error") else 1 if not row.get("passed") else 2, -value, row["index"])


def worst_runs(rows: list, spec: SweepSpec, plan: SamplePlan, folder, count: int = WORST_SHOWN) -> list:
    """The ``count`` worst runs: index, parameters, why, and the command replaying each."""
    figure = CRITERION_FIGURE[spec.scenario]
    out = []
    for row in sorted(rows, key=lambda r: badness(r, figure))[:count]:
        why = row.get("error") or row.get("failures") or "passed"
        out.append({"index": row["index"], "passed": bool(row.get("passed")), "why": why,
                    figure: row.get(figure), "parameters": {n: row[n] for n in plan.names},
                    "replay": replay_command(folder, row["index"])})
    return out


def summarize(rows: list, spec: SweepSpec, plan: SamplePlan, folder, ranking, outcome) -> dict:
    """The summary JSON: success rate and its Wilson 95 % interval, the ranking, the worst runs."""
    n = len(rows)
    passed = sum(1 for r in rows if r.get("passed"))
    lo, hi = wilson_interval(passed, n)
    return {
        "model": spec.model_source, "design": spec.design_source, "controller": spec.controller,
        "scenario": spec.scenario, "plant": spec.plant, "seconds": spec.seconds,
        "samples": plan.count, "finished": n, "complete": n == plan.count,
        "passed": passed, "failed": n - passed, "raised": sum(1 for r in rows if r.get("error")),
        "success_rate": passed / n if n else None,
        "success_rate_95": [lo, hi] if n else None,
        "method": plan.method, "seed": plan.seed, "varied": plan.describe(), "drawn_from": plan.origin,
        "most_important": ranking.top if ranking else None,
        "sensitivity": None if ranking is None else {
            "method": "SALib rbd_fast first-order index", "outcome": ranking.outcome,
            "ranking": [{"parameter": p, "S1": s, "S1_conf95": c} for p, s, c in ranking.entries]},
        "worst_runs": worst_runs(rows, spec, plan, folder),
        "wall_s": round(outcome.wall_s, 3) if outcome is not None else None,
        "ran_now": outcome.ran_now if outcome is not None else 0,
        "workers": outcome.workers if outcome is not None else None,
        "scheduler": outcome.scheduler if outcome is not None else None,
        "runs_per_s": (round(outcome.ran_now / outcome.wall_s, 4)
                       if outcome is not None and outcome.wall_s > 0 and outcome.ran_now else None),
    }


def rank_rows(rows: list, spec: SweepSpec, plan: SamplePlan):
    """The sensitivity ranking of finished ``rows`` (see :mod:`pendc.robust.sensitivity`)."""
    from .sensitivity import rank_parameters

    if not rows:
        return None
    X = np.array([[r[n] for n in plan.names] for r in rows], dtype=float)
    failed = np.array([not r.get("passed") for r in rows])
    if spec.scenario == "swing_up_balance":
        figure_name = LIMIT_RATIO
        figure = np.array([limit_ratio(r) for r in rows], dtype=float)
    else:
        figure_name = CRITERION_FIGURE[spec.scenario]
        figure = np.array([np.nan if r.get(figure_name) is None else r[figure_name] for r in rows], dtype=float)
    return rank_parameters(list(plan.names), X, failed, figure, figure_name, seed=plan.seed)


def limit_ratio(row: dict) -> float:
    """How close a swing-up-and-balance run came to its criterion's limits: the larger of its worst
    angle from the upright over the last 3 s / the tolerance and its ``travel_ratio`` (the driven
    position's largest |value| / the track limit; 1: at a limit), capped at 2 so that a pendulum
    that never came up does not outweigh every other run; NaN for a run that raised."""
    from ..hil.loop import UPRIGHT_TOLERANCE

    worst, travel = row.get("worst_last_3s_rad"), row.get("travel_ratio")
    if worst is None or travel is None:
        return math.nan
    return min(2.0, max(worst / UPRIGHT_TOLERANCE, travel))


def write_results(folder, rows: list, spec: SweepSpec, plan: SamplePlan, outcome=None) -> dict:
    """Rows, ``summary.json`` and ``report.html`` in ``folder``; returns the summary."""
    from .report import write_report

    folder = Path(folder)
    rows = sorted(rows, key=lambda r: r["index"])
    ranking = rank_rows(rows, spec, plan)
    summary = summarize(rows, spec, plan, folder, ranking, outcome)
    write_rows(folder, rows, plan)
    write_atomic(folder / "summary.json", json.dumps(summary, indent=2) + "\n")
    write_report(folder / "report.html", rows, spec, plan, summary, ranking)
    return summary
