"""The list scheduler (pendc.passes.schedule) and the pipelined / shared-multiplier Verilog it
drives: every schedule of a small plant runs bit-exact in Icarus against the compiled
golden kernel (the arithmetic never changes, only when it happens)."""

import math
import shutil
import subprocess

import numpy as np
import pytest

from pendc.backend.emit import render_core
from pendc.backend.memory_files import verilog_names
from pendc.errors import PendcError
from pendc.ir.compiled import CompiledGraph
from pendc.ir.graph import Graph
from pendc.ir.nodes import Kind, make
from pendc.ir.verify import verify
from pendc.passes.error_budget import check_stimuli
from pendc.passes.qformats import assign_qformats
from pendc.passes.ranges import analyze_ranges
from pendc.passes.resources import dsp_for, product_widths
from pendc.passes.schedule import schedule_for, schedule_graph
from pendc.passes.tabulate import fill_lut_tables, tabulate_luts
from plants import DEFAULT

DT = 1e-6
SHAPE = (18, 18)
STEPS = 300


def toy_plant(levels: dict):
    """Integrators fed through a table of u, a product of two signals and constant gains;
    ``levels``: products given wider operands (qformats: 1 = one side 32 bits, two DSP blocks)."""
    n = [make("u", Kind.INPUT, port="u", max_abs=10.0),
         make("y", Kind.LUT, ["u"], expr="sin(v)", lo=None, hi=None, periodic=False, addr_bits=5,
              interpolate=True),
         make("p", Kind.MUL, ["y", "dx"]), make("q", Kind.SUB, ["p", "dtheta"])]
    for s, src, gain in (("dx", "y", 2e-3), ("x", "dx", 1e-3), ("dtheta", "q", 5e-2), ("theta", "dtheta", 1e-3)):
        n += [make(s, Kind.REGISTER, [f"{s}_sum"], reset=0.0), make(f"{s}_inc", Kind.GAIN, [src], value=gain),
              make(f"{s}_sum", Kind.ADD, [s, f"{s}_inc"])]
    g = Graph.build("toy", n, [(s, s) for s in ("x", "dx", "theta", "dtheta")])
    ranges = analyze_ranges(g, check_stimuli(DEFAULT.interface.input, 0.02), DT)
    typed = fill_lut_tables(assign_qformats(tabulate_luts(g, ranges), ranges, margin_bits=2, shape=SHAPE,
                                            levels=levels))
    verify(typed, typed=True)
    return typed


@pytest.fixture(scope="module")
def plant():
    """The toy plant with every product fitted to one DSP block."""
    return toy_plant({})


@pytest.fixture(scope="module")
def wide_plant():
    """The toy plant with two-block products: a 32-bit table word, a 32-bit first operand, a 32-bit coefficient."""
    return toy_plant({"y": 1, "p": 1, "dx_inc": 1})


def products(g):
    return [n for n in g.nodes if product_widths(g, n) is not None]


def test_comb_schedule_is_the_table_stage_structure(plant):
    s = schedule_graph(plant)
    assert s.ii == 2 and not s.units and not s.rom_reg
    assert s.lut_addr["y"] == 0 and s.stage["y"] == 1
    assert s.stage["dx_inc"] == 1 and s.stage["x_inc"] == 0     # x_inc reads the state: no table before it


def test_clock_goal_pipelines_and_respects_dependencies(plant):
    s = schedule_graph(plant, 10.0)
    assert s.ii > 2
    for n in plant.nodes:
        for i in n.inputs:
            if n.kind not in (Kind.REGISTER, Kind.FSM) and plant[i].kind not in (Kind.REGISTER, Kind.FSM):
                assert s.stage[i] <= s.stage[n.name], (i, n.name)
    assert s.stage["y"] >= s.lut_addr["y"] + 1


