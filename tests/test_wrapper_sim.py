"""Bus wrappers in simulation (Icarus): the quadrature decoder, a lockstep burst through each
bus (RAPTOR local bus, AXI4-Lite) against the golden model, and wrappers around cores with
other port formats (a narrow input, a rotor plant, no encoders, ii = 1)."""

import math
import re
from types import SimpleNamespace

import numpy as np
import pytest

from pendc.backend.wrapper import render_wrapper
from pendc.golden import GoldenModel
from pendc.model.interface import InputSpec, PlantInterface, StateSpec
from pendc.model.sensors import SensorSpec
from stand_in_core import RAPTOR_SIGNALS, RAPTOR_TASKS, stand_in_core
from wrapper_bench import ENCODERS, build, rendered, run, tool, write  # noqa: F401 (build, rendered: fixtures)


# ---------------------------------------------------------------- simulation

QDEC_TB = r"""
`timescale 1ns/1ps
module tb_qdec;
    reg clk = 1'b0;
    always #5 clk = !clk;
    reg clr = 1'b1, a = 1'b0, b = 1'b0;
    wire [31:0] count;
    pendulum_qdec dut (.clk(clk), .clr(clr), .a(a), .b(b), .count(count));
    integer i;
    // A leads B: 00 -> 10 -> 11 -> 01 -> 00
    task fwd;
        begin @(negedge clk); if (!a && !b) a = 1; else if (a && !b) b = 1; else if (a && b) a = 0; else b = 0; end
    endtask
    task back;
        begin @(negedge clk); if (!a && !b) b = 1; else if (!a && b) a = 1; else if (a && b) b = 0; else a = 0; end
    endtask
    initial begin
        @(negedge clk); @(negedge clk); clr = 0;
        for (i = 0; i < 10; i = i + 1) fwd;
        @(negedge clk); $display("C fwd10 %0d", $signed(count));
        for (i = 0; i < 13; i = i + 1) back;
        @(negedge clk); $display("C back13 %0d", $signed(count));
        @(negedge clk); a = !a; b = !b;                 // both lines at once: ignored
        @(negedge clk); @(negedge clk); $display("C both %0d", $signed(count));
        clr = 1;                                        // the sample after a clear is not counted
        @(negedge clk); clr = 0; a = !a;
        @(negedge clk); @(negedge clk); $display("C clear %0d", $signed(count));
        $finish;
    end
endmodule
"""


def test_quadrature_decoder(rendered, tmp_path):
    iverilog, vvp = tool("iverilog"), tool("vvp")
    write(tmp_path, {"pendulum_qdec.v": rendered["raptor"][0]["pendulum_qdec.v"], "tb_qdec.v": QDEC_TB})
    res = run([iverilog, "-g2005", "-s", "tb_qdec", "-o", "tb.vvp", "pendulum_qdec.v", "tb_qdec.v"], tmp_path)
    assert res.returncode == 0, res.stderr
    res = run([vvp, "-n", "tb.vvp"], tmp_path)
    got = dict(re.findall(r"^C (\w+) (-?\d+)$", res.stdout, re.M))
    assert got == {"fwd10": "10", "back13": "-3", "both": "-3", "clear": "0"}, res.stdout


