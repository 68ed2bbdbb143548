"""``make fuzz`` (bench/fuzz.py) on the sweep engine: the same findings on one worker and on two,
each batch the graphs its seed says, a lost batch run again by ``--resume``, bad options.

Six graphs in three batches of two under Icarus (a build is a fraction of a second), one graph
per batch through the golden kernel (numba's disk cache keeps its compile).
"""

import importlib.util
import json
from collections import Counter
from pathlib import Path

import pytest

from fuzzcases import draw_cases
from fuzzharness import simulator_available

ROOT = Path(__file__).resolve().parents[1]
SEED, GRAPHS, BATCH = 20261128, 6, 2
OPTIONS = ["--graphs", str(GRAPHS), "--batch", str(BATCH), "--golden", "1", "--sim", "icarus",
           "--seed", str(SEED), "--no-progress"]
VARYING = ("timings_s", "wall_s", "workers")       # what may differ between two runs of one seed

pytestmark = pytest.mark.skipif(not simulator_available("icarus"), reason="iverilog not installed")


def _fuzz_module():
    spec = importlib.util.spec_from_file_location("bench_fuzz", ROOT / "bench" / "fuzz.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


FUZZ = _fuzz_module()


def _run(folder: Path, *extra) -> tuple:
    rc = FUZZ.main([*OPTIONS, "-o", str(folder / "fuzz.json"), *extra])
    report = json.loads((folder / "fuzz.json").read_text())
    batches = {p.name: json.loads(p.read_text()) for p in sorted((folder / "fuzz_batches").glob("0*.json"))}
    return rc, report, batches


def _steady(report: dict) -> dict:
    return {k: v for k, v in report.items() if k not in VARYING}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    one, two = tmp_path_factory.mktemp("one"), tmp_path_factory.mktemp("two")
    return (one, *_run(one, "--workers", "1")), (two, *_run(two, "--workers", "2"))


def test_one_and_two_workers_find_the_same(runs):
    (_, rc1, report1, batches1), (_, rc2, report2, batches2) = runs
    assert rc1 == rc2 == 0
    assert report1["workers"] == 1 and report2["workers"] == 2
    assert report1["graphs"] == GRAPHS and report1["complete"] and report1["golden_checked"] == GRAPHS // BATCH
    assert _steady(report1) == _steady(report2)
    assert sum(report1["node_kinds"].values()) > GRAPHS and sum(report1["ii"].values()) == GRAPHS
    # batch by batch, not only the totals: a batch run with another's seed would show here
    strip = [{name: {k: v for k, v in batch.items() if k != "timings_s"} for name, batch in run.items()}
             for run in (batches1, batches2)]
    assert list(batches1) == ["0000000.json", "0000001.json", "0000002.json"] and strip[0] == strip[1]


def test_each_batch_holds_the_graphs_of_its_seed(runs):
    _, _, _, batches = runs[1]
    for b in range(GRAPHS // BATCH):
        kinds = Counter(n.kind.value for c in draw_cases(BATCH, SEED + b) for n in c.graph.nodes)
        assert batches[f"{b:07d}.json"]["node_kinds"] == dict(kinds)


def test_the_report_keeps_its_fields(runs):
    report = runs[0][2]
    assert list(report) == ["graphs", "complete", "seed", "batch_seeds", "batch", "simulator", "steps_per_graph",
                            "golden_checked", "mismatches", "mismatched_graphs", "node_kinds", "ii", "lint_warnings",
                            "timings_s", "wall_s", "workers", "scheduler", "failed_batches", "python", "details"]
    assert report["seed"] == SEED and report["simulator"] == "icarus" and report["failed_batches"] == {}
    assert {"generate", "golden", "build", "run"} <= set(report["timings_s"])


def test_resume_runs_only_the_lost_batch(runs, capsys):
    folder, _, report, batches = runs[0]
    (folder / "fuzz_batches" / "0000001.json").unlink()
    rc = FUZZ.main(["--resume", "--workers", "1", "--no-progress", "-o", str(folder / "fuzz.json")])
    assert rc == 0
    out, err = capsys.readouterr()
    assert err.count("fuzz: batch ") == 1 and "fuzz: batch 1: " in err
    resumed = json.loads((folder / "fuzz.json").read_text())
    assert _steady(resumed) == _steady(report)


@pytest.mark.parametrize("argv, message", [
    (["--resume", "--seed", "3"], "--resume continues the run"),
    (["--graphs", "0"], "--graphs and --batch must be >= 1"),
    (["--workers", "0"], "--workers must be at least 1"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "a --scheduler's cluster has its own workers"),
])
def test_bad_options_are_one_line(tmp_path, capsys, argv, message):
    assert FUZZ.main([*argv, "-o", str(tmp_path / "fuzz.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("fuzz: error: ") and message in err
    assert not (tmp_path / "fuzz.json").exists()


def test_a_resume_without_a_run_is_one_line(tmp_path, capsys):
    assert FUZZ.main(["--resume", "-o", str(tmp_path / "fuzz.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no fuzz run to resume" in err
