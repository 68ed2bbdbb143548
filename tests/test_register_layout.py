"""The bus wrappers hold what the plant has, and the testbench can push any plant out of range.

* the register map's layout (docs/register_map.md, "Where the registers lie"): the common
  words at the same offsets on every plant, then ``ENC`` (only with an encoder), one word per
  sensor, the step count and the state pairs, one after another;
* a plant whose sensors are only sampled converters (ADCs) gets no ``ENC`` register, no x4
  decoder module and no encoder pins; its wrappers lint clean and read its code words over the
  bus (a one-cycle stand-in core, Icarus);
* the testbench's overflow scenario (tb/overflow_runs.py) for such a plant in state-equation
  form (no rate state), whose full push stays in range: a state deposited near the edge of its
  range drifts out within the bus test's second burst, both golden engines agreeing; a plant
  that nothing drives out of range is reported as such and its overflow tests are skipped.

Cheap by design: one build of a small two-tank plant without the error budget (no simulator
run of it: ``make sim MODEL=...`` is the regression on a plant file).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from pendc import load_model
from pendc.backend.wrapper import COMMON_REGISTERS, has_encoders, module_names, register_map, render_wrapper
from pendc.model.interface import InputSpec, PlantInterface, StateSpec
from pendc.model.sensors import ADC, SensorSpec

from stand_in_core import RAPTOR_SIGNALS, RAPTOR_TASKS, stand_in_core
from test_wrapper import EXPECTED_PORTS
from wrapper_bench import ENCODERS, TOPS, run, tool, write

REPO = Path(__file__).resolve().parents[1]

# a converter-only plant in state-equation form: two levels, no rate state, no encoder
TANKS = PlantInterface(
    name="tanks", core="tanks_core",
    states=(StateSpec("h_1", "m", "level of tank 1 (m)", body="tank 1", quantity="position"),
            StateSpec("h_2", "m", "level of tank 2 (m)", body="tank 2", quantity="position")),
    inputs=(InputSpec("V_p", "V", "pump voltage (V)", 22.0),),
    sensors=(SensorSpec("lvl_1", "h_1", "tank 1", kind=ADC, bits=12, lo=0.0, hi=0.3),
             SensorSpec("lvl_2", "h_2", "tank 2", kind=ADC, bits=12, lo=0.0, hi=0.3)))


def _ports(iface, width: int = 32) -> dict:
    """Port formats any build of ``iface`` could have (a converter's code port holds integers)."""
    ports = {p: {"signed": True, "width": width, "frac": width - 12} for p in (iface.input.name, *iface.outputs)}
    ports.update({s.code_port: {"signed": True, "width": 32, "frac": 0} for s in iface.sensors if s.is_adc})
    return ports


def expected_layout(iface) -> list:
    """The register names in offset order, by the rule docs/register_map.md states."""
    names = iface.register_names()
    (u_reg,) = names[iface.input.name]
    out = [u_reg if r is None else r for r in COMMON_REGISTERS]
    if has_encoders(iface):
        out.append("ENC")
    out += [names[s.name][0] for s in iface.sensors]
    out += ["STEP_COUNT_LO", "STEP_COUNT_HI"]
    out += [r for p in iface.outputs for r in names[p]]
    return out


@pytest.mark.parametrize("plant", ["default", "ball_beam.toml", "furuta_qube.toml", "tanks"])
def test_the_map_follows_the_documented_layout(plant):
    iface = TANKS if plant == "tanks" else load_model(None if plant == "default" else REPO / "models" / plant).interface
    regs = register_map(_ports(iface), interface=iface)
    assert [r["name"] for r in regs] == expected_layout(iface)
    assert [r["offset"] for r in regs] == [4 * i for i in range(len(regs))]       # one word after another
    assert [r["name"] for r in regs[:len(COMMON_REGISTERS)] if r["name"] != iface.register_names()[
        iface.input.name][0]] == [n for n in COMMON_REGISTERS if n is not None]   # 0x00..0x28 on every plant
    # the build's formats change the bits, never an offset
    narrow = register_map(_ports(iface, width=20), interface=iface)
    assert [(r["name"], r["offset"]) for r in narrow] == [(r["name"], r["offset"]) for r in regs]
    assert ("ENC" in {r["name"] for r in regs}) == any(not s.is_adc for s in iface.sensors)


def test_the_doc_states_the_layout_and_the_tanks_example():
    doc = (REPO / "docs" / "register_map.md").read_text(encoding="utf-8")
    assert "Offsets never depend on the model" not in doc
    regs = {r["name"]: r["offset"] for r in register_map(_ports(TANKS), interface=TANKS)}
    for name in ("LVL_1_CODE", "LVL_2_CODE", "STEP_COUNT_LO", "H_1_LO"):
        assert re.search(rf"`{name}` at 0x{regs[name]:02X}", doc), f"docs/register_map.md: {name} at 0x{regs[name]:02X}"


# ---------------------------------------------------------------- a converter-only plant's wrappers

def converter_view(iface, uw: int = 16, w: int = 24):
    ports = {iface.input.name: {"signed": True, "width": uw, "frac": uw - 6}}
    ports.update({p: {"signed": True, "width": w, "frac": w - 4} for p in iface.outputs})
    ports.update({s.code_port: {"signed": True, "width": 32, "frac": 0} for s in iface.sensors})
    view = SimpleNamespace(module="tanks_core", ii=1, interface=iface,
                           ports=[("input", iface.input.name, uw, True)] +
                           [("output", p, w, True) for p in iface.outputs] +
                           [("output", s.code_port, 32, True) for s in iface.sensors])
    return view, ports


CONVERTER_TB = r"""
`timescale 1ns/1ps
module tb_tanks;
    reg clk = 1'b0;
    always #5 clk = !clk;
    reg rst = 1'b1;
""" + RAPTOR_SIGNALS + r"""    tanks_raptor dut (.clk(clk), .rst(rst), .addr(addr), .wdata(wdata), .wr(wr), .rd(rd), .rdata(rdata), .ack(ack));
""" + RAPTOR_TASKS + r"""    initial begin
        repeat (3) @(negedge clk);
        rst = 1'b0;
        w(`N_STEPS, 32'd5); w(`CONTROL, 32'h2);
        q = 32'h2;
        while (q[1]) r(`STATUS, q);
        show("COUNT", `STEP_COUNT_LO); show("H_1_LO", `H_1_LO); show("LVL_1", `LVL_1_CODE);
        show("LVL_2", `LVL_2_CODE); show("AFTER_LAST", `AFTER_LAST);
        $finish;
    end
endmodule
"""


def test_a_converter_only_plant_gets_no_encoder_register_decoder_or_pins(tmp_path):
    verilator, iverilog, vvp = tool("verilator"), tool("iverilog"), tool("vvp")
    view, ports = converter_view(TANKS)
    modules = module_names("tanks_core")
    rendered = {bus: render_wrapper(view, ports, 0x1234, bus) for bus in ("raptor", "axi-lite")}
    for bus, (files, meta) in rendered.items():
        assert sorted(files) == sorted([f"{modules['regs']}.v", f"{meta['module']}.v"]), bus    # no tanks_qdec.v
        names = [r["name"] for r in meta["registers"]]
        assert "ENC" not in names and not any(n.endswith("_COUNT") for n in names)
        assert names == expected_layout(TANKS)
        text = "\n".join(files.values())
        assert "qdec" not in text and "quadrature" not in files[f"{modules['regs']}.v"]
        top = files[f"{meta['module']}.v"]
        pins = re.findall(r"^\s*(?:input|output)\s+(?:wire|reg)\s*(?:\[[^\]]*\])?\s*(\w+)", top, re.M)
        assert pins == [p for p in EXPECTED_PORTS[TOPS[bus]] if p not in ENCODERS], bus    # no encoder pins
    core = {"tanks_core.v": stand_in_core(TANKS, 16, 24, name="tanks_core", codes=True)}
    for bus, (files, meta) in rendered.items():
        names = write(tmp_path / bus, files, core)
        res = run([verilator, "--lint-only", "-Wall", "--default-language", "1364-2005", "--top-module",
                   meta["module"], *names], tmp_path / bus)
        assert res.returncode == 0 and "%Warning" not in res.stderr, res.stderr
    # over the RAPTOR bus: 5 lockstep steps, the code words at their offsets, nothing at ENC's old one
    files, meta = rendered["raptor"]
    regs = {r["name"]: r["offset"] for r in meta["registers"]}
    names = write(tmp_path / "run", files, core)
    (tmp_path / "run" / "tb.v").write_text(CONVERTER_TB)
    defines = [f"-D{n}=8'h{o:02x}" for n, o in regs.items()] + [f"-DAFTER_LAST=8'h{max(regs.values()) + 4:02x}"]
    res = run([iverilog, "-g2005", "-s", "tb_tanks", *defines, "-o", "tb.vvp", *names, "tb.v"], tmp_path / "run")
    assert res.returncode == 0, res.stderr
    res = run([vvp, "-n", "tb.vvp"], tmp_path / "run")
    got = {k: int(v, 16) for k, v in re.findall(r"^R (\w+) ([0-9a-fx]+)$", res.stdout, re.M)}
    assert regs["LVL_1_CODE"] == 0x2C                         # the first plant word: where ENC is with encoders
    assert got["COUNT"] == 5 and got["H_1_LO"] == 5 and got["LVL_1"] == 5 and got["LVL_2"] == 5
    assert got["AFTER_LAST"] == 0


# ---------------------------------------------------------------- the overflow scenario

TANKS_FILE = """
[plant]
name = "two_tanks"
core = "tanks_core"
summary = "two cascaded tanks filled by a pump, Torricelli outflow"
source = "tests/test_register_layout.py: a converter-only plant in state-equation form"
g = 9.81
A_1 = 1.55e-3
A_2 = 1.55e-3
a_1 = 1.78e-5
a_2 = 1.78e-5
K_p = 3.3e-6

[constants]
g = { unit = "m/s^2", meaning = "gravitational acceleration" }
A_1 = { unit = "m^2", meaning = "tank 1 cross-section" }
A_2 = { unit = "m^2", meaning = "tank 2 cross-section" }
a_1 = { unit = "m^2", meaning = "tank 1 outlet area" }
a_2 = { unit = "m^2", meaning = "tank 2 outlet area" }
K_p = { unit = "m^3/(s*V)", meaning = "pump flow constant" }

[intermediates]
q_1 = { value = "1.4142135623730951*a_1*sqrt(g*h_1)", unit = "m^3/s", meaning = "outflow of tank 1" }
q_2 = { value = "1.4142135623730951*a_2*sqrt(g*h_2)", unit = "m^3/s", meaning = "outflow of tank 2" }

[states.h_1]
unit = "m"
meaning = "level in tank 1 (m)"
derivative = "(K_p*V_p - q_1)/A_1"
initial = 0.15
body = "tank 1"
quantity = "position"

[states.h_2]
unit = "m"
meaning = "level in tank 2 (m)"
derivative = "(q_1 - q_2)/A_2"
initial = 0.15
body = "tank 2"
quantity = "position"

[inputs.V_p]
unit = "V"
meaning = "pump voltage (V)"
range = [0.0, 22.0]
neutral = 9.26

[sensors.lvl_1]
kind = "adc"
state = "h_1"
bits = 12
range = [0.0, 0.30]

[sensors.lvl_2]
kind = "adc"
state = "h_2"
bits = 12
range = [0.0, 0.30]
"""


@pytest.fixture(scope="module")
def tanks_build(tmp_path_factory):
    """The two-tank plant built without the error budget (the scenario needs its graph only)."""
    from pendc.caching.build_cache import compile_cached
    from pendc.passes.pipeline import BuildOptions
    path = tmp_path_factory.mktemp("tanks") / "tanks.toml"
    path.write_text(TANKS_FILE, encoding="utf-8")
    model = load_model(path)
    return compile_cached(model, BuildOptions(training_scale=0.1, error_budget=False))


@pytest.fixture(scope="module")
def tb_modules():
    sys.path.insert(0, str(REPO / "tb"))
    import golden_vectors
    import overflow_runs
    import resumed_runs
    import tbconfig
    return SimpleNamespace(gv=golden_vectors, ov=overflow_runs, rr=resumed_runs, cfg=tbconfig)


def _scenario(build, tb):
    from pendc.golden import GoldenModel
    from pendc.model.interface import require_interface
    graph = build.graph
    return tb.ov.golden_overflow(GoldenModel(graph, build.options.dt), graph, require_interface(graph),
                                    tb.rr.ports_of(graph), [n.name for n in tb.rr.state_nodes(graph)],
                                    build.options.dt, *tb.cfg.sampling(build.options.dt))


def _iface(build):
    from pendc.model.interface import require_interface
    return require_interface(build.graph)


@pytest.mark.parametrize("bus", ["raptor", "axi-lite"])
def test_the_tanks_build_has_no_encoder_register_or_decoder(tanks_build, bus, tmp_path):
    """What ``pendc build`` writes for the plant: no decoder module, no ENC in report.json; the
    wrapper around the real core (code ports with fraction bits) is -Wall clean."""
    import json
    from pendc.backend.hdl import build_hdl
    files = build_hdl(tanks_build.graph, tanks_build.resources.to_json(), bus=bus)
    top = module_names("tanks_core")[bus]
    assert "tanks_qdec.v" not in files and {"tanks_regs.v", f"{top}.v", "tanks_core.v"} <= set(files)
    report = json.loads(files["report.json"])
    assert "tanks_qdec.v" not in report["files"] and report["wrapper"] == top
    assert [r["name"] for r in report["registers"]] == expected_layout(_iface(tanks_build))
    assert any(f["frac"] > 0 for p, f in report["ports"].items() if p.endswith("_code"))   # bits below the code
    verilator = tool("verilator")
    names = write(tmp_path, {k: v for k, v in files.items() if k != "report.json"})
    res = run([verilator, "--lint-only", "-Wall", "--default-language", "1364-2005", "--top-module", top, *names],
              tmp_path)
    assert res.returncode == 0 and "%Warning" not in res.stderr and "%Error" not in res.stderr, res.stderr


def test_a_state_form_plant_without_rates_drifts_out_of_range(tanks_build, tb_modules):
    """No rate state, and the full push stays in range for the 4 s the vectors simulate: a level
    deposited near the top of its range drifts out under the full pump voltage, in the window the
    bus test's second burst covers (steps 1000..2000), both golden engines agreeing."""
    iface = _iface(tanks_build)
    assert not any(s.derivative_of for s in iface.states)
    o = _scenario(tanks_build, tb_modules)
    assert "unreachable" not in o and "error" not in o, o
    ov = tb_modules.ov
    assert not o["from_reset"] and o["k0"] == 0
    assert ov.EDGE_STEPS - ov.DRIFT_SLACK <= o["k_star"] <= ov.EDGE_STEPS and 1000 < o["k_star"] < 2000
    assert o["nodes"] and set(o["start"]) <= set(iface.outputs)
    u = o["u_win"]
    assert len(u) == ov.EDGE_RUN and (u == u[0]).all() and len(o["rows"]) == len(u) + 1
    # the deposit is the golden state: the rows start there and the state moves out, toward the edge
    (pos, value), = o["start"].items()
    col = list(tb_modules.rr.ports_of(tanks_build.graph).outputs).index(pos)
    fmt = tanks_build.graph[pos].qformat
    assert o["rows"][0][col] == fmt.from_float(value)
    assert o["rows"][o["k_star"]][col] > o["rows"][0][col]
    assert "near the top of its register's format" in o["how"] and "first overflowing" in o["how"]


def test_a_plant_nothing_drives_out_says_so_and_its_overflow_tests_skip(tanks_build, tb_modules, monkeypatch):
    """When no state drifts out under any constant input, the scenario names what was tried and
    the cocotb overflow tests skip with that reason (never pass)."""
    ov = tb_modules.ov
    monkeypatch.setattr(ov, "drift_start", lambda *a, **k: (None, "stays in range (stand-in)"))
    o = _scenario(tanks_build, tb_modules)
    assert set(o) == {"unreachable"}
    text = o["unreachable"]
    assert "no overflow can be provoked" in text and "no reported state has a rate state" in text
    for pos in ("h_1", "h_2"):
        assert f"{pos} at the top of its register's format" in text and f"{pos} at the bottom of its register's format" in text
    assert "V_p = 22 V" in text and "V_p = 0 V" in text
    pytest.importorskip("cocotb")
    import simlib
    monkeypatch.setattr(simlib, "_VECTORS", {"overflow": o})
    with pytest.raises(pytest.skip.Exception, match="no overflow can be provoked"):
        simlib.overflow_scenario()
    monkeypatch.setattr(simlib, "_VECTORS", {"overflow": {"error": "engines disagree"}})
    with pytest.raises(AssertionError, match="engines disagree"):
        simlib.overflow_scenario()


# ---------------------------------------------------------------- where the quick tests start

def test_the_quick_encoder_test_starts_where_an_encoder_moves(tb_modules):
    """From reset when an encoder moves 2 counts in the first 10 chunks; else (a slow plant: a
    pendubot under 1 N m turns its encoders by one count there) where an encoder moves most."""
    import numpy as np
    gv = tb_modules.gv
    chunks = gv.QUICK_LONG_CHUNKS
    cnt = np.zeros((60, 2), np.int64)
    cnt[:, 0] = np.minimum(np.arange(60), 2)          # 2 counts in the first chunks: from reset
    assert gv.encoders_start(cnt) == 0
    cnt[:, 0] = np.minimum(np.arange(60), 1)          # one count, then still
    cnt[30:, 1] = 3 * np.arange(30)                   # the second encoder moves from chunk 30 on
    at = gv.encoders_start(cnt)
    assert at >= 30 - chunks and at + chunks < 60
    part = cnt[at:at + chunks + 1]
    assert (part.max(axis=0) - part.min(axis=0)).max() == 3 * chunks
    assert gv.encoders_start(np.zeros((60, 0), np.int64)) == 0


def test_the_quick_converter_test_starts_where_the_most_codes_change(tb_modules):
    """A converter that sits on one code for the whole run (a maglev's gap with the ball on its
    post) does not keep the window from the one where the other converter's code changes; the
    vectors name it (``codes_static``)."""
    import numpy as np
    gv = tb_modules.gv
    from pendc.hil.plants.core_ports import CorePorts
    ports = CorePorts.of_interface(TANKS)
    n = 100
    rows = np.zeros((n, len(ports.outputs)), np.int64)
    c1, c2 = (ports.outputs.index(a.port) for a in ports.adcs)
    rows[:, c1] = 3501                                 # static everywhere
    rows[70:, c2] = np.arange(30)                      # moves from chunk 70 on only
    at = gv.codes_start(rows, ports, mid=n // 2)
    assert len(np.unique(rows[at:at + gv.QUICK_LONG_CHUNKS + 1, c2])) >= 2
    assert gv.codes_static(rows, ports) == [ports.adcs[0].name]
    rows[40:, c1] = 3500 + np.arange(n - 40) // 7       # both move from 70 on, only one at mid
    at = gv.codes_start(rows, ports, mid=n // 2)
    assert at >= 70 - gv.QUICK_LONG_CHUNKS and gv.codes_static(rows, ports) == []
