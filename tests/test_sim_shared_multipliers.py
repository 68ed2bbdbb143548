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
    import pickle
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
    with open(tmp_path / "vectors.pickle", "rb") as fh:        # what the two tests read, no more
        vec = pickle.load(fh)
    assert {w["stim"] for w in vec["windows"]} == {"chirp_low"} and not vec["long"] and not vec["bus"]
    assert vec["overflow"] is None
    report = json.loads((tmp_path / "hdl_raptor" / "report.json").read_text())
    assert report["source"].startswith("model sha256:")
    assert report["ii"] > 2 and report["schedule"]["units"] and report["schedule"]["preset"] == "small"
    assert report["resources"]["dsp_scheduled"] <= 4
    assert (repo / "hdl_out" / "report.json").read_bytes() == before
    bad = subprocess.run([sys.executable, "tb/run.py", "--sim", "icarus", "--model", str(tmp_path / "no.toml")],
                         cwd=repo, capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "no model file" in bad.stderr


def test_every_cocotb_test_says_what_it_reads_of_the_vectors():
    """tb/run.py -k computes only what the selected tests read (pendtb.vector_options, from
    tbconfig.TEST_VECTORS): every cocotb test of the suites must have its entry."""
    import re
    tb = Path(__file__).resolve().parents[1] / "tb"
    tests = set()
    for module in ("test_core", "test_bus"):
        names = re.findall(r"@cocotb\.test\(\)\n(?:@.*\n)*async def (\w+)", (tb / f"{module}.py").read_text())
        tests |= {f"{module}.{n}" for n in names if n != "every_step"}
        tests |= {f"{module}.every_step/stim={s}" for s in pendtb.WINDOW_STIMULI if "every_step" in names}
    assert tests == set(pendtb.TEST_VECTORS)
    assert pendtb.vector_options(None) == pendtb.vector_options("no_such_test") == {}
    assert pendtb.vector_options("reset_state,step_handshake") == {
        "stimuli_names": ("chirp_low", "multisine_seed7_1MHz"), "long_chunks": {}, "overflow": False, "bus": False}
    assert pendtb.vector_options("overflow_flags")["overflow"] and pendtb.vector_options("lockstep")["bus"]
