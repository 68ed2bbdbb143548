"""Bus wrappers (RAPTOR local bus, AXI4-Lite): register map, rendering, lint, port lists and the
debug build's overflow status words. Their simulations are tests/test_wrapper_sim.py."""

import re

import pytest

from pendc.backend.emit import render_core
from pendc.backend.wrapper import BUSES, markdown_table, register_map, render_wrapper
# build, rendered: fixtures
from wrapper_bench import ENCODERS, ROOT, TOOL_PATH, TOPS, build, rendered, run, tool, write  # noqa: F401


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
