"""A published design's Q-formats beside pendc's: the plant file's ``[reference_formats]``.

The SCT plant file carries the thesis' fixed-point design (spec §5); the qformat report reads
it from the model's plant definition, so a plant whose file gives none gets no published
column, and the sizing rule run on the published maxima gives the published formats (a check
against the printed figures).
"""

import re
from pathlib import Path
from types import SimpleNamespace

import pytest

import pendc
from pendc.errors import PendcError
from pendc.ir.graph import Graph
from pendc.passes.qformats import thesis_format
from pendc.cli.report import format_qformat_report, qformat_report
from plants import DEFAULT
from test_plantfile import example

FURUTA = Path(__file__).resolve().parents[1] / "models" / "furuta_qube.toml"


def test_the_default_plant_file_gives_the_thesis_formats_for_its_states():
    d = DEFAULT.definition
    named = {s.name for s in DEFAULT.interface.states} | {f"dd{c.name}" for c in d.coordinates}
    assert len(d.reference_formats) == 6 and set(d.reference_formats) <= named
    assert {s.name for s in DEFAULT.interface.states if s.output} <= set(d.reference_formats)
    assert sum("max" in row for row in d.reference_formats.values()) == 2            # the two printed maxima
    assert all(row["format"].startswith("FIX32_") for row in d.reference_formats.values())
    assert "section 5" in d.reference_source


def test_the_rule_gives_the_published_formats_from_their_maxima():
    """II: i = ceil(log2 max) + 1 integer bits of 32, from the maxima the thesis printed."""
    for name, row in DEFAULT.definition.reference_formats.items():
        if "max" in row:
            assert str(thesis_format(row["max"], 32)) == row["format"], name


def test_a_plant_file_without_them_has_none():
    assert pendc.load_model(FURUTA).definition.reference_formats == {}


def _report(model):
    build = SimpleNamespace(graph=Graph("g", (), ()), error=None, model=model,
                            ranges=SimpleNamespace(max_abs={}, sources=()), options=SimpleNamespace(margin_bits=0))
    return qformat_report(build)


def test_the_qformat_report_reads_them_from_the_plant_definition():
    checked = _report(DEFAULT)["reference_rule_check"]
    assert len(checked) == 2 and all(r["rule_gives"] == r["reference_format"] for r in checked.values())
    text = format_qformat_report(_report(DEFAULT))
    assert "DIFFERS" not in text and "section 5" in text
    assert _report(pendc.load_model(FURUTA))["reference_rule_check"] == {}


@pytest.mark.parametrize("table, message", [
    ('[reference_formats]\ny = { format = "FIX32_31" }\n', r"reference_formats\.y: 'y' is not a state"),
    ('[reference_formats]\nx = { format = "Q3.4" }\n', r"reference_formats\.x\.format: 'Q3\.4' is not a format"),
    ('[reference_formats]\nx = { format = "FIX8_9" }\n', "is not a format"),
    ('[reference_formats]\nx = { format = "FIX8_4", max = -1.0 }\n', r"reference_formats\.x\.max"),
    ('[reference_formats]\nx = { format = "FIX8_4", width = 8 }\n', "unknown key 'width'"),
])
def test_a_bad_reference_format_gets_one_line(table, message, tmp_path):
    path = tmp_path / "plant.toml"
    path.write_text(example() + "\n" + table, encoding="utf-8")
    with pytest.raises(PendcError) as info:
        pendc.load_model(path).equations
    assert "\n" not in str(info.value) and re.search(message, str(info.value)), str(info.value)


def test_a_plant_file_of_ones_own_may_give_them(tmp_path):
    path = tmp_path / "plant.toml"
    path.write_text(example() + '\n[reference_formats]\nsource = "my last design"\nddx = { format = "FIX24_18", '
                    'max = 20.0 }\n', encoding="utf-8")
    model = pendc.load_model(path)
    assert model.definition.reference_formats == {"ddx": {"format": "FIX24_18", "max": 20.0}}
    checked = _report(model)["reference_rule_check"]
    assert checked["ddx"]["rule_gives"] == str(thesis_format(20.0, 24))
