"""`tb/run.py` on a model file other than the default, with the small preset's shared multipliers
(ii > 2), bit-exact on Icarus: the regression's command line end to end, and the one schedule
with shared DSP blocks in `make test`. A file of its own (not tests/test_sim.py) so that
pytest-xdist can run it beside the default model's regression (tests/conftest.py).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tb"))

import pendtb  # noqa: E402


def test_run_py_on_another_model_with_shared_multipliers(tmp_path):
    """`tb/run.py --model M.toml --preset small`: a model file other than the default (the default
    physics with a quick [hardware] training), its HDL built under the work folder (never hdl_out/)
    with 4 shared DSP blocks and ii > 2, bit-exact on Icarus (a subset of the core suite)."""
    import json
    import subprocess
    why = pendtb.simulator_missing("icarus")
    if why:
        pytest.skip(why)
    repo = Path(__file__).resolve().parents[1]
    before = (repo / "hdl_out" / "report.json").read_bytes()
    model = tmp_path / "quick_model.toml"
    # no error budget: its rounds compile the whole graph with numba again and again (most of this
    # build's time), and neither the schedule nor the bit-exactness checked here depend on the widths
    model.write_text((repo / "models" / "sct_thesis_final.toml").read_text()
                     + "\n[hardware]\ntraining_scale = 0.02\nerror_budget = false\n")
    cmd = [sys.executable, "tb/run.py", "--sim", "icarus", "--model", str(model),
           "--preset", "small", "--suite", "core", "-k", "reset_state,every_step/stim=chirp_low", "--work", str(tmp_path),
           "--json", str(tmp_path / "summary.json")]
    r = subprocess.run(cmd, cwd=repo, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    summary = json.loads((tmp_path / "summary.json").read_text())
    (suite,) = summary["suites"]
    assert suite["tests"] == 2 and suite["failed"] == 0
    report = json.loads((tmp_path / "hdl_raptor" / "report.json").read_text())
    assert report["source"].startswith("model sha256:")
    assert report["ii"] > 2 and report["schedule"]["units"] and report["schedule"]["preset"] == "small"
    assert report["resources"]["dsp_scheduled"] <= 4
    assert (repo / "hdl_out" / "report.json").read_bytes() == before
    bad = subprocess.run([sys.executable, "tb/run.py", "--sim", "icarus", "--model", str(tmp_path / "no.toml")],
                         cwd=repo, capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "no model file" in bad.stderr
