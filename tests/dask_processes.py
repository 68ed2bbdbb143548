"""A real Dask cluster for tests: a ``dask scheduler`` and ``dask worker`` processes, as a user starts them.

``dask_cluster`` starts the scheduler on a free port (its address read from the scheduler file it
writes), then the workers (single-threaded, no nanny: a killed worker stays dead), yields the
address and the worker processes, and stops every process it started.
"""

import contextlib
import json
import signal
import subprocess
import sys
import time

from robust_helpers import ROOT

SCHEDULER = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
WORKER = [sys.executable, "-m", "distributed.cli.dask_worker"]


def _start(cmd, cwd):
    return subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


@contextlib.contextmanager
def dask_cluster(tmp_path, workers: int = 2, cwd=ROOT):
    """(scheduler address, [worker processes]) of a scheduler and ``workers`` workers started as processes."""
    info = tmp_path / "scheduler.json"
    procs = [_start([*SCHEDULER, "--scheduler-file", str(info), "--port", "0", "--no-dashboard"], tmp_path)]
    try:
        for _ in range(300):
            if info.exists() and info.stat().st_size:
                break
            time.sleep(0.1)
        address = json.loads(info.read_text())["address"]
        started = [_start([*WORKER, "--scheduler-file", str(info), "--nthreads", "1", "--no-nanny",
                           "--no-dashboard"], cwd) for _ in range(workers)]
        procs += started
        yield address, started
    finally:
        for p in procs:
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()
