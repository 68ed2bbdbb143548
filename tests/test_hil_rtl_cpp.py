"""The C++ Verilator plant against the golden plant and against the Verilog-harness plant.

Thousands of random requests (random volts, 1 to 1000 steps, a reset half way) must give the
golden plant's PlantState, port integers and overflow record after every one; a short run must
match :class:`pendc.hil.plants.rtl_plant.RtlPlant` under Verilator answer line for answer line. The
executable is built once per design and cached (the first run compiles the core: ~1.5 min).
"""

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pendc.caching.build_cache import compile_cached
from pendc.errors import PendcError
from pendc.hil.plants.plant import Plant, make_plant
from pendc.hil.plants.rtl_cpp import VerilatorCppPlant, main_source
from pendc.hil.plants.rtl_plant import RtlPlant
from pendc.model.modelfile import load_model

RIG = str(Path(__file__).resolve().parents[1] / "models" / "sct_rig.toml")
needs_verilator = pytest.mark.skipif(
    shutil.which("verilator", path=f"{Path(sys.executable).parent}:/usr/bin:/usr/local/bin") is None,
    reason="verilator is not installed")


@pytest.fixture(scope="module")
def rig():
    model = load_model(RIG)
    return model, compile_cached(model)


@pytest.fixture(scope="module")
def cpp(rig):
    model, build = rig
    with VerilatorCppPlant(model, build=build, on_overflow="mark") as plant:
        yield plant


def _requests(seed: int, count: int) -> list:
    rng = np.random.default_rng(seed)
    volts = rng.uniform(-12.0, 12.0, count)
    steps = np.exp(rng.uniform(0.0, np.log(1000.0), count)).astype(int)
    return [(float(u), int(n)) for u, n in zip(volts, steps)]


@needs_verilator
def test_cpp_plant_gives_the_golden_integers_over_random_requests(rig, cpp):
    model, build = rig
    golden = make_plant("golden", model, build=build, on_overflow="mark")
    assert isinstance(cpp, Plant) and cpp.dt == golden.dt
    assert cpp.reset() == golden.reset() and cpp.raw() == golden.raw()
    requests = _requests(seed=11, count=3000)
    moved = 0
    for k, (volts, n) in enumerate(requests):
        if k == len(requests) // 2:
            assert cpp.reset() == golden.reset() and cpp.raw() == golden.raw()
            assert cpp.overflow_at is None
        want, got = golden.step(volts, n), cpp.step(volts, n)
        assert got == want and cpp.raw() == golden.raw(), f"differs after request {k + 1} ({volts:.3f} V, {n} steps)"
        assert (cpp.overflow_at is not None) == bool(golden.overflows)
        moved = max(moved, abs(got.enc_x), abs(got.enc_theta))
    assert moved > 20                         # the encoders counted, so the decoding was exercised


@needs_verilator
def test_cpp_plant_answers_like_the_verilog_harness(rig, cpp):
    model, build = rig
    with RtlPlant(model, "verilator", build=build, on_overflow="mark") as rtl:   # the --timing harness
        assert rtl.reset() == cpp.reset()
        for k, (volts, n) in enumerate(_requests(seed=5, count=60)):
            if k == 40:
                assert rtl.reset() == cpp.reset()
            assert rtl.step(volts, n) == cpp.step(volts, n) and rtl.raw() == cpp.raw(), f"request {k + 1}"


@needs_verilator
def test_cpp_harness_rejects_a_bad_request(cpp):
    folder = cpp.executable.parent       # where the tables' .mem files are (as HarnessLink runs it)
    r = subprocess.run([str(cpp.executable)], input="0 5 0\n", capture_output=True, text=True, timeout=30, cwd=folder)
    assert r.returncode != 0 and r.stdout.splitlines()[-1] == "ERROR bad request"
    r = subprocess.run([str(cpp.executable)], input="0 5 3\n1 0 0\n", capture_output=True, text=True, timeout=30,
                       cwd=folder)
    first, stepped, after_reset = r.stdout.splitlines()
    assert r.returncode == 0 and first == after_reset != stepped   # a reset answers the power-on state


def test_ports_wider_than_64_bits_are_refused():
    from pendc.hil.plants.core_ports import CorePorts
    core = CorePorts.of_interface(load_model().interface)
    ports = {p: {"signed": True, "width": 40, "frac": 30} for p in (core.input, *core.states)}
    src = main_source(core, ports, 14)
    assert "sext(core->x, 40)" in src      # signed ports sign-extend from their width
    assert f'#include "V{core.module}.h"' in src and "core->enc_theta_b" in src
    ports["theta"] = {"signed": True, "width": 65, "frac": 60}
    with pytest.raises(PendcError, match="theta"):
        main_source(core, ports, 14)
