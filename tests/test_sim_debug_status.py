"""Issue 11 point 2: a debug build's per-node overflow status, against the golden model's error.

The debug build of the default model (Table 14 has no track ends, so a full push drives the
cart out of x's format) starts from a golden state a little before the edge of the format.
The golden model raises :class:`pendc.golden.OverflowStop` naming a node and a step; the
cocotb test (tb/test_debug_status.py) reads the OVERFLOW_STATUS words over the bus and finds
every bit clear before that step and exactly the bits of the nodes that overflow in it after
it. Icarus runs it on both buses (RAPTOR and AXI4-Lite), Verilator on the RAPTOR bus (its
build of a wrapper takes minutes). The normal build stays byte-identical (test_emit_debug).
"""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tb"))

import pendtb  # noqa: E402

PUSH_V = 10.0
MARGIN_M = 2e-4          # start this far below the top of x's format, moving out at DX0
DX0 = 0.3


@pytest.fixture(scope="module")
def prepared(tmp_path_factory):
    from pendc.golden import GoldenModel, OverflowStop
    from pendc.hil.plants.golden_plant import GoldenPlant
    from pendc.hil.plants.rtl_plant import deposit_registers

    work = tmp_path_factory.mktemp("debug_status")
    model, build = pendtb.model_and_build()
    hdl, reports = {}, {}
    for bus in ("raptor", "axi-lite"):
        hdl[bus] = work / f"hdl_{bus.replace('-', '')}"
        reports[bus] = pendtb.emit_debug_hdl(model, build, hdl[bus], bus)
    graph, dt = build.graph, build.options.dt
    initial = (graph.output("x").qformat.max_value - MARGIN_M, DX0, 0.0, 0.0)
    with pytest.raises(OverflowStop) as stop:
        GoldenModel(graph, dt)(np.array([0.0, 5000 * dt]), np.array([PUSH_V, PUSH_V]), initial=initial)
    k_star = stop.value.step
    golden = GoldenPlant(model, build=build, initial=initial, on_overflow="mark")
    if k_star:
        golden.step(PUSH_V, k_star)
    x_before = golden.raw()["x"]
    assert not golden.overflows, f"overflow before the step the golden model raised at: {golden.overflows}"
    golden.step(PUSH_V, 1)
    nodes = sorted(golden.overflows)
    assert stop.value.node in nodes and set(golden.overflows.values()) == {k_star}
    start = GoldenPlant(model, build=build, initial=initial)
    deposit = {reg: (value, width) for (reg, width), value in zip(deposit_registers(graph), start.registers())}
    vec = {"reports": reports, "period_ns": pendtb.PERIOD_NS, "ii": reports["raptor"]["ii"],
           "status_nodes": reports["raptor"]["overflow_status_nodes"], "deposit": deposit,
           "u": golden.quantize_input(PUSH_V), "k_star": k_star, "nodes": nodes, "x_before": x_before}
    path = work / "vectors.pickle"
    path.write_bytes(pickle.dumps(vec))
    return pendtb.Prepared(work=work, hdl=hdl, report=reports, tb_top=None, vectors=path, build=build), vec


def test_the_debug_build_lists_every_node_in_order(prepared):
    prep, vec = prepared
    report = prep.report["raptor"]
    nodes = report["overflow_status_nodes"]
    assert nodes == sorted(set(nodes)) and set(vec["nodes"]) <= set(nodes)
    words = [r for r in report["registers"] if r["name"].startswith("OVERFLOW_STATUS_")]
    assert len(words) == (len(nodes) + 31) // 32
    assert words[0]["offset"] == max(r["offset"] for r in report["registers"] if r not in words) + 4
    for k, w in enumerate(words):       # every node named at its bit in the map's description
        for i, node in enumerate(nodes[32 * k:32 * k + 32]):
            assert f"bit {i} {node}" in w["description"]
    core = (prep.hdl["raptor"] / "pendulum_core.v").read_text()
    assert f"output wire [{len(nodes) - 1}:0] overflow_status," in core


@pytest.mark.parametrize("sim, suites", [("icarus", ("debug_raptor", "debug_axil")),
                                         ("verilator", ("debug_raptor",))])
def test_status_bits_name_the_golden_node_at_its_step(prepared, sim, suites, tmp_path):
    prep, vec = prepared
    why = pendtb.simulator_missing(sim)
    if why:
        pytest.skip(why)
    print(f"golden: step {vec['k_star']} overflows {vec['nodes']}")
    problems = []
    for suite in suites:
        r = pendtb.run_suite(prep, sim, suite, tmp_path)
        if r.tests == 0:
            problems.append(f"{sim}/{suite}: no cocotb test ran (log {r.log})")
        problems += [f"{sim}/{suite}: {f}" for f in r.failures]
    assert not problems, "cocotb failures:\n" + "\n".join(problems)
