"""Issue 9 / issue 11: the RTL under what controllers do, bit-exact with the golden model.

The rig model (Table 14 plus end stops) through the generated Verilog:

* a pendulum spun at 30 rad/s (the state deposited into the core's registers after reset,
  as ``GoldenModel(..., initial=)`` starts its registers) and left alone, under Verilator
  until it has made 20 turns: after every 1 ms request the four state ports and the encoder
  counts (which the harness decodes from the channel lines at every step) equal the golden
  plant's, theta is right after every turn (float simulator, the error budget), and the
  sticky overflow flag stays low, as the golden model says it must;
* the minute of full-scale switching (0/10 V, holds of 1-50 ms): the golden plant runs all
  60 s (no node leaves its range, the cart stays within the stops); windows of it start in
  the RTL from the golden state (every register and encoder FSM deposited) at the moments of
  largest |x| and fastest theta and at spread-out times, each bit-exact with the golden plant;
* Icarus, about a thousand times slower, runs short windows of both.

The full 60 s under Verilator from reset is ``bench/bench_rtl_cpp.py --full-scale`` (about a
minute of simulation at the comb schedule), with its result in JSON.
"""

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from pendc.build_cache import compile_cached
from pendc.hil.golden_plant import GoldenPlant
from pendc.hil.rtl_cpp import VerilatorCppPlant
from pendc.hil.rtl_plant import RtlPlant
from pendc.model.modelfile import load_model
from pendc.passes.pipeline import BuildOptions
from pendc.passes.ranges import full_scale_switching
from pendc.sim.simulator import Simulator

RIG = str(Path(__file__).resolve().parents[1] / "models" / "sct_rig.toml")
SPIN = (0.0, 0.0, 0.0, 30.0)        # x, dx, theta, dtheta: rad/s, just inside dtheta's format
X_STOPS = 0.375 + 0.03              # the track's end plus the stops' deepest penetration
MINUTE = 60.0
WINDOW_MS = {"verilator": 200, "icarus": 3}


def _have(tool):
    return shutil.which(tool, path=f"{Path(sys.executable).parent}:/usr/bin:/usr/local/bin") is not None


needs_verilator = pytest.mark.skipif(not _have("verilator"), reason="verilator is not installed")
needs_icarus = pytest.mark.skipif(not _have("iverilog"), reason="iverilog is not installed")


@pytest.fixture(scope="module")
def rig():
    model = load_model(RIG)
    return model, compile_cached(model)


@pytest.fixture(scope="module")
def spin_golden(rig):
    """The golden spin, 1 ms per row, until 20 turns are complete (and the float reference)."""
    model, build = rig
    v_off = model.parameter_values()["V_off"]
    golden = GoldenPlant(model, build=build, initial=SPIN)
    rows, raws, states = [golden.reset()], [golden.raw()], [golden.registers()]
    while abs(rows[-1].theta) < 20 * 2 * np.pi + 0.5:
        rows.append(golden.step(v_off, 1000))
        raws.append(golden.raw())
        states.append(golden.registers())
        assert len(rows) < 20_000, "the pendulum stopped before 20 turns"
    return v_off, rows, raws, states


@pytest.fixture(scope="module")
def minute(rig):
    """The golden plant through the whole minute: rows every 1 ms, and the register state."""
    model, build = rig
    t, u = full_scale_switching(MINUTE, seed=1)
    golden = GoldenPlant(model, build=build)        # on_overflow="error": a wrap would raise here
    rows, states = [golden.reset()], [golden.registers()]
    for volts in u[:-1]:
        rows.append(golden.step(float(volts), 1000))
        states.append(golden.registers())
    return u, rows, states


