"""The RTL plants against the golden plant: identical integers for the same inputs.

Verilator runs 1 s of full-scale switching (0/10 V at random 1-50 ms intervals) in 1 ms
lockstep requests and must show the golden plant's port integers and encoder counts after
every one; Icarus, much slower, runs the first 5 ms of it. The harness is built once per
design and cached (the first run compiles the core: about a minute for Verilator).
"""

import shutil
import sys
from pathlib import Path

import pytest

from pendc.caching.build_cache import compile_cached
from pendc.hil.plants.plant import make_plant
from pendc.model.modelfile import load_model
from pendc.passes.ranges import full_scale_switching

RIG = str(Path(__file__).resolve().parents[1] / "models" / "sct_rig.toml")


def _have(tool):
    return shutil.which(tool, path=f"{Path(sys.executable).parent}:/usr/bin:/usr/local/bin") is not None


@pytest.fixture(scope="module")
def rig():
    model = load_model(RIG)
    return model, compile_cached(model)


@pytest.mark.parametrize("simulator, seconds", [("verilator", 1.0), ("icarus", 0.005)])
def test_rtl_plant_gives_the_golden_integers(rig, simulator, seconds):
    if not _have("verilator" if simulator == "verilator" else "iverilog"):
        pytest.skip(f"{simulator} is not installed")
    model, build = rig
    t, u = full_scale_switching(seconds, seed=3)
    golden = make_plant("golden", model, build=build)
    with make_plant(simulator, model, build=build) as rtl:
        assert rtl.reset() == golden.reset()
        for k, volts in enumerate(u[:-1]):
            want, got = golden.step(volts, 1000), rtl.step(volts, 1000)
            assert got == want and rtl.raw() == golden.raw(), f"differs after {k + 1} ms"
        assert abs(want.enc_x) > 20           # the cart moved (50 counts in the first 5 ms)
        rtl.reset()
        assert rtl.step(10.0, 1000) == make_plant("golden", model, build=build).step(10.0, 1000)
