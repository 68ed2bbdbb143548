"""The text report of pendc compare: the headline first, labelled figures, models side by side.

Also the layering of issue 12: compare does not import its reports.
"""

from __future__ import annotations

import ast
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from pendc.ident.report_text import format_side_by_side, text_report, trend
from pendc.ident.sidebyside import compare_models
from pendc.model.modelfile import load_model
from plants import STIMULI as stimuli
from pendc.sim.measurements import Measurement
from pendc.sim.simulator import Simulator

IDENT = Path(__file__).resolve().parents[1] / "compiler" / "ident"
SPRING = {"k_c": 200.0, "x_0": 0.0}


def measured(model, t, u, source) -> Measurement:
    r = Simulator(model, dt=1e-4, method="rk4")(t, u)
    return Measurement(t=t, u=u, columns={"t": t, "u": u, **{k: r[k] for k in ("x", "theta", "dx", "dtheta")}},
                       meta={}, source=source)


@pytest.fixture(scope="module")
def model():
    return load_model()


@pytest.fixture(scope="module")
def side(model):
    """Two models (without and with the spring that made the data) on two short runs."""
    truth = model.with_effect("cart_spring", SPRING)
    t, u = stimuli.chirp(duration=2)
    t2, u2 = stimuli.steps(duration=2)
    data = [measured(truth, t, u, "chirp.csv"), measured(truth, t2, u2, "steps.csv")]
    return compare_models([model, truth], data)


def test_first_line_shows_the_error_falling(side):
    text = format_side_by_side(side)
    first = text.splitlines()[0]
    assert re.match(r"headline: free-run fit on chirp\.csv, A: sct_thesis_final -> B: sct_thesis_final \+cart_spring: "
                    r"x -?\d+\.\d+ % -> 100\.00 %, theta -?\d+\.\d+ % -> 100\.00 % \(A -> B: the error falls\)$", first)
    assert text.splitlines()[1].startswith("  why: a free run is meaningful")


def test_one_table_per_file_with_changes(side):
    text = format_side_by_side(side)
    blocks = [i for i, line in enumerate(text.splitlines()) if line.startswith("headline: ")]
    assert len(blocks) == 2 and "steps.csv" in text.splitlines()[blocks[1]]
    for i, cs in enumerate(side.runs):
        a, b = cs
        row = next(line for line in text.splitlines()[blocks[i]:] if line.startswith("free-run fit x (%)"))
        cells = row.split()[4:]
        assert [float(v) for v in cells] == pytest.approx([a.fit["x"], b.fit["x"], b.fit["x"] - a.fit["x"]], abs=0.006)
    assert sum(line.startswith("figure ") for line in text.splitlines()) == 2 and "B - A" in text
    assert "free-run theta, whole turns apart (max) (turns)" in text
    assert text.count("--- A: ") == 2 and text.count("--- B: ") == 2


def test_json_labels_every_figure_and_change(side):
    out = json.loads(json.dumps(side.to_json(), allow_nan=False))
    assert out["models"] == list(side.labels) and len(out["runs"]) == 2
    run = out["runs"][0]
    assert run["headline"]["metric"] == "free_run" and run["headline"]["label"] == "free-run fit"
    b = side.labels[1]
    assert run["headline"]["change"][b]["x"] == pytest.approx(side.runs[0][1].fit["x"] - side.runs[0][0].fit["x"])
    for entry in run["models"]:
        assert entry["fit"]["label"] == "free-run fit (%)"
        assert entry["fit_horizon"]["label"] == "0.5 s horizon fit (%)" and entry["fit_horizon"]["horizon_s"] == 0.5
        assert "wrapped" in entry["fit_theta_wrapped"]["label"]
    assert {row["figure"] for row in run["table"]} >= {"free-run fit x", "0.5 s horizon fit theta"}


def test_single_comparison_is_the_plain_report(side):
    c = side.runs[0][0]
    assert text_report(c).splitlines()[0].startswith("headline: free-run fit x ")


def test_trend_words():
    assert trend({"x": 50.0, "theta": 90.0}, {"x": 60.0, "theta": 95.0}) == "the error falls"
    assert trend({"x": 50.0}, {"x": 40.0}) == "the error rises"
    assert trend({"x": 50.0, "theta": 90.0}, {"x": 60.0, "theta": 80.0}) == "mixed: x better, theta worse"
    assert trend({"x": math.nan, "theta": 90.0}, {"x": 1.0, "theta": 90.001}) == "the error is unchanged"


def test_compare_does_not_import_its_reports():
    """Issue 12: the reports sit below compare (they import it, never the reverse)."""
    def imports(name):
        tree = ast.parse((IDENT / name).read_text())
        return {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module} | \
            {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    for core in ("compare.py", "sidebyside.py", "horizon.py", "headline.py", "whiteness.py"):
        assert not {m for m in imports(core) if "report" in m}, core
    assert "compare" in imports("report_text.py") and "report_text" in imports("report_html.py")


def test_undefined_figures_are_na_not_warnings(side, recwarn):
    """A figure that cannot be computed (here: made undefined by hand) prints n/a, is null in
    JSON, and no warning is raised on the way."""
    import dataclasses
    c = side.runs[0][0]
    blank = dataclasses.replace(c, fit={k: float("nan") for k in c.fit}, fit_wrapped=float("nan"))
    s = dataclasses.replace(side, runs=((blank, side.runs[0][1]),))
    text = format_side_by_side(s)
    assert "x undefined" in text and "n/a" in text
    out = json.loads(json.dumps(s.to_json(), allow_nan=False))
    row = next(r for r in out["runs"][0]["table"] if r["figure"] == "free-run fit x")
    assert row["values"][s.labels[0]] is None and row["change"][s.labels[1]] is None
    assert not recwarn.list