def bus_testbench(regs: list) -> str:
    """Plain Verilog-2005 testbench driving both wrappers with one register sequence."""
    lp = "\n".join(f"    localparam [7:0] {r['name']} = 8'h{r['offset']:02x};" for r in regs)
    return r"""
`timescale 1ns/1ps
module tb;
    reg clk = 1'b0;
    always #5 clk = !clk;
    reg rst = 1'b1;
""" + lp + r"""
    localparam [7:0] UNMAPPED = 8'hf0;
    // RAPTOR local bus
    reg  [7:0]  addr = 8'd0;
    reg  [31:0] wdata = 32'd0;
    reg         wr = 1'b0, rd = 1'b0;
    wire [31:0] rdata;
    wire        ack;
    wire [3:0]  enc_r;
    pendulum_raptor dut_r (.clk(clk), .rst(rst), .addr(addr), .wdata(wdata), .wr(wr), .rd(rd),
        .rdata(rdata), .ack(ack), .enc_x_a(enc_r[0]), .enc_x_b(enc_r[1]), .enc_theta_a(enc_r[2]),
        .enc_theta_b(enc_r[3]));
    // AXI4-Lite
    reg  [7:0]  awaddr = 8'd0, araddr = 8'd0;
    reg         awvalid = 1'b0, wvalid = 1'b0, bready = 1'b0, arvalid = 1'b0, rready = 1'b0;
    reg  [31:0] wdata_a = 32'd0;
    wire        awready, wready, bvalid, arready, rvalid;
    wire [1:0]  bresp, rresp;
    wire [31:0] rdata_a;
    wire [3:0]  enc_a;
    pendulum_axil dut_a (.aclk(clk), .aresetn(!rst),
        .s_axi_awaddr(awaddr), .s_axi_awprot(3'd0), .s_axi_awvalid(awvalid), .s_axi_awready(awready),
        .s_axi_wdata(wdata_a), .s_axi_wstrb(4'hf), .s_axi_wvalid(wvalid), .s_axi_wready(wready),
        .s_axi_bresp(bresp), .s_axi_bvalid(bvalid), .s_axi_bready(bready),
        .s_axi_araddr(araddr), .s_axi_arprot(3'd0), .s_axi_arvalid(arvalid), .s_axi_arready(arready),
        .s_axi_rdata(rdata_a), .s_axi_rresp(rresp), .s_axi_rvalid(rvalid), .s_axi_rready(rready),
        .enc_x_a(enc_a[0]), .enc_x_b(enc_a[1]), .enc_theta_a(enc_a[2]), .enc_theta_b(enc_a[3]));

    reg axi;            // which bus the sequence uses
    reg [31:0] q;
    integer errors = 0, polls, t0;

    // all bus signals change on the falling edge; the slaves sample on the rising edge
    task r_write(input [7:0] a, input [31:0] d);
        begin
            @(negedge clk); addr = a; wdata = d; wr = 1'b1;
            @(negedge clk); wr = 1'b0;
            if (ack !== 1'b1) begin errors = errors + 1; $display("E no ack after write"); end
        end
    endtask
    task r_read(input [7:0] a, output [31:0] d);
        begin
            @(negedge clk); addr = a; rd = 1'b1;
            @(negedge clk); rd = 1'b0; d = rdata;
            if (ack !== 1'b1) begin errors = errors + 1; $display("E no ack after read"); end
        end
    endtask
    task a_write(input [7:0] a, input [31:0] d);
        reg hs_aw, hs_w;
        begin
            @(negedge clk); awaddr = a; awvalid = 1'b1; wdata_a = d; wvalid = 1'b1; bready = 1'b1;
            while (awvalid || wvalid) begin
                hs_aw = awvalid && awready; hs_w = wvalid && wready;
                @(negedge clk);
                if (hs_aw) awvalid = 1'b0;
                if (hs_w) wvalid = 1'b0;
            end
            while (bvalid !== 1'b1) @(negedge clk);
            if (bresp !== 2'b00) begin errors = errors + 1; $display("E bresp %b", bresp); end
            @(negedge clk); bready = 1'b0;
        end
    endtask
    task a_read(input [7:0] a, output [31:0] d);
        reg hs;
        begin
            @(negedge clk); araddr = a; arvalid = 1'b1; rready = 1'b1;
            while (arvalid) begin
                hs = arready;
                @(negedge clk);
                if (hs) arvalid = 1'b0;
            end
            while (rvalid !== 1'b1) @(negedge clk);
            d = rdata_a;
            if (rresp !== 2'b00) begin errors = errors + 1; $display("E rresp %b", rresp); end
            @(negedge clk); rready = 1'b0;
        end
    endtask
    task wr32(input [7:0] a, input [31:0] d);
        begin if (axi) a_write(a, d); else r_write(a, d); end
    endtask
    task rd32(input [7:0] a, output [31:0] d);
        begin if (axi) a_read(a, d); else r_read(a, d); end
    endtask
    task show(input [8*24-1:0] name, input [7:0] a);
        begin rd32(a, q); $display("R %0d %0s %h", axi, name, q); end
    endtask
    task wait_idle;
        begin
            polls = 0; q = 32'h2;
            while (q[1] && polls < 10000) begin rd32(STATUS, q); polls = polls + 1; end
            $display("R %0d POLLS %h", axi, polls);
        end
    endtask

    task sequence;
        begin
            show("ID", ID); show("VERSION", VERSION); show("BUILD_ID", BUILD_ID); show("CONFIG", CONFIG);
            show("STATUS0", STATUS);
            wr32(UNMAPPED, 32'hdeadbeef); show("UNMAPPED", UNMAPPED);
            wr32(ID, 32'h12345678); show("ID_AFTER_WRITE", ID);
            wr32(STEP_DIV, 32'd0); show("STEP_DIV_CLAMPED", STEP_DIV);
            wr32(U, `U_WORD); show("U", U);
            wr32(N_STEPS, 32'd100);
            wr32(CONTROL, 32'h2);                      // LOCKSTEP
            show("STATUS_BUSY", STATUS);
            wait_idle;
            show("STATUS_DONE", STATUS); show("STEPS_LEFT", STEPS_LEFT);
            show("STEP_COUNT_LO", STEP_COUNT_LO); show("STEP_COUNT_HI", STEP_COUNT_HI);
            show("X_LO", X_LO); show("X_HI", X_HI); show("DX_LO", DX_LO); show("DX_HI", DX_HI);
            show("THETA_LO", THETA_LO); show("THETA_HI", THETA_HI);
            show("DTHETA_LO", DTHETA_LO); show("DTHETA_HI", DTHETA_HI);
            show("ENC", ENC); show("ENC_X_COUNT", ENC_X_COUNT); show("ENC_THETA_COUNT", ENC_THETA_COUNT);
            show("OVERFLOW", OVERFLOW);
            q = axi ? dut_a.u_regs.core_overflow : dut_r.u_regs.core_overflow;
            $display("R %0d CORE_OVERFLOW %h", axi, q);
            wr32(OVERFLOW, 32'h1); show("OVERFLOW_W1C", OVERFLOW);
            // a rising core flag sets the sticky bit (forced here: the model itself may not overflow)
            @(negedge clk);
            if (axi) force dut_a.u_regs.core_overflow = 1'b0; else force dut_r.u_regs.core_overflow = 1'b0;
            @(negedge clk);
            if (axi) force dut_a.u_regs.core_overflow = 1'b1; else force dut_r.u_regs.core_overflow = 1'b1;
            @(negedge clk);
            if (axi) release dut_a.u_regs.core_overflow; else release dut_r.u_regs.core_overflow;
            show("OVERFLOW_RISE", OVERFLOW); show("STATUS_OVERFLOW", STATUS);
            wr32(OVERFLOW, 32'h1); show("OVERFLOW_CLEARED", OVERFLOW);
            wr32(CONTROL, 32'h4);                      // single step
            wait_idle; show("STEP_COUNT_SINGLE", STEP_COUNT_LO);
            wr32(STEP_DIV, 32'd10); show("STEP_DIV", STEP_DIV);
            wr32(CONTROL, 32'h1);                      // free run
            show("STATUS_RUN", STATUS);
            t0 = $time;
            #2000;                                     // 200 cycles
            wr32(CONTROL, 32'h0);
            #100;
            show("STEP_COUNT_RUN", STEP_COUNT_LO);
            wr32(CONTROL, 32'h8);                      // soft reset
            show("STATUS_RESET", STATUS); show("STEP_COUNT_RESET", STEP_COUNT_LO);
            show("X_LO_RESET", X_LO); show("X_HI_RESET", X_HI);
            show("DX_LO_RESET", DX_LO); show("ENC_X_COUNT_RESET", ENC_X_COUNT);
            show("ENC_THETA_COUNT_RESET", ENC_THETA_COUNT); show("U_KEPT", U);
        end
    endtask

    initial begin
        repeat (4) @(negedge clk);
        rst = 1'b0;
        axi = 1'b0; sequence;
        axi = 1'b1; sequence;
        if (enc_r !== {dut_r.u_regs.u_core.enc_theta_b, dut_r.u_regs.u_core.enc_theta_a,
                       dut_r.u_regs.u_core.enc_x_b, dut_r.u_regs.u_core.enc_x_a}) begin
            errors = errors + 1; $display("E encoder pins");
        end
        $display("R 9 ERRORS %h", errors);
        $finish;
    end
    initial begin
        #5000000; $display("E timeout"); $finish;
    end
endmodule
"""


