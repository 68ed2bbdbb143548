"""The emitted HDL: deterministic, the committed hdl_out/ is current, report.json describes it."""

import json
import random
import re
import shutil
import subprocess
from collections import Counter
from pathlib import Path

import pytest

from pendc import load_model
from pendc.backend.hdl import build_hdl, write_hdl
from pendc.caching.build_cache import compile_cached
from pendc.ir.nodes import Kind

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def files():
    build = compile_cached(load_model())
    return build_hdl(build.graph, build.resources.to_json(), source="models/sct_thesis_final.toml")


def test_rebuilding_gives_identical_files(files):
    build = compile_cached(load_model())
    again = build_hdl(build.graph, build.resources.to_json(), source="models/sct_thesis_final.toml")
    assert again == files


def test_committed_hdl_out_is_current(capsys):
    """Exactly what `pendc build --check` (the command that writes hdl_out/) says."""
    from pendc.cli import main

    assert main(["build", "--check", "-o", str(ROOT / "hdl_out")]) == 0, \
        f"run `pendc build` and commit hdl_out/: {capsys.readouterr().err.strip()}"


def test_report_json_describes_the_build(files):
    report = json.loads(files["report.json"])
    assert report["top"] == "pendulum_core" and report["dt"] == 1e-6 and report["ii"] >= 1
    assert set(report["ports"]) == {"u", "x", "dx", "theta", "dtheta"}
    for port in report["ports"].values():
        assert set(port) == {"signed", "width", "frac"}
    assert set(report["files"]) == set(files)
    assert report["registers"] and report["qformats"]["ddx"].startswith("FIX")
    assert report["resources"]["dsp18"] > 0
    core = files["pendulum_core.v"]
    for name, port in report["ports"].items():
        assert f"signed [{port['width'] - 1}:0] {name}" in core


