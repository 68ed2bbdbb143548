"""The thesis' published Q-formats (spec §5) beside pendc's: kept in the model, keyed by plant.

The table lives in ``pendc.model.thesis_formats`` (physics of the plant the thesis built); the
qformat report reads it through the graph's plant interface, so a plant the thesis did not
build gets no thesis column, and the sizing rule run on the thesis' own printed maxima gives
the thesis' own printed formats (a check against the published figures).
"""

from pathlib import Path
from types import SimpleNamespace

import pytest

import pendc
from pendc.ir.graph import Graph
from pendc.model.interface import INFO_KEY
from pendc.model.thesis_formats import thesis_formats
from pendc.passes.qformats import thesis_format
from pendc.reports import format_qformat_report, qformat_report

FURUTA = Path(__file__).resolve().parents[1] / "models" / "furuta_qube.toml"


@pytest.fixture(scope="module")
def cart():
    return pendc.load_model().interface


def test_the_thesis_formats_name_nodes_of_the_cart_pendulum(cart):
    formats = thesis_formats(cart)
    named = {s.name for s in cart.states} | {q.name for q in cart.quantities}
    assert len(formats) == 6 and set(formats) <= named
    assert {s.name for s in cart.states if s.output} <= set(formats)     # every reported state register
    assert sum("max" in row for row in formats.values()) == 2            # the two printed maxima
    assert all(row["format"].startswith("FIX32_") for row in formats.values())


def test_the_rule_gives_the_thesis_formats_from_its_maxima(cart):
    """II: i = ceil(log2 max) + 1 integer bits of 32, from the maxima the thesis printed."""
    for name, row in thesis_formats(cart).items():
        if "max" in row:
            assert str(thesis_format(row["max"], 32)) == row["format"], name


def test_no_thesis_formats_for_another_plant_or_a_hand_built_graph():
    assert thesis_formats(pendc.load_model(FURUTA).interface) == {}
    assert thesis_formats(None) == {}


def test_the_qformat_report_reads_them_through_the_graphs_interface(cart):
    """An empty graph carrying the cart-pendulum's interface: the rule check lists the two
    maxima; carrying none, it lists nothing (the table is not the report's own)."""
    def report(info):
        build = SimpleNamespace(graph=Graph("g", (), (), info=info), error=None,
                                ranges=SimpleNamespace(max_abs={}, sources=()), options=SimpleNamespace(margin_bits=0))
        return qformat_report(build)

    checked = report(((INFO_KEY, cart),))["thesis_rule_check"]
    assert len(checked) == 2 and all(r["rule_gives"] == r["thesis_format"] for r in checked.values())
    assert "DIFFERS" not in format_qformat_report(report(((INFO_KEY, cart),)))
    assert report(())["thesis_rule_check"] == {}
