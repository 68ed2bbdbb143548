"""Independent tasks on Dask: each result computed wherever the cluster has a core, kept as it finishes.

A task is a picklable function and its arguments, keyed by an index; its result is a JSON-able
dict. :func:`run_tasks` runs every index whose result the results folder does not hold yet and
writes each result, atomically, to ``NNNNNNN.json`` in that folder the moment its task finishes.
So a resume (the same call again) runs only what is missing, no task twice and none lost, and
Ctrl-C cancels what is queued and keeps every finished result.

Distribution, scheduling and retries are Dask distributed's: a :class:`distributed.LocalCluster`
of single-threaded worker processes on this machine's cores when no scheduler is given, else a
``distributed.Client`` on ``--scheduler tcp://HOST:PORT`` (any cluster: dask-jobqueue,
dask-kubernetes, ``dask scheduler`` by hand), with no other difference. A task that a dying worker
takes with it runs again elsewhere (Dask's reassignment, and ``RETRIES`` more attempts on each
task). A task Dask gives up on goes to the caller's ``on_failure``: a result to keep (``pendc
robust``: a failed row), or nothing, so that a resume runs it again.
"""

from __future__ import annotations

import json
import logging
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable

from ..atomic import write_atomic
from ..errors import PendcError

RETRIES = 2            # extra attempts Dask gives a task whose worker died under it (or that raised)


@dataclass(frozen=True)
class Task:
    """One unit of work: ``fn(*args)``, run on some worker, returns a JSON-able dict."""

    fn: Callable
    args: tuple = ()


@dataclass(frozen=True)
class TasksOutcome:
    """How a run ended: every kept result (by index, earlier runs' too), how many ran now, the
    tasks Dask gave up on and nobody kept (index -> message), wall time, workers, where."""

    results: dict
    ran_now: int
    wall_s: float
    workers: int
    interrupted: bool
    scheduler: str
    failed: dict = field(default_factory=dict)


def result_path(folder: str | os.PathLike, index: int) -> Path:
    """The file that holds the result of task ``index``."""
    return Path(folder) / f"{index:07d}.json"


def read_results(folder: str | os.PathLike, indices: Iterable[int]) -> dict:
    """{index: result} of every finished task of ``indices`` in ``folder``; a file that does not
    read (torn by hand, another index's, not a task's) is no result, so its task runs again."""
    wanted = set(indices)
    out = {}
    folder = Path(folder)
    if not folder.is_dir():
        return out
    for path in folder.glob("*.json"):
        try:
            result = json.loads(path.read_text())
            index = int(result["index"])
        except (ValueError, KeyError, TypeError, OSError):
            continue
        if index in wanted and path.name == result_path(folder, index).name:
            out[index] = result
    return out


CONNECT_S = 10      # how long a --scheduler address may take to answer


def _unreachable(scheduler: str) -> str | None:
    """Why a ``tcp://`` scheduler address cannot be connected to, else None. Dask's client
    retries a refused address until its timeout: a mistyped port would cost CONNECT_S of waiting
    for an answer the machine gave at once (the scheduler logs the probe's connection at INFO
    level, closed before a handshake). Anything else (a host that does not resolve, another
    protocol) is left to Dask's own connect and its message."""
    import socket
    from urllib.parse import urlsplit

    try:
        parts = urlsplit(scheduler)
        host, port = parts.hostname, parts.port
    except ValueError:
        return None
    if parts.scheme != "tcp" or not host or port is None:
        return None
    try:
        with socket.create_connection((host, port), timeout=CONNECT_S):
            return None
    except ConnectionRefusedError:
        return "connection refused"
    except TimeoutError:
        return f"no answer in {CONNECT_S} s"     # Dask's connect would wait as long again
    except OSError:
        return None