def test_every_table_is_one_instance_of_one_rom_module_with_its_words_in_a_mem_file(files):
    """One parameterised ROM module; per LUT node one instance naming its .mem file, whose
    words (one a line, hexadecimal) fill exactly the instance's depth and data width."""
    graph = compile_cached(load_model()).graph
    luts = sorted(n.name for n in graph.nodes if n.kind is Kind.LUT)
    assert luts and sorted(n for n in files if n.endswith(".mem")) == [f"pendulum_core_rom_{t}.mem" for t in luts]
    assert re.findall(r"^module (\w+)", files["pendulum_core_rom.v"], re.M) == ["pendulum_core_rom"]
    assert "$readmemh(INIT_FILE, mem)" in files["pendulum_core_rom.v"]
    core = " ".join(files["pendulum_core.v"].split())
    instances = re.findall(r"pendulum_core_rom #\(\.ADDR_WIDTH\((\d+)\), \.DATA_WIDTH\((\d+)\), \.DEPTH\((\d+)\), "
                           r'\.INIT_FILE\("([\w.]+)"\)\) u_rom_(\w+) \(', core)
    assert sorted(i[4] for i in instances) == luts
    for addr_width, data_width, depth, mem, table in instances:
        assert mem == f"pendulum_core_rom_{table}.mem"
        words = [ln for ln in files[mem].splitlines() if not ln.startswith("//")]
        assert len(words) == int(depth) <= 2 ** int(addr_width), mem
        assert {len(w) for w in words} == {(int(data_width) + 3) // 4} and int("".join(words), 16) >= 0, mem


@pytest.mark.skipif(shutil.which("iverilog") is None, reason="Icarus Verilog not installed")
def test_a_simulation_without_its_mem_file_stops_naming_it(tmp_path, files):
    """Run where a table's .mem file is missing or short, the ROM stops the simulation with one
    line naming the file, instead of going on with unknown words; with the file, it reads them."""
    core = " ".join(files["pendulum_core.v"].split())
    addr, data, depth, mem, _ = re.search(r"pendulum_core_rom #\(\.ADDR_WIDTH\((\d+)\), \.DATA_WIDTH\((\d+)\), "
                                          r'\.DEPTH\((\d+)\), \.INIT_FILE\("([\w.]+)"\)\) u_rom_(\w+) \(', core).groups()
    (tmp_path / "pendulum_core_rom.v").write_text(files["pendulum_core_rom.v"])
    (tmp_path / "tb.v").write_text(
        f"module tb; reg clk = 0; wire [{int(data) - 1}:0] q;\n"
        f"pendulum_core_rom #(.ADDR_WIDTH({addr}), .DATA_WIDTH({data}), .DEPTH({depth}), .INIT_FILE(\"{mem}\")) "
        f"u (.clk(clk), .en(1'b1), .addr({addr}'d0), .q(q));\n"
        "initial begin #1 clk = 1; #1 $display(\"word %h\", q); $finish; end endmodule\n")
    subprocess.run(["iverilog", "-g2005", "-o", "t.vvp", "tb.v", "pendulum_core_rom.v"], cwd=tmp_path, check=True)

    def run(folder):
        folder.mkdir(exist_ok=True)
        return subprocess.run(["vvp", "-n", str(tmp_path / "t.vvp")], cwd=folder, capture_output=True,
                              text=True).stdout
    missing = run(tmp_path / "missing")
    assert f"{mem} is missing or has fewer than {depth} words" in missing and "\nword " not in "\n" + missing
    words = [ln for ln in files[mem].splitlines() if not ln.startswith("//")]
    (tmp_path / "short").mkdir()
    (tmp_path / "short" / mem).write_text("\n".join(words[:-1]) + "\n")
    assert "is missing or has fewer than" in run(tmp_path / "short")
    (tmp_path / "whole").mkdir()
    (tmp_path / "whole" / mem).write_text(files[mem])
    assert f"word {words[0].lower()}" in run(tmp_path / "whole")


def test_writing_replaces_the_folder_atomically(tmp_path, files):
    out = tmp_path / "hdl"
    write_hdl(out, {"stale.v": "x"})
    write_hdl(out, files)
    assert sorted(p.name for p in out.iterdir()) == sorted(files)
    assert [p.name for p in tmp_path.iterdir()] == ["hdl"]
    assert not any("syntax" in n for n in files)


# ---------------------------------------------------------------- readable Verilog (issue 12, point 3)

NODE_COMMENT = re.compile(r"^ *// (\S+) = (\w+)\(", re.M)
LINE_LIMIT = 120


def _node_sections(core: str) -> dict:
    """Node name -> the text from its comment to the next node's comment."""
    marks = list(NODE_COMMENT.finditer(core))
    ends = [m.start() for m in marks[1:]] + [len(core)]
    return {m.group(1): core[m.start():end] for m, end in zip(marks, ends)}


@pytest.fixture(scope="module")
def furuta():
    """The second plant's build: (graph, files), through the same backend entry point."""
    build = compile_cached(load_model(ROOT / "models" / "furuta_qube.toml"))
    return build.graph, build_hdl(build.graph, build.resources.to_json(), source="models/furuta_qube.toml")


@pytest.mark.parametrize("plant", ["sct", "furuta"])
def test_every_ir_node_has_exactly_one_comment(plant, files, request):
    """One comment per node naming it, its kind, its Q-format and its meaning, and the node's
    value n_<node> declared (and assigned) under it, for either plant."""
    if plant == "sct":
        graph, core = compile_cached(load_model()).graph, files["pendulum_core.v"]
    else:
        graph, fur = request.getfixturevalue("furuta")
        core = fur["furuta_core.v"]
    named = Counter(m.group(1) for m in NODE_COMMENT.finditer(core))
    assert named == Counter(n.name for n in graph.nodes)
    sections = _node_sections(core)
    for n in graph.nodes:
        text = sections[n.name]
        comment = " ".join(ln.strip().lstrip("/").strip() for ln in text.splitlines() if ln.strip().startswith("//"))
        comment = " ".join(comment.split())
        assert comment.startswith(f"{n.name} = {n.kind.value}(") and f": {n.qformat}" in comment, comment
        assert " ".join(n.meaning.split()) in comment, (n.name, n.meaning)
        word = "localparam" if n.kind is Kind.CONST else "reg" if n.kind is Kind.REGISTER else "wire"
        assert re.search(rf"^ *{word}\b[^;=]* n_{re.escape(n.name)}( =|;)", text, re.M), text
    assert not re.search(r"^ *assign n_", core, re.M)          # node wires are assigned where declared


@pytest.mark.parametrize("plant", ["sct", "furuta"])
def test_no_line_is_longer_than_the_limit(plant, files, request):
    built = files if plant == "sct" else request.getfixturevalue("furuta")[1]
    for name, text in built.items():
        if name.endswith((".v", ".mem")):
            longest = max(text.splitlines(), key=len)
            assert len(longest) <= LINE_LIMIT, f"{name}: {longest}"


def test_wrapping_keeps_every_token_and_the_limit():
    """The line breaker (pendc.backend.verilog_text.wrap) only moves whitespace."""
    from pendc.backend.verilog_text import wrap
    rng = random.Random(12)
    for _ in range(300):
        terms = [f"(n_{rng.choice('abcdefgh') * rng.randint(1, 30)} & {{{rng.randint(1, 9)}{{x[3]}}, y}})"
                 for _ in range(rng.randint(1, 12))]
        expr = " | ".join(terms)
        lines = wrap("wire signed [63:0] n_hit = ", expr, ";")
        assert "".join(ln.strip() + " " for ln in lines).split() == f"wire signed [63:0] n_hit = {expr};".split()
        assert all(len(ln) <= 110 for ln in lines if " " in ln.strip()), lines


def test_the_second_plant_builds_its_own_core_wrappers_and_register_map(furuta, files):
    """The Furuta pendulum's files are named by its interface's core, its register map has
    exactly its interface's register names besides the fixed ones, and nothing in them names a
    state or encoder of the cart pendulum."""
    from pendc.model.interface import require_interface
    graph, fur = furuta
    iface = require_interface(graph)
    assert iface.core == "furuta_core"
    report = json.loads(fur["report.json"])
    assert report["top"] == "furuta_core" and report["wrapper"] == "furuta_raptor"
    assert {"furuta_core.v", "furuta_regs.v", "furuta_qdec.v", "furuta_raptor.v"} <= set(fur)
    assert all(name.startswith("furuta_") for name in fur if name.endswith((".v", ".mem")))
    sct = require_interface(compile_cached(load_model()).graph)
    fixed = {r["name"] for r in json.loads(files["report.json"])["registers"]}
    fixed -= {r for regs in sct.register_names().values() for r in regs}
    names = {r["name"] for r in report["registers"]}
    assert names == fixed | {r for regs in iface.register_names().values() for r in regs}
    foreign = [*sct.outputs, *(s.name for s in sct.sensors), *(c for s in sct.sensors for c in s.channels)]
    for name, text in fur.items():
        hits = [w for w in foreign if re.search(rf"\b(n_)?{w}\b", text)]
        assert not hits, f"{name} names {hits}"