def test_dsp_budget_limits_every_cycle_and_units_share(plant):
    s = schedule_graph(plant, 10.0, dsp=1, shape=SHAPE)
    used = {}
    for n in products(plant):
        used[s.stage[n.name]] = used.get(s.stage[n.name], 0) + dsp_for(*product_widths(plant, n), SHAPE)
    assert max(used.values()) <= 1
    assert len(s.units) == 1 and len(s.units[0].uses) == len(products(plant))
    assert len({c for _, c in s.units[0].uses}) == len(s.units[0].uses)     # one product per cycle


def test_ii_request_gives_exactly_that_many_cycles(plant):
    for ii in (3, 6):
        assert schedule_for(plant, SHAPE, ii=ii).ii == ii
    with pytest.raises(PendcError, match="at least 2"):
        schedule_for(plant, SHAPE, ii=1)
    with pytest.raises(PendcError, match="unknown preset"):
        schedule_for(plant, SHAPE, preset="turbo")


TB = """`timescale 1ns/1ps
module tb;
    reg clk = 1'b0, rst = 1'b1, step = 1'b0;
    reg signed [{uw}:0] u = 0;
    reg signed [{uw}:0] mem [0:{last}];
    wire ready, overflow;
    wire signed [{xw}:0] x; wire signed [{dxw}:0] dx; wire signed [{tw}:0] theta; wire signed [{dtw}:0] dtheta;
    {module} dut (.clk(clk), .rst(rst), .step(step), .ready(ready), .u(u), .x(x), .dx(dx),
                       .theta(theta), .dtheta(dtheta), .overflow(overflow));
    always #5 clk = ~clk;
    integer i, fd;
    initial begin
        $readmemh("u.hex", mem);
        fd = $fopen("out.txt", "w");
        @(negedge clk); @(negedge clk); rst = 1'b0;
        for (i = 0; i <= {last}; i = i + 1) begin
            u = mem[i]; step = 1'b1;
            @(negedge clk); step = 1'b0;
            while (!ready) @(negedge clk);
            $fwrite(fd, "%0d %0d %0d %0d %0d\\n", x, dx, theta, dtheta, overflow);
        end
        $fclose(fd);
        $finish;
    end
endmodule
"""


def run_icarus(graph, schedule, work):
    view, files = render_core(graph, schedule=schedule)
    work.mkdir()
    for name, text in files.items():      # the tables' .mem files too: the simulation runs in work
        (work / name).write_text(text)
    rng = np.random.default_rng(3)
    u = graph["u"].qformat
    ints = rng.integers(u.from_float(-9.0), u.from_float(9.0), STEPS)
    (work / "u.hex").write_text("".join(f"{int(v) & ((1 << u.width) - 1):x}\n" for v in ints))
    w = {k: graph[k].qformat.width - 1 for k in ("x", "dx", "theta", "dtheta")}
    (work / "tb.v").write_text(TB.format(module=view.module, uw=u.width - 1, last=STEPS - 1, xw=w["x"], dxw=w["dx"], tw=w["theta"],
                                         dtw=w["dtheta"]))
    subprocess.run(["iverilog", "-g2005", "-o", "sim", "tb.v", *verilog_names(files)], cwd=work, check=True)
    subprocess.run(["vvp", "-n", "sim"], cwd=work, check=True, capture_output=True)
    hw = np.loadtxt(work / "out.txt", dtype=np.int64)
    return view, ints, hw


@pytest.mark.skipif(shutil.which("iverilog") is None, reason="Icarus Verilog not installed")
@pytest.mark.parametrize("request_", [{"preset": "comb"}, {"preset": "fast"}, {"ii": 8, "dsp": 1},
                                      {"goal": 10.0, "wide": True}],
                         ids=["comb", "fast", "ii8-shared", "partial-products"])
