"""Every shipped data file through diagnose and fit: no Python warning, no traceback, nothing
on stderr but ``pendc: note:`` lines (issue 8: "no warning or traceback on any shipped data";
compare is checked file by file in test_compare_cli). Warnings are turned into errors while
the command runs, so one would fail it.

All files go through one command each (files of different experiments fit together, each
simulated under its own), with one candidate and one free parameter: the whole pipeline
(reading, output weighting, shooting, noise floor, evidence, ties, labelled figures per
file, intervals, the model file) runs on every file at a fraction of a full diagnosis's cost.
"""

from __future__ import annotations

import json
from pathlib import Path

from cli_capture import run_cli

DATA = Path(__file__).resolve().parents[1] / "data"
SHIPPED = sorted(DATA.glob("*.csv"))


_run = run_cli


def _clean(err: str) -> bool:
    return "Traceback" not in err and all(line.startswith("pendc: note: ") for line in err.splitlines() if line.strip())


def test_every_shipped_file_through_diagnose(capsys):
    assert len(SHIPPED) >= 6 and DATA / "unknown_pendulum_swing.csv" in SHIPPED
    rc, out, err = _run(capsys, "diagnose", *SHIPPED, "--effects", "coulomb_pendulum", "--workers", "1", "--json")
    assert rc == 0 and _clean(err), err
    d = json.loads(out)
    assert [c["effect"] for c in d["candidates"]] == ["coulomb_pendulum"]
    assert [f["file"] for f in d["fit_now"]["files"]] == [str(p) for p in SHIPPED]


def test_every_shipped_file_through_fit(capsys, tmp_path):
    rc, out, err = _run(capsys, "fit", *SHIPPED, "--free", "b_theta", "--max-evaluations", "40", "--objective", "horizon",
                        "-o", tmp_path / "fitted.toml")
    assert rc == 0 and _clean(err), err
    lines = out.splitlines()
    assert lines[0] == "figures on the fit data:"
    assert lines[1].startswith("before: 0.5 s horizon fit") and "pooled over 6 files" in lines[1]
    assert all(any(f"  {p} (" in line for line in lines) for p in SHIPPED)     # a figure per file
    assert (tmp_path / "fitted.toml").exists()


def test_fit_says_which_data_its_figures_are_on(capsys, tmp_path):
    """With --validate the before/after figures are the held-out file's, and the first line says
    so (they read as the fit data's before: found by the private check)."""
    rc, out, err = _run(capsys, "fit", SHIPPED[0], "--free", "b_theta", "--max-evaluations", "3",
                        "--validate", SHIPPED[1], "-o", tmp_path / "fitted.toml")
    assert rc == 0 and _clean(err), err
    lines = out.splitlines()
    assert lines[0] == f"figures on {SHIPPED[1]} (held out: --validate):"
    assert lines[1].startswith("before: 0.5 s horizon fit") and "pooled" not in lines[1]     # one file
