"""The backend on models other than the default: every lowerable effect reaches the Verilog,
which stays bit-exact with the golden model (plain Icarus testbench, a few thousand steps)."""

import shutil
import subprocess

import numpy as np
import pytest

from pendc import load_model
from pendc.backend.emit import render_core, write_tree
from pendc.golden import GoldenModel
from pendc.ident.datagen import HIDDEN_PARAMS
from pendc.passes.pipeline import BuildOptions, compile_model
from pendc.passes.ranges import per_step
from pendc.sim.stimuli import swing_up

pytestmark = pytest.mark.skipif(shutil.which("iverilog") is None, reason="Icarus Verilog (iverilog) not installed")

# every hidden effect of the identification data that has a hardware form
EFFECTS = {k: v for k, v in HIDDEN_PARAMS.items() if k != "input_delay"}
STEPS = 12000   # long enough for a lagging drive to break the cart loose

TESTBENCH = """`timescale 1ns/1ps
module tb;
  reg clk = 0, rst = 1, step = 0;
  reg signed [{uw}:0] u;
  wire ready, overflow;
  wire signed [{xw}:0] x; wire signed [{dxw}:0] dx; wire signed [{tw}:0] theta; wire signed [{dtw}:0] dtheta;
  wire ea, eb, ta, tb_;
  reg [{uw}:0] mem [0:{last}];
  integer k, f;
  pendulum_core dut(.clk(clk), .rst(rst), .step(step), .ready(ready), .u(u), .x(x), .dx(dx), .theta(theta),
    .dtheta(dtheta), .enc_x_a(ea), .enc_x_b(eb), .enc_theta_a(ta), .enc_theta_b(tb_), .overflow(overflow));
  always #5 clk = ~clk;
  initial begin
    $readmemh("u.hex", mem);
    f = $fopen("out.txt", "w");
    u = 0;
    @(negedge clk); @(negedge clk); rst = 0;
    for (k = 0; k <= {last}; k = k + 1) begin
      $fdisplay(f, "%0d %0d %0d %0d %0d%0d%0d%0d", x, dx, theta, dtheta, ea, eb, ta, tb_);
      u = mem[k]; step = 1;
      @(negedge clk); step = 0;
      while (!ready) @(negedge clk);
    end
    $fclose(f); $finish;
  end
endmodule
"""


@pytest.mark.parametrize("effect", sorted(EFFECTS))
def test_effect_reaches_the_verilog_bit_exactly(effect, tmp_path):
    model = load_model().with_effect(effect, EFFECTS[effect])
    # Without the error budget: what is checked is that the effect's nodes reach the Verilog and
    # the Verilog computes what the golden model computes, for whatever formats the graph has; the
    # budget would only widen some of them, at the cost of two more numba compilations of the whole
    # graph per round (most of this test's time). The budget's widening itself is bit-exact in
    # the default model's regression (test_sim.py) and checked in test_error_budget.py.
    build = compile_model(model, BuildOptions(training_scale=0.1, error_budget=False))
    view, files = render_core(build.graph, f"default + {effect}")
    write_tree(tmp_path / "hdl", files)
    golden = GoldenModel(build.graph, 1e-6)
    t, u = swing_up()      # inside what the short training covered, where cart and pendulum move
    ints = golden.quantize_input(per_step(u, t, 1e-6)[900_000:900_000 + STEPS])
    g = build.graph
    uw = g["u"].qformat.width
    (tmp_path / "u.hex").write_text("\n".join(f"{int(v) & ((1 << uw) - 1):x}" for v in ints) + "\n")
    widths = {p: g.output(p).qformat.width - 1 for p in ("x", "dx", "theta", "dtheta")}
    (tmp_path / "tb.v").write_text(TESTBENCH.format(uw=uw - 1, last=STEPS - 1, xw=widths["x"], dxw=widths["dx"],
                                                     tw=widths["theta"], dtw=widths["dtheta"]))
    sources = sorted(str(p) for p in (tmp_path / "hdl").glob("*.v"))
    subprocess.run(["iverilog", "-g2005", "-o", str(tmp_path / "sim.vvp"), str(tmp_path / "tb.v"), *sources],
                   check=True, capture_output=True)
    subprocess.run(["vvp", "-n", str(tmp_path / "sim.vvp")], cwd=tmp_path, check=True, capture_output=True)
    rtl = np.loadtxt(tmp_path / "out.txt", dtype=np.int64, usecols=(0, 1, 2, 3))
    trace = golden.run_steps(ints)
    gold = np.stack([np.asarray(trace.outputs[p], np.int64) for p in ("x", "dx", "theta", "dtheta")], 1)
    mismatch = np.flatnonzero((rtl != gold).any(axis=1))
    assert mismatch.size == 0, f"first mismatch at step {mismatch[0]}: rtl {rtl[mismatch[0]]} golden {gold[mismatch[0]]}"
    # something moved: the cart, and the pendulum's rate (12 ms from rest through a motor lag can
    # leave theta's increment below one LSB of its integrator input, so theta itself may still be 0)
    assert np.ptp(gold[:, 0]) > 0 and np.ptp(gold[:, 3]) > 0
    if effect == "cart_spring":
        # the spring multiplies x itself, or x narrowed to the multiplier's width first
        xs = {"x"} | {n.name for n in g.nodes if n.kind.value == "cast" and tuple(n.inputs) == ("x",)}
        assert any(n.kind.value in ("mul", "gain") for n in g.nodes if xs & set(n.inputs))
