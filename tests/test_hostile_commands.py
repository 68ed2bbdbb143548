"""Hostile input to every command other than the measurement readers (issue 11, point 3).

tests/test_data_cli.py covers the measurement files of compare / diagnose / fit; this table
covers model TOML, simulate's input and step, stimulus names, build output paths, report
arguments, hil controller specs and animate's input. Every row: exactly one
``pendc: error:`` line naming the problem, exit status 2, no traceback, and the folder the
command ran in is byte-for-byte unchanged (nothing created, nothing altered).
The table is listed in docs/hostile_inputs.md.
"""

import os
import re
import stat
from pathlib import Path

import numpy as np
import pytest

from pendc.cli import main
from pendc.sim.measurements import format_csv

ROOT = Path(__file__).resolve().parents[1]
GOOD_MODEL = (ROOT / "models" / "sct_thesis_final.toml").read_text()


def model_with(old: str, new: str) -> str:
    assert old in GOOD_MODEL
    return GOOD_MODEL.replace(old, new)


def tu_csv(n=2000, dt=1e-3, t=None, u=None) -> str:
    t = np.arange(n) * dt if t is None else np.asarray(t, float)
    u = np.full(t.size, 5.0) if u is None else np.asarray(u, float)
    return format_csv({"t": t, "u": u}, {})


def run_csv(theta=None) -> str:
    t = np.arange(200) * 0.01
    cols = {"t": t, "u": np.full(t.size, 5.0), "x": 0.01 * np.sin(t),
            "theta": np.sin(t) if theta is None else np.asarray(theta, float)}
    return format_csv(cols, {})


NAN_THETA = np.sin(np.arange(200) * 0.01)
NAN_THETA[50] = np.nan
BAD_T = np.arange(2000) * 1e-3
BAD_T[100] = BAD_T[50]
NAN_U = np.full(2000, 5.0)
NAN_U[7] = np.nan
BIG_U = np.full(2000, 5.0)
BIG_U[40] = 1e30

