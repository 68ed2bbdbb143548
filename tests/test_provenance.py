"""Table 3 parameters recomputed from raw thesis data (spec plant.md section 3): the SCT
plant's own record in data/sct_thesis/, run as its script and imported from there."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parents[1] / "data" / "sct_thesis"
sys.path.insert(0, str(HERE))

import thesis_data as td  # noqa: E402
from provenance import (  # noqa: E402
    Derived,
    derive_parameters,
    derived_to_json,
    format_derived_table,
)

NAMES = ["L", "I", "alpha", "M", "M_mfr_1096", "mu_s", "mu_s_left", "mu_s_right",
         "mu_c_pairwise", "b_x_pairwise", "mu_c_lstsq", "b_x_lstsq"]
# 4 significant digits: half a unit in the 4th digit is at most 5e-4 relative.
SIG4 = 5e-4


@pytest.fixture(scope="module")
def d() -> dict[str, Derived]:
    return derive_parameters()


def test_names_and_order(d):
    assert list(d) == NAMES
    assert all(isinstance(x, Derived) and x.name == k for k, x in d.items())


@pytest.mark.parametrize("name, expected", [
    ("L", 0.138867),
    ("I", 6.21034e-3),
    ("alpha", 51.525),
    ("M", 103.205),
    ("M_mfr_1096", 103.787),
    ("mu_s", 0.03709),
    ("mu_s_left", 0.03589),     # V+ = 5.705 V, cart moves left (+x), II.94
    ("mu_s_right", 0.03828),    # V- = 4.248 V, cart moves right (-x), II.95
    ("mu_c_pairwise", 0.02626),
    ("b_x_pairwise", 139.6),
    ("mu_c_lstsq", 0.02672),
    ("b_x_lstsq", 137.1),
])
def test_values_to_four_digits(d, name, expected):
    assert d[name].value == pytest.approx(expected, rel=SIG4)


def test_spec_rounded_friction_figures(d):
    # The spec quotes these to 3-4 digits; check exactly that rounding.
    assert round(d["mu_c_pairwise"].value, 4) == 0.0263
    assert round(d["b_x_pairwise"].value, 1) == 139.6
    assert round(d["mu_c_lstsq"].value, 4) == 0.0267
    assert round(d["b_x_lstsq"].value, 1) == 137.1


def test_thesis_figures_are_printed_values(d):
    assert d["M"].thesis == td.M_PRINTED == 103.205
    assert d["M_mfr_1096"].thesis == 103.205
    assert d["mu_c_pairwise"].thesis == d["mu_c_lstsq"].thesis == 0.0292
    assert d["b_x_pairwise"].thesis == d["b_x_lstsq"].thesis == 155.1574
    assert d["mu_s"].thesis == 0.03709


def test_mu_s_is_mean_of_directions(d):
    mean = (d["mu_s_left"].value + d["mu_s_right"].value) / 2
    assert d["mu_s"].value == pytest.approx(mean, rel=1e-12)
    assert "M*g" in d["mu_s"].note and "(M+m)*g" in d["mu_s"].note
    assert "left" in d["mu_s_left"].note and "right" in d["mu_s_right"].note


def test_rel_diff(d):
    for x in d.values():
        assert x.rel_diff == pytest.approx((x.value - x.thesis) / abs(x.thesis))
    assert d["b_x_lstsq"].rel_diff < -0.1


def test_flags(d):
    for name in ["M", "M_mfr_1096", "mu_c_pairwise", "b_x_pairwise",
                 "mu_c_lstsq", "b_x_lstsq"]:
        assert d[name].flagged, name
    for name in ["L", "I", "alpha", "mu_s", "mu_s_left", "mu_s_right"]:
        assert not d[name].flagged, name
    # Any numeric disagreement beyond 0.1 % must be flagged.
    assert all(x.flagged for x in d.values() if abs(x.rel_diff) > 1e-3)


def test_notes_document_choices(d):
    assert "1.096" in d["M"].note and "0.5146" in d["M"].note
    assert "0.01388672" in d["I"].note and "186.5/2+15" in d["I"].note
    assert "241.5/2" in d["L"].note
    assert "0.1124" in d["mu_c_pairwise"].note          # 4.2 V mean misprint
    assert "15 pairs" in d["mu_c_pairwise"].note
    assert "6 printed means" in d["mu_c_lstsq"].note and "18 runs" in d["mu_c_lstsq"].note
    assert all(x.note and x.unit for x in d.values())


def test_computed_not_typed_in(d, monkeypatch):
    # Perturbing a raw input must move the derived value: nothing is hard-coded.
    monkeypatch.setattr(td, "M_CART_G", 600.0)
    monkeypatch.setattr(td, "K_M_NM_PER_A", 0.6)
    e = derive_parameters()
    assert e["M"].value != pytest.approx(d["M"].value, rel=1e-4)
    assert e["alpha"].value == pytest.approx(d["alpha"].value * 0.6 / 0.54)


def test_json_shape(d):
    j = derived_to_json(d)
    assert list(j) == ["derived"]
    assert list(j["derived"]) == NAMES
    for name, entry in j["derived"].items():
        assert set(entry) == {"value", "thesis", "rel_diff", "note", "unit", "flagged"}
        assert entry["value"] == d[name].value
        assert entry["rel_diff"] == d[name].rel_diff
        assert isinstance(entry["flagged"], bool)
    json.dumps(j)   # must be serialisable as-is


def test_table_deterministic_and_complete(d):
    t1 = format_derived_table(d)
    t2 = format_derived_table(derive_parameters())
    assert t1 == t2
    lines = t1.splitlines()
    assert lines[0].split()[:2] == ["name", "ours"] and "rel. diff (%)" in lines[0]
    for name in NAMES:
        assert any(line.split()[0] == name for line in lines[2:]), name
    flagged_rows = [line for line in lines[2:] if " ! " in line]
    assert len(flagged_rows) == sum(x.flagged for x in d.values())


def test_the_script_prints_the_table_and_the_json():
    table = subprocess.run([sys.executable, str(HERE / "derive.py")], capture_output=True, text=True, check=True)
    assert "mu_c_pairwise" in table.stdout
    out = subprocess.run([sys.executable, str(HERE / "derive.py"), "--json"], capture_output=True, text=True,
                         check=True)
    d = json.loads(out.stdout)["derived"]
    assert set(d) == set(NAMES)
    assert d["M"]["value"] == pytest.approx(103.205, rel=5e-5)
    assert d["M_mfr_1096"]["value"] == pytest.approx(103.787, rel=5e-5)
    assert d["mu_c_pairwise"]["value"] == pytest.approx(0.0263, rel=5e-3)
    assert d["b_x_pairwise"]["value"] == pytest.approx(139.6, rel=5e-3)
    bad = subprocess.run([sys.executable, str(HERE / "derive.py"), "--bogus"], capture_output=True, text=True)
    assert bad.returncode == 2 and "unrecognized arguments" in bad.stderr
