"""The error budget on inputs it was not tuned on (pendc.cli.heldout, ``pendc report qformat``):
one input of each class, none of them a check stimulus, and the verdict per class."""

import numpy as np
import pytest

import pendc
from pendc.caching.build_cache import compile_cached
from pendc.cli.heldout import CLASSES, format_budget, held_out_check, held_out_stimuli
from pendc.passes.error_budget import check_stimuli
from pendc.passes.pipeline import BuildOptions
from pendc.passes.segmented_error import compare_segmented
from plants import DEFAULT

DT = 1e-6
OPTIONS = BuildOptions(training_scale=0.02)     # test_error_budget's short build (the build cache)


@pytest.fixture(scope="module")
def build():
    return compile_cached(pendc.load_model(), OPTIONS)


def test_held_out_check_runs_one_input_per_class(build):
    rep = held_out_check(build)
    assert rep["seconds"] == build.error.seconds and rep["form"] == build.error.form
    assert tuple(rep["stimuli"]) == CLASSES and not rep["skipped"] and rep["overflow"] is None
    stimuli, _ = held_out_stimuli(build, rep["seconds"])
    checks = check_stimuli(DEFAULT.interface.input, rep["seconds"])
    for name, (t, u) in stimuli.items():                # none of them is a check stimulus
        assert not any(len(u) == len(c) and np.allclose(u, c) for _, c in checks.values()), name
    runs = compare_segmented(build.graph, stimuli, DT)
    for name, r in rep["stimuli"].items():               # the report's numbers are the comparison's
        assert r["errors"] == runs[name].segmented and r["plain"] == runs[name].plain
        assert r["met"] == all(r["errors"][s] <= b for s, b in rep["budgets"].items()), name
        if name != "tap":        # the SCT cart's static friction holds it against the tap: both runs stay
            assert r["errors"]["x"] > 0 and r["errors"]["theta"] > 0
    t, u = stimuli["tap"]
    neutral, span = DEFAULT.interface.input.neutral, DEFAULT.interface.input.hi - DEFAULT.interface.input.lo
    assert np.allclose(u[t < 0.02], neutral + 0.001 * span) and np.all(u[t >= 0.02] == neutral)
    assert rep["met"]
    text = "\n".join(format_budget(build.error.to_json(), rep))
    assert "held out" in text and all(name in text for name in CLASSES) and "OVER" not in text


def test_held_out_check_fails_on_a_shrunk_budget(build):
    small = {s: b / 1000 for s, b in build.error.budgets.items()}
    rep = held_out_check(build, budgets=small)
    assert not rep["met"] and all("x" in r["over"] and not r["met"] for c, r in rep["stimuli"].items() if c != "tap")
    assert rep["stimuli"]["tap"]["met"]          # x and theta exactly 0 in both runs: the cart sticks
    assert "NOT met" in "\n".join(format_budget(build.error.to_json(), rep))