# (id, files to create, argv, what the error line must say (a regex), xfail reason or None)
# every argv runs in the scratch folder; paths are relative to it
ROWS = [
    # --- model TOML (read through `build --model M -o out`: nothing may appear at out/)
    ("model-missing", {}, ["build", "--model", "none.toml", "-o", "out"], r"none\.toml", None),
    ("model-empty", {"m.toml": ""}, ["build", "--model", "m.toml", "-o", "out"], r"m\.toml", None),
    ("model-truncated", {"m.toml": GOOD_MODEL[:GOOD_MODEL.index("M = ") + 4]},
     ["build", "--model", "m.toml", "-o", "out"], r"m\.toml", None),
    ("model-not-toml", {"m.toml": "this is not toml {"}, ["build", "--model", "m.toml", "-o", "out"],
     r"m\.toml", None),
    ("model-wrong-type", {"m.toml": model_with("M = 103.205", 'M = "heavy"')},
     ["build", "--model", "m.toml", "-o", "out"], r"\bM\b", None),
    ("model-unknown-effect", {"m.toml": GOOD_MODEL + "\n[effects.warp_drive]\nk = 1.0\n"},
     ["build", "--model", "m.toml", "-o", "out"], r"warp_drive", None),
    ("model-unknown-parameter", {"m.toml": model_with("b_x = 877.31327", "b_x = 877.31327\nb_q = 1.0")},
     ["build", "--model", "m.toml", "-o", "out"], r"b_q", None),
    ("model-unknown-table", {"m.toml": GOOD_MODEL + "\n[plantt]\ng = 1.0\n"},
     ["build", "--model", "m.toml", "-o", "out"], r"plantt", None),
    ("model-negative-mass", {"m.toml": model_with("m = 0.581", "m = -0.581")},
     ["build", "--model", "m.toml", "-o", "out"], r"\bm\b", None),
    ("model-zero-inertia", {"m.toml": model_with("I = 6.21034e-3", "I = 0.0")},
     ["build", "--model", "m.toml", "-o", "out"], r"\bI\b", None),
    ("model-negative-mu_s", {"m.toml": model_with("mu_s = 0.1035951", "mu_s = -0.1")},
     ["build", "--model", "m.toml", "-o", "out"], r"mu_s", None),
    ("model-nan", {"m.toml": model_with("M = 103.205", "M = nan")},
     ["build", "--model", "m.toml", "-o", "out"], r"\bM\b", None),
    ("model-inf", {"m.toml": model_with("L = 0.138867", "L = inf")},
     ["build", "--model", "m.toml", "-o", "out"], r"\bL\b", None),
    ("model-missing-parameter", {"m.toml": model_with("M = 103.205\n", "")},
     ["build", "--model", "m.toml", "-o", "out"], r"\bM\b", None),
    ("model-a-folder", {"m.toml/": None}, ["build", "--model", "m.toml", "-o", "out"],
     r"m\.toml: is a folder, not a model file", None),
    ("model-not-utf8", {"m.toml": GOOD_MODEL.replace("[plant]", "# Masse in \xe4\n[plant]").encode("latin-1")},
     ["build", "--model", "m.toml", "-o", "out"], r"m\.toml: line \d+: not UTF-8 text", None),
    ("model-and-input-both-stdin", {}, ["simulate", "--model", "-", "--input", "-", "-o", "o.csv"],
     r"standard input \('-'\) can be read only once; it is given to --model and --input", None),
    # --- simulate --input and its step
    ("simulate-input-missing", {}, ["simulate", "--input", "none.csv", "-o", "o.csv"], r"none\.csv", None),
    ("simulate-input-empty", {"in.csv": ""}, ["simulate", "--input", "in.csv", "-o", "o.csv"], r"in\.csv", None),
    ("simulate-input-no-u", {"in.csv": "t\n0\n0.001\n0.002\n"}, ["simulate", "--input", "in.csv", "-o", "o.csv"],
     r"\bu\b", None),
    ("simulate-input-nan", {"in.csv": tu_csv(u=NAN_U)}, ["simulate", "--input", "in.csv", "-o", "o.csv"],
     r"(?i)nan|not a number|finite", None),
    ("simulate-input-time-repeats", {"in.csv": tu_csv(t=BAD_T)}, ["simulate", "--input", "in.csv", "-o", "o.csv"],
     r"(?i)time|\bt\b", None),
    ("simulate-input-text", {"in.csv": "t,u\n0,1\n0.001,volts\n"}, ["simulate", "--input", "in.csv", "-o", "o.csv"],
     r"volts|in\.csv", None),
    ("simulate-input-millivolts", {"in.csv": tu_csv(u=np.full(2000, 5000.0))},
     ["simulate", "--input", "in.csv", "-o", "o.csv"], r"in\.csv: column 'u' looks like millivolts", None),
    ("simulate-input-outlier-u", {"in.csv": tu_csv(u=BIG_U)}, ["simulate", "--input", "in.csv", "-o", "o.csv"],
     r"in\.csv: line \d+: u = 1e\+30 is an outlier", None),
    ("simulate-dt-zero", {"in.csv": tu_csv()}, ["simulate", "--input", "in.csv", "--dt", "0", "-o", "o.csv"],
     r"--dt", None),
    ("simulate-dt-negative", {"in.csv": tu_csv()}, ["simulate", "--input", "in.csv", "--dt", "-1e-6", "-o", "o.csv"],
     r"--dt: must be positive, got '-1e-6'", None),
    ("simulate-dt-negative-equals", {"in.csv": tu_csv()},
     ["simulate", "--input", "in.csv", "--dt=-1e-6", "-o", "o.csv"], r"--dt: must be positive, got '-1e-6'", None),
    ("simulate-dt-nan", {"in.csv": tu_csv()}, ["simulate", "--input", "in.csv", "--dt", "nan", "-o", "o.csv"],
     r"--dt", None),
    ("simulate-x0-three-numbers", {"in.csv": tu_csv()}, ["simulate", "--input", "in.csv", "--x0", "0,0,0"],
     r"--x0", None),
    ("simulate-output-a-folder", {"in.csv": tu_csv(), "o/": None}, ["simulate", "--input", "in.csv", "-o", "o"],
     r"o: is a folder", None),
    ("simulate-output-ends-in-slash", {"in.csv": tu_csv()}, ["simulate", "--input", "in.csv", "-o", "o.csv/"],
     r"o\.csv/: ends in '/'", None),
    ("simulate-output-under-a-file", {"in.csv": tu_csv(), "notes.txt": "mine"},
     ["simulate", "--input", "in.csv", "-o", "notes.txt/o.csv"], r"notes\.txt/o\.csv: folder notes\.txt", None),
    # --- stimulus
    ("stimulus-unknown", {}, ["stimulus", "chirp_mid", "-o", "s.csv"], r"unknown stimulus 'chirp_mid'", None),
    ("stimulus-output-missing-folder", {}, ["stimulus", "steps", "-o", "no/s.csv"], r"no/s\.csv", None),
    # --- build -o
    ("build-o-existing-file", {"notes.txt": "my notes\n"}, ["build", "-o", "notes.txt"],
     r"notes\.txt: is a file", None),
    ("build-o-users-folder", {"thesis/chapter1.tex": "text"}, ["build", "-o", "thesis"],
     r"thesis: holds chapter1\.tex", None),
    ("build-o-under-a-file", {"notes.txt": "my notes\n"}, ["build", "-o", "notes.txt/hdl"],
     r"notes\.txt/hdl: notes\.txt is not a folder", None),
    ("build-check-missing", {}, ["build", "--check", "-o", "nowhere"], r"nowhere: folder does not exist", None),
    ("build-check-a-file", {"notes.txt": "my notes\n"}, ["build", "--check", "-o", "notes.txt"],
     r"notes\.txt: is not a folder", None),
    ("build-o-stdout", {}, ["build", "-o", "-"], r"build: -o names the output folder", None),
    ("build-ii-zero", {}, ["build", "--ii", "0", "-o", "out"], r"--ii", None),
    ("build-preset-and-ii", {}, ["build", "--preset", "fast", "--ii", "4", "-o", "out"], r"--preset", None),
    ("build-bus-unknown", {}, ["build", "--bus", "wishbone", "-o", "out"], r"wishbone", None),
    # --- report
    ("report-unknown-what", {}, ["report", "timing"], r"timing", None),
    ("report-no-kind", {}, ["report"], r"report: .*required: KIND", None),
    ("report-bad-model", {"m.toml": "[plant]\n"}, ["report", "qformat", "--model", "m.toml"], r"m\.toml", None),
    ("report-synth-missing-build-dir", {}, ["report", "synth", "--build-dir", "nowhere"], r"nowhere", None),
    ("report-freq-negative", {}, ["report", "synth", "--freq", "-5"], r"--freq", None),
    ("report-drift-with-resources", {}, ["report", "resources", "--drift"],
     r"report resources: unrecognized arguments: --drift \(report resources takes --model", None),
    ("report-synth-with-model", {"m.toml": GOOD_MODEL}, ["report", "synth", "--model", "m.toml"],
     r"report synth: unrecognized arguments: --model m\.toml \(report synth takes --build-dir", None),
    ("report-qformat-with-build-dir", {}, ["report", "qformat", "--build-dir", "hdl_out"],
     r"report qformat: unrecognized arguments: --build-dir", None),
    # --- hil --controller
    ("hil-controller-no-module", {}, ["hil", "--controller", "no_such_module_xyz:Ctl", "--seconds", "0.01"],
     r"no_such_module_xyz", None),
    ("hil-controller-no-class", {}, ["hil", "--controller", "os:NoSuchController", "--seconds", "0.01"],
     r"NoSuchController", None),
    ("hil-controller-malformed", {}, ["hil", "--controller", "a:b:c", "--seconds", "0.01"], r"a:b:c", None),
    ("hil-controller-file-missing", {}, ["hil", "--controller", "ctl.py:Ctl", "--seconds", "0.01"], r"ctl\.py", None),
    ("hil-controller-file-broken", {"ctl.py": "def broken(:\n"},
     ["hil", "--controller", "ctl.py:Ctl", "--seconds", "0.01"], r"ctl\.py", None),
    ("hil-seconds-negative", {}, ["hil", "--seconds", "-1"], r"positive", None),
    ("hil-out-is-a-file", {"run": "keep"}, ["hil", "--seconds", "0.01", "--out", "run"],
     r"run: is a file; --out names a folder", None),
    ("hil-out-under-a-file", {"notes.txt": "keep"}, ["hil", "--seconds", "0.01", "--out", "notes.txt/run"],
     r"notes\.txt/run: notes\.txt is not a folder", None),
    ("hil-out-stdout", {}, ["hil", "--seconds", "0.01", "--out", "-"], r"hil: --out names a folder", None),
    # --- animate
    ("animate-missing", {}, ["animate", "none.csv", "-o", "a.html"], r"none\.csv", None),
    ("animate-empty", {"run.csv": ""}, ["animate", "run.csv", "-o", "a.html"], r"run\.csv", None),
    ("animate-no-theta", {"run.csv": "t,x\n0,0\n0.01,0\n"}, ["animate", "run.csv", "-o", "a.html"], r"theta", None),
    ("animate-nan", {"run.csv": run_csv(NAN_THETA)}, ["animate", "run.csv", "-o", "a.html"],
     r"(?i)nan|finite|not a number", None),
    ("animate-unknown-extension", {"run.csv": run_csv()}, ["animate", "run.csv", "-o", "a.docx"], r"docx", None),
    ("animate-fps-zero", {"run.csv": run_csv()}, ["animate", "run.csv", "-o", "a.gif", "--fps", "0"], r"fps", None),
    ("animate-output-a-folder", {"run.csv": run_csv(), "a.html/": None}, ["animate", "run.csv", "-o", "a.html"],
     r"a\.html: is a folder", None),
    ("animate-input-a-folder", {"runs/": None}, ["animate", "runs", "-o", "a.html"],
     r"runs: is a folder, not a run file", None),
    ("animate-not-utf8", {"run.csv": b"t,x,theta\n0,0,\xff\n"}, ["animate", "run.csv", "-o", "a.html"],
     r"run\.csv: cannot read", None),
    ("animate-output-stdout", {"run.csv": run_csv()}, ["animate", "run.csv", "-o", "-"],
     r"animate: -o names a file", None),
    ("animate-output-ends-in-slash", {"run.csv": run_csv()}, ["animate", "run.csv", "-o", "a.gif/"],
     r"a\.gif/: ends in '/'", None),
    ("animate-output-missing-folder", {"run.csv": run_csv()}, ["animate", "run.csv", "-o", "no/a.gif"],
     r"no/a\.gif: folder no does not exist", None),
    # --- standard input named twice (read once, before anything else)
    ("compare-data-and-model-stdin", {}, ["compare", "-", "--model", "-"],
     r"can be read only once; it is given to --model and data file", None),
    ("fit-data-and-validate-stdin", {}, ["fit", "-", "--validate", "-", "-o", "f.toml"],
     r"can be read only once; it is given to data file and --validate", None),
]