def quad_count(a, b) -> int:
    """x4 count of a sampled A/B pair (up when A leads), as the decoder in the wrapper counts."""
    n = 0
    for k in range(1, len(a)):
        if (a[k] ^ a[k - 1] ^ b[k] ^ b[k - 1]) & 1:
            n += -1 if a[k - 1] ^ b[k] else 1
    return n


def word(v: int) -> int:
    return v & 0xFFFFFFFF


def test_lockstep_through_both_buses(build, rendered, tmp_path):
    """Write U, run 100 lockstep steps, read back count, states and encoder counts via each bus;
    then a single step, a short free run, and a soft reset."""
    iverilog, vvp = tool("iverilog"), tool("vvp")
    regs = rendered["raptor"][1]["registers"]
    golden = GoldenModel(build["graph"], 1e-6)
    u_int = int(golden.quantize_input([2.0])[0])
    trace = golden.run_steps(np.full(101, u_int, dtype=np.int64))
    out = {k: [int(v) for v in np.asarray(trace.outputs[k])] for k in trace.outputs}
    files = dict(build["core"])
    files.update(rendered["raptor"][0])
    files.update(rendered["axi-lite"][0])
    files["tb.v"] = bus_testbench(regs)
    names = write(tmp_path, files)
    res = run([iverilog, "-g2005", "-s", "tb", f"-DU_WORD=32'd{word(u_int)}", "-o", "tb.vvp", *names], tmp_path)
    assert res.returncode == 0, res.stderr
    res = run([vvp, "-n", "tb.vvp"], tmp_path, timeout=60)
    assert not re.search(r"^E ", res.stdout, re.M), res.stdout
    got = {}
    for axi, name, value in re.findall(r"^R (\d) (\w+) ([0-9a-fx]+)$", res.stdout, re.M):
        got.setdefault(int(axi), {})[name] = int(value, 16)
    assert got[9]["ERRORS"] == 0
    ports, ident, ii = build["ports"], build["ident"], build["view"].ii
    u = ports["u"]
    for axi in (0, 1):
        r = got[axi]
        assert r["ID"] == 0x50454E44 and r["BUILD_ID"] == ident and r["VERSION"] == 0x00010000
        assert r["CONFIG"] == ii | (u["width"] << 8) | ((u["frac"] & 0xFF) << 16)
        assert r["UNMAPPED"] == 0 and r["ID_AFTER_WRITE"] == 0x50454E44
        assert r["STEP_DIV_CLAMPED"] == ii and r["STEP_DIV"] == 10
        assert r["U"] == word(u_int) and r["U_KEPT"] == word(u_int)
        assert r["STATUS0"] == 0 and r["STATUS_BUSY"] & 2 and r["STATUS_DONE"] & 3 == 0
        assert r["STEPS_LEFT"] == 0
        assert (r["STEP_COUNT_LO"], r["STEP_COUNT_HI"]) == (100, 0)
        for s in ("x", "dx", "theta", "dtheta"):
            value = out[s][100]
            assert r[f"{s.upper()}_LO"] == word(value), s
            assert r[f"{s.upper()}_HI"] == word(value >> 32), s
        lines = [out[p][100] for p in ENCODERS]
        assert r["ENC"] == lines[0] | lines[1] << 1 | lines[2] << 2 | lines[3] << 3
        assert r["ENC_X_COUNT"] == word(quad_count(out["enc_x_a"], out["enc_x_b"]))
        assert r["ENC_THETA_COUNT"] == word(quad_count(out["enc_theta_a"], out["enc_theta_b"]))
        core_ovf = r["CORE_OVERFLOW"] & 1          # the core's own flag (compared with the golden elsewhere)
        assert r["OVERFLOW"] == core_ovf << 1 | core_ovf and r["STATUS_DONE"] >> 2 == core_ovf
        assert r["OVERFLOW_W1C"] == core_ovf << 1
        assert r["OVERFLOW_RISE"] == core_ovf << 1 | 1 and r["STATUS_OVERFLOW"] & 4
        assert r["OVERFLOW_CLEARED"] == core_ovf << 1
        assert r["STEP_COUNT_SINGLE"] == 101
        assert r["STATUS_RUN"] & 1
        assert 101 + 17 <= r["STEP_COUNT_RUN"] <= 101 + 23    # ~200 cycles at 10 cycles per step
        assert r["STATUS_RESET"] == 0 and r["STEP_COUNT_RESET"] == 0
        assert (r["X_LO_RESET"], r["X_HI_RESET"], r["DX_LO_RESET"]) == (word(out["x"][0]), word(out["x"][0] >> 32),
                                                                     word(out["dx"][0]))
        assert r["ENC_X_COUNT_RESET"] == 0 and r["ENC_THETA_COUNT_RESET"] == 0