def test_schedules_are_bit_exact_in_icarus(plant, wide_plant, request_, tmp_path):
    preset = request_.get("preset")
    if request_.get("wide"):        # 10 ns: a two-block product does not fit a cycle, its two blocks do
        plant = wide_plant
        s = schedule_graph(plant, request_["goal"], None, SHAPE)
        wide = [n.name for n in products(plant) if dsp_for(*product_widths(plant, n), SHAPE) == 2]
        assert len(wide) >= 3 and set(s.partial_reg) == set(wide)
    else:
        s = schedule_for(plant, SHAPE, ii=request_.get("ii"), dsp=request_.get("dsp"), preset=preset)
    view, ints, hw = run_icarus(plant, s, tmp_path / "hdl")
    assert view.ii == s.ii
    if request_.get("dsp"):
        assert s.ii == 8 and len(s.units) == 1 and view.dp.pipe_regs
    gold = CompiledGraph(plant, "fixed").run({"u": ints})     # row k: the state step k starts from
    expect = np.stack([gold.outputs[p][1:] for p in ("x", "dx", "theta", "dtheta")], axis=1)
    assert hw.shape == (STEPS, 5)
    assert np.abs(expect).max() > 1000                          # the plant moves
    np.testing.assert_array_equal(hw[:-1, :4], expect)
    # u reaches beyond the table's trained domain: the sticky flag rises after the same step as the golden one's
    assert gold.overflows and hw[:, 4].any()
    assert int(np.argmax(hw[:, 4])) == min(gold.overflows.values())
    assert math.isfinite(s.clock_ns) or preset == "comb"
    if s.partial_reg:       # the partial products are what the pipeline registers hold, not the whole product
        held = {src for _, _, _, src, _ in view.dp.pipe_regs}
        assert all(any(src.startswith(f"n_{node}") and src.endswith(("_xlo", "_xhi")) for src in held)
                   for node in s.partial_reg)


def test_fast_is_the_shortest_estimated_step_at_100mhz(plant):
    """``--preset fast``: of the clock goals up to its own (9.5 ns: 100 MHz less the routing the
    model misses), the shortest estimated step; among equal estimates the loosest goal."""
    from pendc.passes.schedule import FAST_GOALS, PRESETS
    limit = PRESETS["fast"][0]
    assert limit <= 10.0
    s = schedule_for(plant, SHAPE, preset="fast")
    assert s.clock_ns <= limit
    goals = [g for g in FAST_GOALS if g <= limit]
    others = {g: schedule_graph(plant, g, None, SHAPE) for g in goals}
    best = min(o.estimated_step_ns for o in others.values())
    assert s.estimated_step_ns == best
    assert s.clock_ns == max(g for g, o in others.items() if o.estimated_step_ns == best)
    assert s.estimated_step_ns == pytest.approx(s.ii * s.estimated_period_ns, abs=0.01)


def test_registered_products_read_registered_operands(plant):
    """A product registered before its rounding runs from registers: every computed operand is
    ready a cycle before the product's, and the node completes the cycle after it."""
    for goal in (6.0, 8.0, 10.0):
        s = schedule_graph(plant, goal, None, SHAPE)
        for node, cycle in s.product_reg.items():
            assert s.stage[node] == cycle + 1
            if plant[node].kind is not Kind.LUT:
                for i in plant[node].inputs:
                    if plant[i].kind not in (Kind.CONST, Kind.INPUT, Kind.REGISTER, Kind.FSM):
                        assert s.stage[i] < cycle, (node, i)
            else:
                assert cycle > s.lut_addr[node]


def test_delay_model_is_charged_per_cycle(plant):
    """The estimated period covers flip-flop overhead, so no schedule promises more than its goal
    once a product fits a cycle; a combinational schedule's period is its longest chain."""
    from pendc.passes.delays import ECP5_SPEED6
    assert ECP5_SPEED6.add(56) > ECP5_SPEED6.add(8)
    assert ECP5_SPEED6.product(32, 18, 2) > ECP5_SPEED6.product(18, 18, 1)
    for goal in (10.0, 15.0, 30.0):
        s = schedule_graph(plant, goal, None, SHAPE)
        assert ECP5_SPEED6.overhead() < s.estimated_period_ns <= goal
    comb = schedule_graph(plant)
    assert comb.estimated_period_ns > schedule_graph(plant, 10.0, None, SHAPE).estimated_period_ns


