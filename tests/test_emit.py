"""The emitted HDL: deterministic, the committed hdl_out/ is current, report.json describes it."""

import json
from pathlib import Path

import pytest

from pendc import load_model
from pendc.backend.hdl import build_hdl, write_hdl
from pendc.build_cache import compile_cached

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


def test_writing_replaces_the_folder_atomically(tmp_path, files):
    out = tmp_path / "hdl"
    write_hdl(out, {"stale.v": "x"})
    write_hdl(out, files)
    assert sorted(p.name for p in out.iterdir()) == sorted(files)
    assert [p.name for p in tmp_path.iterdir()] == ["hdl"]
    assert not any("syntax" in n for n in files)