# ---------------------------------------------------------------- other port formats, ii = 1

# a made-up second plant: one rotor, one input, one encoder; no name shared with the pendulum
ROTOR = PlantInterface(
    name="rotor", core="rotor_core",
    states=(StateSpec("phi", "rad", "rotor angle (rad)", body="rotor", quantity="angle", period=2 * math.pi,
                      turns=4),
            StateSpec("dphi", "rad/s", "rotor rate (rad/s)", body="rotor", quantity="rate", derivative_of="phi")),
    inputs=(InputSpec("torque", "N*m", "motor torque (N*m)", 1.0),),
    sensors=(SensorSpec("enc_phi", "phi", "rotor", band=2 * math.pi / 2000, lines=1000, bands_per_rev=2000),))


def tiny_tb(plant) -> str:
    """Writes the input, runs a burst of 5 steps and reads back the first state, the encoder
    lines and the first encoder's count, by the plant's own register names."""
    names = plant.register_names()
    channels = [c for sensor in plant.sensors for c in sensor.channels]
    conns = "".join(f", .{c}(enc[{i}])" for i, c in enumerate(channels))
    (u_reg,), (lo, hi) = names[plant.input.name], names[plant.outputs[0]]
    count = names[plant.sensors[0].name][0]
    return rf"""
`timescale 1ns/1ps
module tb_tiny;
    reg clk = 1'b0;
    always #5 clk = !clk;
    reg rst = 1'b1;
{RAPTOR_SIGNALS}    wire [{max(len(channels), 1) - 1}:0]  enc;
    tiny_raptor dut (.clk(clk), .rst(rst), .addr(addr), .wdata(wdata), .wr(wr), .rd(rd),
        .rdata(rdata), .ack(ack){conns});
{RAPTOR_TASKS}    initial begin
        repeat (3) @(negedge clk);
        rst = 1'b0;
        w(`{u_reg}, 32'h00018000); show("U", `{u_reg});
        w(`N_STEPS, 32'd5); w(`CONTROL, 32'h2);
        q = 32'h2;
        while (q[1]) r(`STATUS, q);
        show("STEP_DIV", `STEP_DIV);
        show("COUNT", `STEP_COUNT_LO); show("X_LO", `{lo}); show("X_HI", `{hi});
        show("ENC", `ENC); show("ENC_COUNT", `{count});
        $display("R U_CORE %h", dut.u_regs.u_core.u_seen);
        $finish;
    end
endmodule
"""