def test_shared_unit_mux_grows_with_its_uses():
    """A unit's operand mux: one LUT level up to four products, log2(uses) + 1 beyond (small's
    units of 12-14 products: five levels, as routed)."""
    from pendc.passes.delays import ECP5_SPEED6 as M
    from pendc.passes.schedule import operand_mux_delay
    assert operand_mux_delay(M, 2) == operand_mux_delay(M, 4) == M.lut_level
    assert operand_mux_delay(M, 13) == 5 * M.lut_level > operand_mux_delay(M, 5) == 4 * M.lut_level


def test_no_schedule_beats_the_step_bound(plant, wide_plant):
    """The critical chain of one step (pendc.passes.step_bound) is a lower bound of every
    schedule's estimated step under the same delay model, and its path runs from a state
    (or the input) to the register whose next value is latest."""
    from pendc.passes.step_bound import step_bound
    for g in (plant, wide_plant):
        bound = step_bound(g, shape=SHAPE)
        schedules = [schedule_graph(g)] + [schedule_graph(g, goal, None, SHAPE) for goal in (6.0, 10.0, 15.0, 30.0)]
        assert all(bound.bound_ns <= s.estimated_step_ns + 1e-9 for s in schedules)
        first, last = bound.path[0][0], bound.path[-1][0]
        assert g[first].kind in (Kind.REGISTER, Kind.INPUT, Kind.FSM)
        assert any(r.inputs[0] == last for r in g.of_kind(Kind.REGISTER)) and max(bound.ends.values()) == bound.bound_ns
        assert [t for _, t in bound.path] == sorted(t for _, t in bound.path)


def test_step_bound_what_ifs(wide_plant):
    """One-block products shorten the chain of a plant with two-block products on it; a table read
    a step ahead starts the step as a register, and its own read joins the ends."""
    from pendc.passes.step_bound import step_bound
    base = step_bound(wide_plant, shape=SHAPE)
    assert step_bound(wide_plant, shape=SHAPE, one_block=True).bound_ns < base.bound_ns
    ahead = step_bound(wide_plant, shape=SHAPE, lookahead=("y",))
    assert "y (next step)" in ahead.ends and ahead.bound_ns <= base.bound_ns
    assert all(name != "y" or t < 1.0 for name, t in ahead.path)


def test_fmax_preset_is_the_10ns_goal(wide_plant):
    """``--preset fmax``: the 10 ns goal itself (not a tighter goal that ties on the estimate), with
    the two-block products registered at their partial products, so no cycle holds two blocks."""
    s = schedule_for(wide_plant, SHAPE, preset="fmax")
    assert s.clock_ns == 10.0 and s.preset == "fmax" and s.partial_reg
    assert s == schedule_graph(wide_plant, 10.0, None, SHAPE, "fmax")


@pytest.mark.parametrize("signed", [True, False])
def test_overflow_term_as_the_backend_emits_it(signed):
    """node_delay.requant_can_overflow says exactly when backend.arith.requantize registers an
    overflow term (what the step-time presets charge a LUT level and the flag's OR for)."""
    from pendc.backend.arith import Netlist, requantize
    from pendc.ir.qformat import Overflow, QFormat, Rounding
    from pendc.passes.node_delay import requant_can_overflow
    seen = set()
    for w in (4, 9):
        for f in (0, 3, 5):
            q = QFormat(signed, w, min(f, w - 1))
            for ow in (3, 4, 9, 10, 12):
                for of in (0, 2, 3, 6):
                    out = QFormat(True, ow, min(of, ow - 1))
                    for rounding in (Rounding.NEAREST, Rounding.TRUNCATE):
                        net = Netlist()
                        requantize(net, "v", "x", q.width, q.frac, out, rounding, Overflow.WRAP, "n", signed=signed)
                        emitted = bool(net.overflow)
                        assert requant_can_overflow(q, out, rounding) == emitted, (q, out, rounding)
                        seen.add(emitted)
    assert seen == {True, False}
