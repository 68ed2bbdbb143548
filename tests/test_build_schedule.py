"""`pendc build --preset/--ii/--dsp/--target` and `pendc report resources` per product, on the
default model with shortened training (a [hardware] table), so the compile stays quick."""

import json

import pytest

from pendc.cli import main
from pendc.model.modelfile import default_model_path
from quick_training import quick_copy


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "quick.toml"
    quick_copy(default_model_path(), path)
    return path


def build(model_file, out, *flags):
    code = main(["build", "--model", str(model_file), "-o", str(out), *flags])
    assert code == 0
    return json.loads((out / "report.json").read_text())


def test_presets_and_ii(model_file, tmp_path):
    small = build(model_file, tmp_path / "small", "--preset", "small")
    assert small["schedule"]["preset"] == "small" and small["schedule"]["request"]["preset"] == "small"
    assert small["resources"]["dsp_scheduled"] <= 4 and small["schedule"]["units"]
    assert small["ii"] > 2 and small["ii"] * 10 <= 1000          # >= 1 MHz step rate at the 100 MHz goal
    comb = build(model_file, tmp_path / "comb", "--preset", "comb")
    assert comb["ii"] == 2 and not comb["schedule"]["units"]
    fast = build(model_file, tmp_path / "fast", "--preset", "fast")
    assert fast["ii"] >= comb["ii"] and not fast["schedule"]["units"]
    six = build(model_file, tmp_path / "ii", "--ii", "40", "--dsp", "2")     # two 1-block units, 40 cycles
    assert six["ii"] == 40 and six["resources"]["dsp_scheduled"] <= 2 and len(six["schedule"]["units"]) <= 2
    # every schedule of the default arithmetic has the same formats; the step-time presets build the
    # short chain (BuildOptions.short_chain): dt folded into the tables, so no acceleration node
    assert small["qformats"] == comb["qformats"] == six["qformats"]
    assert "ddx" in comb["qformats"] and "ddx" not in fast["qformats"]


@pytest.mark.parametrize("flags, message", [
    (["--preset", "fast", "--ii", "4"], "give one of them"),
    (["--ii", "1"], "no schedule in 1 cycle"),
    (["--dsp", "0"], "--dsp must be a positive integer"),
])
def test_bad_schedule_requests_are_one_line_errors(model_file, tmp_path, capsys, flags, message):
    assert main(["build", "--model", str(model_file), "-o", str(tmp_path / "x"), *flags]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pendc: error:") and message in err and err.count("\n") == 1
    assert not (tmp_path / "x").exists()


def test_resources_report_says_why_each_product_got_its_width(model_file, capsys):
    assert main(["report", "resources", "--model", str(model_file), "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["dsp_shape"] == "18x18" and r["products"]
    assert r["dsp"] == sum(p["dsp"] for p in r["products"])
    for p in r["products"]:
        assert p["why"] and (p["level"] is None or 0 <= p["level"] <= 2)
        if p["level"] == 0:
            assert p["dsp"] == 1 and "one 18x18 DSP block" in p["why"]
    assert main(["report", "resources", "--model", str(model_file), "--target", "xc7", "--json"]) == 0
    x = json.loads(capsys.readouterr().out)
    assert x["dsp_shape"] == "25x18"


def test_fmax_build_is_bit_exact_in_icarus(tmp_path):
    """The default model's core at a 100 MHz goal (``--preset fmax``: two-block products registered
    at their partial products, about 20 cycles a step) runs bit-exact against the golden kernel in
    Icarus. The default model (its compile is shared with the other tests), not the quick one:
    the quick check leaves every product in one block, and the partial products are the point."""
    import shutil

    import numpy as np
    from test_schedule import STEPS, run_icarus

    from pendc.caching.build_cache import compile_cached
    from pendc.ir.compiled import CompiledGraph
    from pendc.model.modelfile import load_model
    from pendc.passes.schedule import schedule_for
    if shutil.which("iverilog") is None:
        pytest.skip("Icarus Verilog not installed")
    from pendc.backend.hdl import build_hdl
    compiled = compile_cached(load_model())
    graph = compiled.graph
    # the API (`pendc build --preset` lists fmax once the command line knows it)
    report = json.loads(build_hdl(graph, compiled.resources.to_json(), request={"preset": "fmax"})["report.json"])
    s = schedule_for(graph, (18, 18), preset="fmax")
    assert report["ii"] == s.ii > 10 and report["schedule"]["partial_products_registered"] == s.partial_reg
    assert s.partial_reg and s.clock_ns == 10.0
    view, ints, hw = run_icarus(graph, s, tmp_path / "hdl")
    gold = CompiledGraph(graph, "fixed").run({"u": ints})
    expect = np.stack([gold.outputs[p][1:] for p in ("x", "dx", "theta", "dtheta")], axis=1)
    assert np.abs(expect[:, 1]).max() > 0                   # the cart moves
    np.testing.assert_array_equal(hw[:-1, :4], expect)
    assert hw.shape == (STEPS, 5)