@pytest.mark.parametrize("uw,w,encoders,plant", [(16, 20, True, "pendulum"), (32, 64, False, "pendulum"),
                                                 (9, 33, True, "pendulum"), (12, 40, True, "rotor")])
def test_other_formats_lint_and_run(uw, w, encoders, plant, build, tmp_path):
    """Narrow inputs, states of 20/33/64 bits, a core without encoder lines, ii = 1 (steps back to
    back), and a second plant, whose wrapper takes every name from its plant interface."""
    verilator, iverilog, vvp = tool("verilator"), tool("iverilog"), tool("vvp")
    plant = build["view"].interface if plant == "pendulum" else ROTOR
    ports = {plant.input.name: {"signed": True, "width": uw, "frac": uw - 4}}
    ports.update({s: {"signed": True, "width": w, "frac": w - 8} for s in plant.outputs})
    channels = [c for sensor in plant.sensors for c in sensor.channels]
    view = SimpleNamespace(module="tiny_core", ii=1, interface=plant,
                           ports=[("input", plant.input.name, uw, True)] + [("output", s, w, True) for s in plant.outputs]
                           + ([("output", e, 1, False) for e in channels] if encoders else []))
    files, meta = render_wrapper(view, ports, 0x1234, "raptor")
    assert sorted(files) == ["tiny_qdec.v", "tiny_raptor.v", "tiny_regs.v"] and meta["module"] == "tiny_raptor"
    regs = {r["name"] for r in meta["registers"]}
    assert {r for pair in plant.register_names().values() for r in pair} <= regs
    names = write(tmp_path, files, {"tiny_core.v": stand_in_core(plant, uw, w, encoders=encoders)})
    (tmp_path / "tb.v").write_text(tiny_tb(plant))
    res = run([verilator, "--lint-only", "-Wall", "--default-language", "1364-2005", "--top-module",
               "tiny_raptor", *names], tmp_path)
    assert res.returncode == 0 and "%Warning" not in res.stderr, res.stderr
    defines = [f"-D{r['name']}=8'h{r['offset']:02x}" for r in meta["registers"]]
    res = run([iverilog, "-g2005", "-s", "tb_tiny", *defines, "-o", "tb.vvp", *names, "tb.v"], tmp_path)
    assert res.returncode == 0, res.stderr
    res = run([vvp, "-n", "tb.vvp"], tmp_path)
    got = {k: int(v, 16) for k, v in re.findall(r"^R (\w+) ([0-9a-fx]+)$", res.stdout, re.M)}
    u_low = 0x00018000 & ((1 << uw) - 1)
    u_signed = u_low - (1 << uw) if u_low >> (uw - 1) else u_low
    assert got["U"] == word(u_signed) and got["U_CORE"] == u_low
    assert got["STEP_DIV"] == 1 and got["COUNT"] == 5
    assert (got["X_LO"], got["X_HI"]) == (5, 0)
    assert got["ENC"] == ((5 & ((1 << len(channels)) - 1)) if encoders else 0)
    assert got["ENC_COUNT"] == (word(quad_count([0, 1, 0, 1, 0, 1], [0, 0, 1, 1, 0, 0])) if encoders else 0)


