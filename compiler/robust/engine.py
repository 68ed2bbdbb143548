"""The sweep on Dask: a row per run, computed wherever the cluster has a core, kept as it finishes.

Distribution, scheduling and retries are Dask distributed's: a :class:`distributed.LocalCluster`
on this machine's cores when no scheduler is given, else a ``distributed.Client`` on
``--scheduler tcp://HOST:PORT`` (any cluster: dask-jobqueue, dask-kubernetes, ``dask scheduler``
by hand), with no other difference. A task that a dying worker takes with it runs again elsewhere
(Dask's); a run that raises is already a failed row (:func:`~pendc.robust.scenario_runner.run_row`).

A sweep folder holds ``sweep.json`` (the spec and the sample plan: what a resume and a replay
read) and ``rows/`` (one JSON file per finished run, written atomically as its task completes).
Ctrl-C cancels what is left and keeps every finished row; ``--resume DIR`` runs only the indices
without a row. Rows are a function of (plan, index) alone, so the same seed gives the same rows on
any number of workers. Imports dask.distributed, tqdm and the robust package.
"""

from __future__ import annotations

import json
import logging
import os
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from ..atomic import write_atomic
from ..errors import PendcError
from .sampling import SamplePlan, plan_from_dict, plan_to_dict
from .scenario_runner import SweepSpec, run_row

MANIFEST = "sweep.json"
ROWS = "rows"
RETRIES = 2            # extra attempts Dask gives a task whose worker died under it
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
    return Path(folder) / ROWS / f"{index:07d}.json"


def read_rows(folder: str | os.PathLike, count: int) -> dict:
    """{index: row} of every finished run in ``folder`` (a file that does not read is run again)."""
    out = {}
    rows = Path(folder) / ROWS
    if not rows.is_dir():
        return out
    for path in rows.glob("*.json"):
        try:
            row = json.loads(path.read_text())
            index = int(row["index"])
        except (ValueError, KeyError, TypeError, OSError):
            continue
        if 0 <= index < count and path.name == f"{index:07d}.json":
            out[index] = row
    return out


def _client(scheduler: str | None, workers: int | None):
    """A Dask client: on ``scheduler``, else on a new LocalCluster of ``workers`` single-threaded processes."""
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            return Client(scheduler, timeout="10s"), None
        except (OSError, TimeoutError, ValueError) as exc:
            raise PendcError(f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({exc})") from None
    n = workers or os.cpu_count() or 1
    # one thread per worker: the kernels are numba loops, the controller Python; processes, not threads
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                           silence_logs=logging.ERROR)
    return Client(cluster), cluster


def _row_of(future, index: int, plan: SamplePlan, design) -> dict:
    """The row a finished future holds; a task Dask gave up on (its workers kept dying under it,
    ``KilledWorker``) is a failed row with that message."""
    try:
        return future.result()
    except Exception as exc:   # noqa: BLE001 -- Dask's own failure of one task ends that run, not the sweep
        from .scenario_runner import FIGURES
        return {"index": index, **plan.params_of(index, design), **{f: None for f in FIGURES},
                "passed": False, "failures": "", "error": f"{type(exc).__name__}: {exc}".splitlines()[0]}


def _progress_bar(total: int, initial: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="run", disable=not (enabled and sys.stderr.isatty()),
                file=sys.stderr, dynamic_ncols=True)


def run_sweep(spec: SweepSpec, plan: SamplePlan, folder: str | os.PathLike, scheduler: str | None = None,
              workers: int | None = None, progress: bool = True, stop_after: int | None = None) -> SweepOutcome:
    """Run every index of ``plan`` that ``folder`` holds no row of; write each row as it finishes.

    ``stop_after`` ends the sweep as Ctrl-C would once that many rows finished in this call (for
    tests of an interrupted sweep)."""
    from distributed import as_completed

    folder = Path(folder)
    done = read_rows(folder, plan.count)
    missing = [i for i in range(plan.count) if i not in done]
    design = plan.design()
    start = time.perf_counter()
    interrupted, ran, n_workers, where = False, 0, 0, scheduler or "LocalCluster"
    if missing:
        client, cluster = _client(scheduler, workers)
        futures = []
        try:
            n_workers = len(client.scheduler_info(n_workers=-1).get("workers", {})) or (workers or 0)
            futures = client.map(run_row, [spec] * len(missing), missing,
                                 [plan.params_of(i, design) for i in missing],
                                 key=[f"pendc-robust-{spec.fingerprint}-{plan.seed}-{i}" for i in missing],
                                 pure=False, retries=RETRIES)
            with _progress_bar(plan.count, len(done), progress) as bar:
                index_of = {f.key: i for f, i in zip(futures, missing)}
                for future in as_completed(futures):
                    row = _row_of(future, index_of[future.key], plan, design)
                    write_atomic(row_path(folder, row["index"]), json.dumps(row) + "\n")
                    done[row["index"]] = row
                    ran += 1
                    bar.update(1)
                    if stop_after is not None and ran >= stop_after:
                        raise KeyboardInterrupt
        except KeyboardInterrupt:
            interrupted = True
        finally:
            if futures:
                client.cancel(futures)
            client.close()
            if cluster is not None:
                cluster.close()
    rows = [done[i] for i in sorted(done)]
    return SweepOutcome(rows=rows, ran_now=ran, wall_s=time.perf_counter() - start, workers=n_workers,
                        interrupted=interrupted, scheduler=where)
