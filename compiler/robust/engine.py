"""The robust sweep on Dask: a row per run, computed wherever the cluster has a core, kept as it finishes.

The distribution is :mod:`pendc.sweep.engine`'s (a LocalCluster on this machine's cores, or any
Dask scheduler with ``--scheduler tcp://HOST:PORT``; retries when a worker dies; one file per
finished task; resume; Ctrl-C keeps what finished): a run is one task, ``run_row`` on one sampled
plant. A run that raises is already a failed row (:func:`~pendc.robust.scenario_runner.run_row`),
and so is a run Dask gave up on (its workers kept dying): both are kept, never run again.

A sweep folder holds ``sweep.json`` (the spec and the sample plan: what a resume and a replay
read) and ``rows/`` (one JSON file per finished run, written atomically as its task completes).
Ctrl-C cancels what is left and keeps every finished row; ``--resume DIR`` runs only the indices
without a row. Rows are a function of (plan, index) alone, so the same seed gives the same rows on
any number of workers. Imports the sweep engine and the robust package.
"""
from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path

from ..atomic import write_atomic
from ..errors import PendcError
from ..sweep.engine import Task, read_results, result_path, run_tasks
from .sampling import SamplePlan, plan_from_dict, plan_to_dict
from .scenario_runner import SweepSpec, run_row

MANIFEST = "sweep.json"
ROWS = "rows"
MANIFEST_VERSION = 1


@dataclass(frozen=True)
class SweepOutcome:
    """How a sweep ended: every finished row (by index), what ran now, the wall time, the workers."""

    rows: list
    ran_now: int
    wall_s: float
    workers: int
    interrupted: bool
    scheduler: str


def write_manifest(folder: Path, spec: SweepSpec, plan: SamplePlan) -> None:
    """``sweep.json``: what the sweep is, for a resume or a replay."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / ROWS).mkdir(exist_ok=True)
    data = {"version": MANIFEST_VERSION, "spec": asdict(spec), "plan": plan_to_dict(plan)}
    write_atomic(folder / MANIFEST, json.dumps(data, indent=1) + "\n")


def read_manifest(folder: str | os.PathLike) -> tuple[SweepSpec, SamplePlan]:
    """The spec and plan of the sweep in ``folder`` (a one-line error if it holds none)."""
    path = Path(folder) / MANIFEST
    if not path.is_file():
        raise PendcError(f"{folder}: not a sweep folder (no {MANIFEST}; pendc robust --out DIR makes one)")
    try:
        data = json.loads(path.read_text())
        if data.get("version") != MANIFEST_VERSION:
            raise ValueError(f"version {data.get('version')!r}, this pendc reads {MANIFEST_VERSION}")
        return SweepSpec(**data["spec"]), plan_from_dict(data["plan"])
    except (ValueError, KeyError, TypeError) as exc:
        raise PendcError(f"{path}: not a sweep manifest pendc can read ({exc})") from None


def row_path(folder: Path, index: int) -> Path:
    return result_path(Path(folder) / ROWS, index)


def read_rows(folder: str | os.PathLike, count: int) -> dict:
    """{index: row} of every finished run in ``folder`` (a file that does not read is run again)."""
    return read_results(Path(folder) / ROWS, range(count))


def _failed_row(plan: SamplePlan, design):
    """A task Dask gave up on (its workers kept dying under it, ``KilledWorker``) is a failed row
    with that message: kept, as a run that raised is."""
    from .scenario_runner import FIGURES

    def row(index: int, exc: BaseException) -> dict:
        return {"index": index, **plan.params_of(index, design), **{f: None for f in FIGURES},
                "passed": False, "failures": "", "error": f"{type(exc).__name__}: {exc}".splitlines()[0]}
    return row


def run_sweep(spec: SweepSpec, plan: SamplePlan, folder: str | os.PathLike, scheduler: str | None = None,
              workers: int | None = None, progress: bool = True, stop_after: int | None = None) -> SweepOutcome:
    """Run every index of ``plan`` that ``folder`` holds no row of; write each row as it finishes.

    ``stop_after`` ends the sweep as Ctrl-C would once that many rows finished in this call (for
    tests of an interrupted sweep)."""
    design = plan.design()
    outcome = run_tasks(lambda i: Task(run_row, (spec, i, plan.params_of(i, design))), range(plan.count),
                        Path(folder) / ROWS, key=f"pendc-robust-{spec.fingerprint}-{plan.seed}",
                        scheduler=scheduler, workers=workers, progress=progress, unit="run",
                        on_failure=_failed_row(plan, design), stop_after=stop_after)
    return SweepOutcome(rows=list(outcome.results.values()), ran_now=outcome.ran_now, wall_s=outcome.wall_s,
                        workers=outcome.workers, interrupted=outcome.interrupted, scheduler=outcome.scheduler)
