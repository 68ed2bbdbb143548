"""pendc.robust.engine: the sweep on Dask, its faults and its determinism.

One reference sweep on one LocalCluster worker; the same seed on a real scheduler and two workers
started as separate processes (one of them killed mid-sweep), and on a LocalCluster of two workers
interrupted by Ctrl-C and resumed, must give exactly its rows: none missing, none twice.
"""

import os
import signal

import pytest

from dask_processes import dask_cluster
from pendc.robust.engine import read_rows
from robust_helpers import HANG_GUARD_S, ROOT, rows_of, start_pendc, sweep_args, wait_for_rows

SAMPLES = 8


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The undisturbed sweep, made by the CLI and run on one worker."""
    out = tmp_path_factory.mktemp("reference") / "sweep"
    proc = start_pendc(sweep_args(out, SAMPLES, "--workers", "1"))
    stdout, stderr = proc.communicate(timeout=HANG_GUARD_S)
    assert proc.returncode == 0, stderr
    assert f"ran {SAMPLES} runs" in stdout
    rows = rows_of(out)
    assert [r["index"] for r in rows] == list(range(SAMPLES))
    assert sum(r["passed"] for r in rows) not in (0, SAMPLES), "the ranges should make some runs fail"
    return out, rows


def test_a_killed_worker_on_a_real_scheduler_loses_nothing(reference, tmp_path):
    """A scheduler and two workers as separate processes; one worker is killed mid-sweep."""
    with dask_cluster(tmp_path, workers=2) as (address, workers):
        out = tmp_path / "sweep"
        sweep = start_pendc(sweep_args(out, SAMPLES, "--scheduler", address))
        wait_for_rows(out, 2, sweep)
        assert sweep.poll() is None, "the sweep ended before a worker could be killed"
        workers[0].send_signal(signal.SIGKILL)
        stdout, stderr = sweep.communicate(timeout=HANG_GUARD_S)
        assert sweep.returncode == 0, stderr
        assert workers[0].wait(timeout=10) == -signal.SIGKILL
        assert f"({address})" in stdout
        assert rows_of(out) == reference[1]


def test_ctrl_c_keeps_what_finished_and_resume_completes(reference, tmp_path):
    out = tmp_path / "sweep"
    proc = start_pendc(sweep_args(out, SAMPLES, "--workers", "2"))
    wait_for_rows(out, 3, proc)
    assert proc.poll() is None, "the sweep ended before it could be interrupted"
    os.kill(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=HANG_GUARD_S)
    assert proc.returncode == 130, stderr
    assert "interrupted" in stderr and f"--resume {out}" in stderr
    kept = rows_of(out)
    assert 3 <= len(kept) < SAMPLES
    assert kept == [r for r in reference[1] if r["index"] in {k["index"] for k in kept}]
    assert (out / "rows.parquet").exists() and (out / "summary.json").exists()   # what finished is written
    proc = start_pendc(["robust", "--resume", str(out), "--no-progress", "--workers", "2"])
    stdout, stderr = proc.communicate(timeout=HANG_GUARD_S)
    assert proc.returncode == 0, stderr
    assert f"ran {SAMPLES - len(kept)} runs" in stdout
    assert rows_of(out) == reference[1]


def test_a_run_that_raises_is_a_failed_row(tmp_path):
    """A scenario raising inside every task: the sweep completes, each row says why."""
    out = tmp_path / "sweep"
    proc = start_pendc(sweep_args(out, 3, "--workers", "1", "--controller", "robust_helpers:ResetRaises"),
                       cwd=ROOT / "tests")
    stdout, stderr = proc.communicate(timeout=HANG_GUARD_S)
    assert proc.returncode == 0, stderr
    rows = rows_of(out)
    assert [r["index"] for r in rows] == [0, 1, 2]
    assert all(not r["passed"] and r["error"] == "RuntimeError: this controller cannot start" for r in rows)
    assert "success rate 0.0 % (0 of 3 passed" in stdout and "3 raised" in stdout


def test_read_rows_skips_what_is_not_a_row(tmp_path):
    (tmp_path / "rows").mkdir()
    (tmp_path / "rows" / "0000001.json").write_text('{"index": 1, "passed": true}\n')
    (tmp_path / "rows" / "0000002.json").write_text('{"index": 2, "pass')          # torn by hand
    (tmp_path / "rows" / "0000003.json").write_text('{"index": 4, "passed": true}\n')   # wrong file
    (tmp_path / "rows" / "0000009.json").write_text('{"index": 9, "passed": true}\n')   # beyond the plan
    assert list(read_rows(tmp_path, 5)) == [1]