def snapshot(root: Path) -> dict:
    """Every path under ``root`` with its kind, mode and content."""
    out = {}
    for p in sorted(root.rglob("*")):
        st = p.lstat()
        out[str(p.relative_to(root))] = (stat.S_IFMT(st.st_mode), stat.S_IMODE(st.st_mode),
                                         p.read_bytes() if stat.S_ISREG(st.st_mode) else None)
    return out


def make(root: Path, files: dict) -> None:
    for name, text in files.items():
        path = root / name
        if name.endswith("/"):
            path.mkdir(parents=True)
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            if isinstance(text, bytes):
                path.write_bytes(text)
            else:
                path.write_text(text)


def test_every_row_is_listed_in_the_docs():
    """docs/hostile_inputs.md lists the table: every row once, and no row that is not in it."""
    text = (ROOT / "docs" / "hostile_inputs.md").read_text()
    section = text[text.index("(`tests/test_hostile_commands.py`)"):text.index("## Measurement files")]
    listed = [line.split("|")[1].strip() for line in section.splitlines() if line.startswith("| ")][1:]
    assert sorted(listed) == sorted(rid for rid, *_ in ROWS)


def params():
    for rid, files, argv, pattern, xfail in ROWS:
        marks = [pytest.mark.xfail(strict=True, reason=xfail)] if xfail else []
        yield pytest.param(files, argv, pattern, id=rid, marks=marks)


