"""pendc.robust.report: the page answers first and draws every figure it promises."""

import numpy as np

from pendc.robust.report import render_report, success_along
from pendc.robust.results import rank_rows, summarize
from pendc.robust.sampling import SamplePlan
from pendc.robust.scenario_runner import FIGURES, SweepSpec

PLAN = SamplePlan(nominal={"a": 0.5, "b": 0.5}, ranges=(("a", 0.0, 1.0), ("b", 0.0, 1.0)), count=40, seed=2)
SPEC = SweepSpec(model_text="", design_text="", model_source="m<1>.toml", design_source="m<1>.toml")


def _rows():
    x = PLAN.design()
    return [{"index": i, "a": a, "b": b, "passed": bool(a < 0.7), "failures": "" if a < 0.7 else "fell",
             "error": "", **{f: None for f in FIGURES}, "worst_last_3s_rad": 0.01 if a < 0.7 else 3.0}
            for i, (a, b) in enumerate(x)]


def test_success_along_a_parameter():
    centres, rate, runs = success_along(np.arange(12.0), np.arange(12) < 6, bins=3)
    assert list(centres) == [1.5, 5.5, 9.5] and list(rate) == [1.0, 0.5, 0.0] and list(runs) == [4, 4, 4]


def test_the_page(tmp_path):
    rows = _rows()
    ranking = rank_rows(rows, SPEC, PLAN)
    summary = summarize(rows, SPEC, PLAN, tmp_path, ranking, None)
    page = render_report(rows, SPEC, PLAN, summary, ranking)
    passed = sum(r["passed"] for r in rows)
    assert f"{passed} of 40 runs passed: success rate <b>{100 * passed / 40:.1f} %</b>" in page
    assert "the parameter that matters most: <b>a</b>" in page
    assert page.count("data:image/png;base64,") == 3
    assert "<h2>Failure region: a and b</h2>" in page
    assert "m&lt;1&gt;.toml" in page and "m<1>.toml" not in page          # escaped
    assert f"pendc robust --resume {tmp_path} --replay" in page
    assert "http" not in page.replace("http-equiv", "")                    # self-contained


def test_a_page_with_no_finished_run(tmp_path):
    summary = summarize([], SPEC, PLAN, tmp_path, None, None)
    page = render_report([], SPEC, PLAN, summary, None)
    assert "No run finished." in page and "data:image/png" not in page
