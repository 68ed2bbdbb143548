"""pendc.robust.results: the rows' files, the Wilson interval, the worst runs and their replay."""

import json
import math

import pyarrow.csv as pacsv
import pyarrow.parquet as pq
import pytest

from pendc.robust.results import (badness, columns_of, replay_command, rows_table, summarize, wilson_interval,
                                  worst_runs, write_rows)
from pendc.robust.sampling import SamplePlan
from pendc.robust.scenario_runner import FIGURES, SweepSpec

PLAN = SamplePlan(nominal={"a": 1.0, "b": 2.0}, ranges=(("a", 0.0, 2.0), ("b", 1.0, 3.0)), count=4)
SPEC = SweepSpec(model_text="", design_text="", model_source="m.toml", design_source="m.toml")


def _row(i, passed, worst, error=""):
    return {"index": i, "a": 0.1 * i, "b": 1.0 + i, "passed": passed, "failures": "" if passed else "too far",
            "error": error, **{f: None for f in FIGURES}, "worst_last_3s_rad": worst, "switches": 1,
            "travel_ratio": 0.1 / 0.3, "max_abs_x_m": 0.1, "max_abs_theta_rad": 3.3}


ROWS = [_row(3, True, 0.01), _row(0, False, 0.2), _row(2, False, None, "RuntimeError: boom"), _row(1, False, 3.1)]


def test_wilson_interval():
    lo, hi = wilson_interval(8, 10)
    assert (round(lo, 4), round(hi, 4)) == (0.4902, 0.9433)       # the textbook figures for 8 of 10
    assert wilson_interval(0, 10)[0] == 0.0 and wilson_interval(10, 10)[1] == 1.0
    assert wilson_interval(10, 10)[0] == pytest.approx(0.7225, abs=1e-4)
    assert all(math.isnan(v) for v in wilson_interval(0, 0))


def test_rows_are_written_sorted_with_fixed_columns(tmp_path):
    table = rows_table(ROWS, PLAN)
    assert table.column_names == columns_of(ROWS, PLAN)
    assert table.column_names[:6] == ["index", "a", "b", "passed", "failures", "error"]
    assert table.column("index").to_pylist() == [0, 1, 2, 3]
    write_rows(tmp_path, ROWS, PLAN)
    back = pq.read_table(tmp_path / "rows.parquet")
    assert back.equals(table)
    csv = pacsv.read_csv(tmp_path / "rows.csv")
    assert csv.column("index").to_pylist() == [0, 1, 2, 3]
    assert csv.column("error").to_pylist()[2] == "RuntimeError: boom"


def test_worst_runs_raised_first_then_failed_by_their_figure(tmp_path):
    order = [r["index"] for r in sorted(ROWS, key=lambda r: badness(r, "worst_last_3s_rad"))]
    assert order == [2, 1, 0, 3]
    worst = worst_runs(ROWS, SPEC, PLAN, tmp_path / "sw eep", count=2)
    assert [w["index"] for w in worst] == [2, 1]
    assert worst[0]["why"] == "RuntimeError: boom" and worst[1]["parameters"] == {"a": 0.1, "b": 2.0}
    assert worst[1]["replay"] == f"pendc robust --resume '{tmp_path}/sw eep' --replay 1"
    assert replay_command("out", 7) == "pendc robust --resume out --replay 7"


def test_the_summary(tmp_path):
    summary = summarize(ROWS, SPEC, PLAN, tmp_path, None, None)
    assert (summary["passed"], summary["failed"], summary["raised"], summary["finished"]) == (1, 3, 1, 4)
    assert summary["success_rate"] == 0.25 and summary["complete"]
    assert summary["success_rate_95"] == list(wilson_interval(1, 4))
    json.dumps(summary)          # every value is JSON


def test_limit_ratio():
    from pendc.robust.results import limit_ratio
    assert limit_ratio({"worst_last_3s_rad": 0.01, "travel_ratio": 0.5, "max_abs_theta_rad": 3.2}) == pytest.approx(0.5)
    assert limit_ratio({"worst_last_3s_rad": 0.04, "travel_ratio": 0.5}) == pytest.approx(0.8)
    assert limit_ratio({"worst_last_3s_rad": 3.1, "travel_ratio": 0.5}) == 2.0
    assert math.isnan(limit_ratio({"worst_last_3s_rad": 0.01, "max_abs_x_m": 0.15}))
    assert math.isnan(limit_ratio({"worst_last_3s_rad": None}))