@pytest.mark.parametrize("files, argv, pattern", list(params()))
def test_hostile_input_is_one_error_and_changes_nothing(tmp_path, monkeypatch, capsys, files, argv, pattern):
    make(tmp_path, files)
    monkeypatch.chdir(tmp_path)
    before = snapshot(tmp_path)
    code = main(argv)
    captured = capsys.readouterr()
    err = captured.err
    assert "Traceback" not in err and "Warning:" not in err, err
    errors = [line for line in err.splitlines() if line.startswith("pendc: error:")]
    assert len(errors) == 1, f"expected one error line, got stderr:\n{err}"
    assert errors[0].count("pendc:") == 1, errors[0]
    assert re.search(pattern, errors[0]), f"{errors[0]!r} does not name {pattern!r}"
    assert code == 2
    assert snapshot(tmp_path) == before, "the command created or changed files"


UNWRITABLE = Path("/proc/pendc-test")   # /proc takes no new files, even from root (a read-only folder does)


@pytest.mark.skipif(not Path("/proc/self").exists(), reason="needs Linux /proc for a place nobody can write")
@pytest.mark.parametrize("argv", [
    ["stimulus", "steps", "-o", f"{UNWRITABLE}.csv"],
    ["simulate", "--input", "in.csv", "-o", f"{UNWRITABLE}.csv"],
    ["animate", "run.csv", "-o", f"{UNWRITABLE}.html"],
    ["hil", "--seconds", "0.01", "--out", str(UNWRITABLE)],
], ids=["stimulus", "simulate", "animate", "hil"])
def test_an_unwritable_output_is_one_error_naming_it(tmp_path, monkeypatch, capsys, argv):
    make(tmp_path, {"in.csv": tu_csv(n=20), "run.csv": run_csv()})
    monkeypatch.chdir(tmp_path)
    before = snapshot(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"pendc: error: {argv[-1]}: ") and "Traceback" not in err, err
    assert snapshot(tmp_path) == before and not Path(argv[-1]).exists()