def open_client(scheduler: str | None, workers: int | None):
    """(client, cluster): a client on ``scheduler``, else on a new LocalCluster of ``workers``
    single-threaded processes (default one per core; ``cluster`` is None for a scheduler's)."""
    from distributed import Client, LocalCluster

    if scheduler:
        unreachable = _unreachable(scheduler)
        if unreachable:
            raise PendcError(f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({unreachable})")
        try:
            return Client(scheduler, timeout=f"{CONNECT_S}s"), None
        except (OSError, TimeoutError, ValueError) as exc:
            raise PendcError(f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({exc})") from None
    n = workers or os.cpu_count() or 1
    # one thread per worker: the tasks are numba loops, simulators and Python; processes, not threads
    # the workers' own logs stay quiet: a task's failure reaches the caller through its future, and a
    # worker still heartbeating while the cluster closes would print a connection traceback
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                           silence_logs=logging.CRITICAL)
    return Client(cluster), cluster


def _progress_bar(total: int, initial: int, unit: str, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit=unit, disable=not (enabled and sys.stderr.isatty()),
                file=sys.stderr, dynamic_ncols=True)


def _submit(client, tasks: list, key: str) -> dict:
    """{future: index} of ``tasks`` ([(index, Task)]), one ``client.map`` per function and arity
    (a map is one message to the scheduler, a submit per task thousands of them)."""
    groups: dict = {}
    for index, task in tasks:
        groups.setdefault((task.fn, len(task.args)), []).append((index, task.args))
    index_of = {}
    for (fn, arity), members in groups.items():
        columns = [[args[k] for _, args in members] for k in range(arity)]
        keys = [f"{key}-{index}" for index, _ in members]
        if arity:
            futures = client.map(fn, *columns, key=keys, pure=False, retries=RETRIES)
        else:
            futures = [client.submit(fn, key=k, pure=False, retries=RETRIES) for k in keys]
        index_of.update({f: index for f, (index, _) in zip(futures, members)})
    return index_of


def run_tasks(task_of: Callable[[int], Task], indices: Iterable[int], folder: str | os.PathLike, key: str,
              scheduler: str | None = None, workers: int | None = None, progress: bool = True,
              unit: str = "task", on_failure: Callable | None = None, keep: Callable | None = None,
              after: Callable | None = None, upload: Iterable = (), on_start: Callable | None = None,
              stop_after: int | None = None) -> TasksOutcome:
    """Run ``task_of(i)`` for every ``i`` of ``indices`` whose result ``folder`` does not hold.

    ``key`` names the run on the scheduler (task ``i`` is ``key-i``: two runs on one cluster must
    differ in it). As each task finishes, ``keep(index, result)`` (if given) returns what is kept
    (e.g. the result without the files it carried, written elsewhere), that is written to
    ``folder``, and ``after(index, kept, results)`` (if given) may return a status line, printed
    on standard error above the progress bar. ``on_failure(index, exc)`` turns a task Dask gave up on into a result to
    keep, or None (kept nowhere: listed in ``failed``, run again by a resume). ``upload`` names
    ``.py`` files every worker needs importable (a remote worker has only what is installed).
    ``on_start(workers)`` (if given) runs once the cluster answers, before any task is sent (what
    a run writes or prints before its work; nothing, if the scheduler cannot be reached).
    ``stop_after`` ends the run as Ctrl-C would once that many tasks finished (for tests)."""
    from distributed import as_completed

    folder = Path(folder)
    indices = list(indices)
    done = read_results(folder, indices)
    missing = [i for i in indices if i not in done]
    start = time.perf_counter()
    interrupted, ran, n_workers, where, failed = False, 0, 0, scheduler or "LocalCluster", {}
    if missing:
        client, cluster = open_client(scheduler, workers)
        futures: dict = {}
        try:
            n_workers = len(client.scheduler_info(n_workers=-1).get("workers", {})) or (workers or 0)
            if on_start:
                on_start(n_workers)
            folder.mkdir(parents=True, exist_ok=True)
            for path in upload:
                client.upload_file(str(path), load=False)   # into each worker's folder on its sys.path
            futures = _submit(client, [(i, task_of(i)) for i in missing], key)
            with _progress_bar(len(indices), len(done), unit, progress) as bar:
                for future in as_completed(list(futures)):
                    index = futures[future]
                    try:
                        result = future.result()
                    except Exception as exc:   # noqa: BLE001 -- Dask's failure of one task ends that task, not the run
                        result = on_failure(index, exc) if on_failure else None
                        if result is None:
                            failed[index] = f"{type(exc).__name__}: {exc}".splitlines()[0]
                    if result is not None:
                        kept = {"index": index, **(keep(index, result) if keep else result)}
                        write_atomic(result_path(folder, index), json.dumps(kept) + "\n")
                        done[index] = kept
                        line = after(index, kept, done) if after else None
                        if line:
                            bar.write(line, file=sys.stderr)
                    ran += 1
                    bar.update(1)
                    if stop_after is not None and ran >= stop_after:
                        raise KeyboardInterrupt
        except KeyboardInterrupt:
            interrupted = True
        finally:
            if futures:
                client.cancel(list(futures))
            client.close()
            if cluster is not None:
                cluster.close()
    return TasksOutcome(results={i: done[i] for i in sorted(done)}, ran_now=ran,
                        wall_s=time.perf_counter() - start, workers=n_workers, interrupted=interrupted,
                        scheduler=where, failed=failed)