def test_the_spin_is_right_after_every_turn_in_the_golden_model(rig, spin_golden):
    model, _ = rig
    v_off, rows, _, _ = spin_golden
    t = np.array([r.t for r in rows])
    theta = np.array([r.theta for r in rows])
    ref = Simulator(model)(t, np.full_like(t, v_off), x0=SPIN)
    turns = np.floor(ref["theta"] / (2 * np.pi))
    at_turn = np.flatnonzero(np.diff(turns) != 0) + 1
    assert len(at_turn) >= 20
    assert np.max(np.abs(theta[at_turn] - ref["theta"][at_turn])) < BuildOptions().budget_theta
    assert max(abs(r.x) for r in rows) < X_STOPS


@needs_verilator
def test_the_spun_pendulum_is_bit_exact_in_verilator_over_20_turns(rig, spin_golden):
    model, build = rig
    v_off, rows, raws, _ = spin_golden
    with VerilatorCppPlant(model, build=build, initial=SPIN) as rtl:     # overflow flag: an error
        assert rtl.reset() == rows[0] and rtl.raw() == raws[0]
        for k in range(1, len(rows)):
            got = rtl.step(v_off, 1000)
            assert got == rows[k] and rtl.raw() == raws[k], f"differs after {k} ms"
    count = 2 * np.pi / 20000                   # 0.314 mrad: the x4 pendulum encoder counted every turn
    assert abs(rows[-1].enc_theta * count - rows[-1].theta) < 2 * count


def _windows(u, rows, count: int) -> list:
    """Start rows of ``count`` windows: the largest |x|, the fastest theta, the rest spread out."""
    x = np.array([abs(r.x) for r in rows[:-1]])
    w = np.array([abs(r.dtheta) for r in rows[:-1]])
    picks = [int(np.argmax(x)), int(np.argmax(w))]
    picks += [int(k) for k in np.linspace(0, len(rows) - 2, count - 2 + 2)[1:-1]]
    return sorted({min(k, len(rows) - 2) for k in picks})


def _run_window(rtl, golden, u, rows, states, k0: int, ms: int) -> None:
    assert rtl.load(states[k0]) == golden.load(states[k0])
    assert rtl.raw() == golden.raw()
    for j in range(min(ms, len(u) - 1 - k0)):
        want, got = golden.step(float(u[k0 + j]), 1000), rtl.step(float(u[k0 + j]), 1000)
        assert got == want and rtl.raw() == golden.raw(), f"window from {k0} ms differs after {j + 1} ms"
        # the golden plant continues the minute's own run: the window is that run, not a new one
        assert rtl.raw()["x"] == round(rows[k0 + j + 1].x / rtl._lsb["x"])


def test_the_minute_of_full_scale_switching_stays_on_the_track(minute):
    _, rows, _ = minute
    assert rows[-1].t == pytest.approx(MINUTE)
    x = np.array([r.x for r in rows])
    assert np.max(np.abs(x)) <= X_STOPS and np.max(np.abs(x)) > 0.375     # it hit the stops


@needs_verilator
def test_windows_of_the_minute_are_bit_exact_in_verilator(rig, minute):
    model, build = rig
    u, rows, states = minute
    golden = GoldenPlant(model, build=build)
    with VerilatorCppPlant(model, build=build, loadable=True) as rtl:
        for k0 in _windows(u, rows, 10):
            _run_window(rtl, golden, u, rows, states, k0, WINDOW_MS["verilator"])


@needs_icarus
def test_windows_of_the_minute_and_the_spin_are_bit_exact_in_icarus(rig, minute, spin_golden):
    model, build = rig
    u, rows, states = minute
    golden = GoldenPlant(model, build=build)
    with RtlPlant(model, "icarus", build=build, schedule={"preset": "comb"}) as rtl:
        for k0 in _windows(u, rows, 4)[:2]:          # the largest |x| and the fastest theta
            _run_window(rtl, golden, u, rows, states, k0, WINDOW_MS["icarus"])
        v_off, spin_rows, _, spin_states = spin_golden
        k0 = len(spin_rows) - 1 - WINDOW_MS["icarus"]  # the 20th turn
        _run_window(rtl, golden, np.full(len(spin_rows), v_off), spin_rows, spin_states, k0,
                    WINDOW_MS["icarus"])
