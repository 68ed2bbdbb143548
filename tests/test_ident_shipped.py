"""Every shipped data file through compare, diagnose and fit: no Python warning, no traceback,
nothing on stderr but ``pendc: note:`` lines (issue 8: "no warning or traceback on any shipped
data"). Warnings are turned into errors while the command runs, so one would fail it.

diagnose is asked for one or two candidates (``--effects``) and fit for a short budget: the
whole pipeline (output weighting, shooting, noise floor, evidence, ties, figures, intervals,
the model file) still runs on every file, at a fraction of the full diagnosis's cost.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import pytest

from pendc.cli import main

DATA = Path(__file__).resolve().parents[1] / "data"
SHIPPED = sorted(p.name for p in DATA.glob("*.csv"))
# per file: the candidates diagnose tests, and what fit frees (a cart_held file has no cart)
PLAN = {
    "unknown_pendulum_swing.csv": ("viscous_pendulum,theta_offset", ["--free", "I,b_theta"]),
}
DEFAULT_PLAN = ("cart_spring,coulomb_pendulum", ["--add", "cart_spring"])


def _run(capsys, *argv):
    with warnings.catch_warnings():
        warnings.simplefilter("error")            # any Python warning fails the command
        rc = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def _clean(err: str) -> bool:
    return all(line.startswith("pendc: note: ") for line in err.splitlines() if line.strip())


def test_every_shipped_file_is_covered():
    assert len(SHIPPED) >= 6 and "unknown_pendulum_swing.csv" in SHIPPED


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_file_through_diagnose_and_fit(capsys, tmp_path, name):
    effects, fit_args = PLAN.get(name, DEFAULT_PLAN)
    rc, out, err = _run(capsys, "diagnose", DATA / name, "--effects", effects, "--workers", "1", "--json")
    assert rc == 0 and _clean(err), err
    d = json.loads(out)
    assert d["candidates"] and {c["effect"] for c in d["candidates"]} <= set(effects.split(","))
    rc, out, err = _run(capsys, "fit", DATA / name, *fit_args, "--max-evaluations", "8", "--force",
                        "-o", tmp_path / "fitted.toml")
    assert rc == 0 and _clean(err), err
    assert out.splitlines()[0].startswith("before: 0.5 s horizon fit") and (tmp_path / "fitted.toml").exists()
