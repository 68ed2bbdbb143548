"""``pendc robust``: a 20-sample sweep end to end (rows, summary, HTML seen in headless Chromium,
the replay of its worst run), and every bad input a one-line error."""

import json

import pyarrow.parquet as pq
import pytest

from cli_capture import run_cli
from robust_helpers import sweep_args
from test_hil_animate import browser  # noqa: F401  (the headless Chromium fixture)

SAMPLES = 20


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("robust") / "sweep"
    from pendc.cli import main
    import io
    import contextlib
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(sweep_args(out, SAMPLES, "--workers", "2"))
    return rc, buf.getvalue(), out


def test_a_sweep_writes_rows_summary_and_report(sweep):
    rc, out, folder = sweep
    assert rc == 0
    table = pq.read_table(folder / "rows.parquet")
    assert table.column("index").to_pylist() == list(range(SAMPLES))
    assert table.column_names[:3] == ["index", "alpha", "b_x"]
    assert (folder / "rows.csv").read_text().count("\n") == SAMPLES + 1
    summary = json.loads((folder / "summary.json").read_text())
    passed = sum(table.column("passed").to_pylist())
    assert summary["passed"] == passed and 0 < passed < SAMPLES
    assert f"success rate {100 * passed / SAMPLES:.1f} % ({passed} of {SAMPLES} passed" in out
    assert summary["most_important"] == "alpha"           # the drive gain decides the swing-up, not the damping
    assert f"the parameter that matters most: alpha" in out
    worst = summary["worst_runs"][0]
    assert not worst["passed"] and worst["replay"] == f"pendc robust --resume {folder} --replay {worst['index']}"


def test_the_report_in_headless_chromium(sweep, browser):  # noqa: F811
    page = browser.new_page()
    page.goto((sweep[2] / "report.html").as_uri())
    headline = page.inner_text("p.headline")
    assert "runs passed" in headline and "alpha" in headline
    sizes = page.evaluate("Array.from(document.images).map(i => [i.alt, i.naturalWidth])")
    assert [alt for alt, _ in sizes] == ["success rate along each parameter", "failure region", "sensitivity ranking"]
    assert all(width > 200 for _, width in sizes)          # every PNG decoded
    assert "pendc robust --resume" in page.inner_text("table:last-of-type")
    page.close()


def test_replay_runs_one_alone(sweep, capsys):
    folder = sweep[2]
    worst = json.loads((folder / "summary.json").read_text())["worst_runs"][0]
    rc, out, err = run_cli(capsys, "robust", "--resume", folder, "--replay", worst["index"])
    assert rc == 0, err
    assert "failed: " + worst["why"] in out
    record = folder / f"replay_{worst['index']}"
    assert (record / "run.csv").exists() and (record / "run.png").exists()
    assert f"# alpha: {worst['parameters']['alpha']:.9g}" in (record / "run.csv").read_text()


def test_resuming_a_complete_sweep_runs_nothing(sweep, capsys):
    before = (sweep[2] / "rows.parquet").read_bytes()
    rc, out, err = run_cli(capsys, "robust", "--resume", sweep[2], "--no-progress")
    assert rc == 0 and "ran " not in out and "success rate" in out
    assert (sweep[2] / "rows.parquet").read_bytes() == before


@pytest.mark.parametrize("argv, message", [
    (["--vary", "alpha"], "expected NAME=LO:HI"),
    (["--vary", "nope=1:2"], "--vary nope: not a parameter of the model"),
    (["--samples", "0"], "--samples must be at least 1"),
    (["--replay", "3"], "--replay K replays run K of a finished sweep"),
    (["--resume", "."], "--resume writes into the sweep's own folder; drop --out"),
    (["--plant", "icarus"], "invalid choice: 'icarus'"),
    (["--scenario", "balance_step", "--controller", "lqr"], "runs with --scenario swing_up_balance"),
    (["--model", "missing.toml"], "missing.toml: model file not found"),
    (["--workers", "0"], "--workers must be at least 1"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "a --scheduler's cluster has its own workers"),
    (["--scheduler", "tcp://127.0.0.1:1", "--vary", "alpha=200:300", "--samples", "2"],
     "--scheduler tcp://127.0.0.1:1: cannot reach a Dask scheduler there (connection refused)"),
])
def test_bad_input_is_one_line(capsys, tmp_path, argv, message):
    rc, out, err = run_cli(capsys, "robust", "--out", tmp_path / "x", *argv)
    assert rc == 2 and err.count("\n") == 1 and err.startswith("pendc: error: ") and message in err


def test_a_resume_takes_no_sweep_options_and_out_is_not_reused(sweep, capsys):
    rc, _, err = run_cli(capsys, "robust", "--resume", sweep[2], "--samples", "5")
    assert rc == 2 and "drop --samples" in err
    rc, _, err = run_cli(capsys, "robust", "--out", sweep[2], "--vary", "alpha=200:300")
    assert rc == 2 and "already holds a sweep" in err


def test_a_folder_that_holds_no_sweep(capsys, tmp_path):
    rc, _, err = run_cli(capsys, "robust", "--resume", tmp_path)
    assert rc == 2 and f"{tmp_path}: not a sweep folder (no sweep.json" in err


@pytest.mark.parametrize("controller", ["lqr", "builtin", "hold", "robust_helpers:ResetRaises"])
def test_a_plant_without_a_pendulum_is_refused_before_the_sweep(capsys, tmp_path, controller):
    """Every run of a converter's sweep raised "... use --controller lqr at an operating point" (the
    option given), and the sweep reported 0 % success; now one line before any run says what to do."""
    from test_hardware_dt import RC

    model = tmp_path / "rc.toml"
    model.write_text(RC, encoding="utf-8")
    rc, out, err = run_cli(capsys, "robust", "--model", model, "--controller", controller, "--samples", "4",
                           "--out", tmp_path / "sweep")
    assert rc == 2 and err.count("\n") == 1 and out == ""
    assert "judge a pendulum, whatever --controller runs, and plant 'rc'" in err
    assert f"run pendc hil --model {model} --controller lqr --start half" in err
    assert "use --controller lqr" not in err and not (tmp_path / "sweep").exists()
