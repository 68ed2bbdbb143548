"""Issue 9 / issue 11: the RTL under what controllers do, bit-exact with the golden model.

The rig model (Table 14 plus end stops) through the generated Verilog:

* a pendulum spun at 30 rad/s and left alone until it has made 20 turns: the golden model
  keeps theta right after every turn (float simulator, the error budget) and no node leaves
  its range; under Verilator the first 200 ms from the spin's start (``initial``, deposited
  into the core's registers after reset, as ``GoldenModel(..., initial=)`` starts its
  registers) and 200 ms from the golden state at every 4th turn up to the 20th: after every
  1 ms request the four state ports and the encoder counts (decoded by the harness from the
  channel lines at every step) equal the golden plant's and the sticky overflow flag stays low;
* the minute of full-scale switching (0/10 V, holds of 1-50 ms): the golden model runs all
  60 s (no node leaves its range, the cart stays within the stops); windows of it start in
  the RTL from the golden state (every register and encoder FSM deposited) at the moments of
  largest |x| and fastest theta and at spread-out times, each bit-exact with the golden plant
  after every ms and on the minute's own trajectory;
* Icarus, about a thousand times slower, runs short windows of both.

The full 60 s and the whole spin under Verilator, from reset and from the spin's start, are
``make full-scale`` (bench/bench_rtl_cpp.py --full-scale, JSON in bench/out/), too long for the test suite.
"""

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from pendc.caching.build_cache import compile_cached
from pendc.hil.plants.golden_plant import GoldenPlant
from pendc.hil.plants.rtl_cpp import VerilatorCppPlant
from pendc.hil.plants.rtl_plant import RtlPlant
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


def _golden_ms(build, u_per_ms, initial=None, until=None) -> dict:
    """The golden kernel 1 ms at a time: the output integers and every register after each ms
    (``until(outputs)`` stops early), and the overflow record (a wrap cannot pass unnoticed)."""
    from pendc.golden import GoldenStepper
    stepper = GoldenStepper(build.graph)
    start = None if initial is None else dict(zip(("x", "dx", "theta", "dtheta"), initial))
    stepper.reset(start)
    ports = stepper.ports
    rows, states = [], [tuple(int(v) for v in stepper.state)]
    quant = build.graph["u"].qformat
    for volts in u_per_ms:
        out = stepper.advance(quant.from_float(float(volts)), 1000, every_step=False)
        rows.append(dict(zip(ports, (int(v) for v in out[-1]))))
        states.append(tuple(int(v) for v in stepper.state))
        if until is not None and until(rows[-1]):
            break
    return {"rows": rows, "states": states, "overflows": dict(stepper.overflows)}


@pytest.fixture(scope="module")
def spin_golden(rig):
    """The golden spin, 1 ms per row, until 20 turns are complete."""
    model, build = rig
    v_off = model.parameter_values()["V_off"]
    lsb = build.graph.output("theta").qformat.lsb
    run = _golden_ms(build, np.full(30_000, v_off), SPIN, until=lambda r: abs(r["theta"] * lsb) > 20 * 2 * np.pi + 0.5)
    assert abs(run["rows"][-1]["theta"] * lsb) > 20 * 2 * np.pi, "the pendulum stopped before 20 turns"
    return v_off, run


@pytest.fixture(scope="module")
def minute(rig):
    """The golden model through the whole minute: output integers and registers every 1 ms."""
    _, build = rig
    t, u = full_scale_switching(MINUTE, seed=1)
    return u, _golden_ms(build, u[:-1])


def test_the_spin_is_right_after_every_turn_in_the_golden_model(rig, spin_golden):
    model, build = rig
    v_off, run = spin_golden
    assert run["overflows"] == {}
    lsb = build.graph.output("theta").qformat.lsb
    theta = np.array([SPIN[2]] + [r["theta"] * lsb for r in run["rows"]])
    t = np.arange(len(theta)) * 1e-3
    ref = Simulator(model)(t, np.full_like(t, v_off), x0=SPIN)
    turns = np.floor(ref["theta"] / (2 * np.pi))
    at_turn = np.flatnonzero(np.diff(turns) != 0) + 1
    assert len(at_turn) >= 20
    assert np.max(np.abs(theta[at_turn] - ref["theta"][at_turn])) < BuildOptions().budget_theta


@needs_verilator
def test_the_spun_pendulum_is_bit_exact_in_verilator_over_20_turns(rig, spin_golden):
    """From the spin's start (``initial``, deposited) and from the golden state at every 4th
    turn up to the 20th: 100 ms each, bit-exact after every ms. The whole spin from its start
    is bench/bench_rtl_cpp.py --full-scale."""
    model, build = rig
    v_off, run = spin_golden
    lsb = build.graph.output("theta").qformat.lsb
    theta = np.array([r["theta"] * lsb for r in run["rows"]])
    golden = GoldenPlant(model, build=build, initial=SPIN)
    with VerilatorCppPlant(model, build=build, initial=SPIN) as rtl:     # overflow flag: an error
        assert rtl.reset() == golden.reset() and rtl.raw() == golden.raw()
        for k in range(WINDOW_MS["verilator"]):
            assert rtl.step(v_off, 1000) == golden.step(v_off, 1000) and rtl.raw() == golden.raw(), f"after {k + 1} ms"
        u = np.full(len(run["rows"]) + 1, v_off)
        for turn in range(4, 21, 4):
            k0 = min(int(np.argmax(np.abs(theta) >= turn * 2 * np.pi)), len(run["rows"]) - WINDOW_MS["verilator"])
            _run_window(rtl, golden, u, run, k0, WINDOW_MS["verilator"])


def _windows(run: dict, count: int) -> list:
    """Start rows of ``count`` windows: the largest |x|, the fastest theta, the rest spread out."""
    rows = run["rows"]
    x = np.array([abs(r["x"]) for r in rows])
    w = np.array([abs(r["dtheta"]) for r in rows])
    picks = [int(np.argmax(x)), int(np.argmax(w))]      # the window's first ms ends there
    picks += [int(k) for k in np.linspace(0, len(rows), count)[1:-1]]
    return sorted({min(k, len(rows) - 1) for k in picks})


def _run_window(rtl, golden, u, run: dict, k0: int, ms: int) -> None:
    """From the golden state after k0 ms (every register deposited) ``ms`` ms on, bit-exact after
    each, and on the golden run's own trajectory."""
    assert rtl.load(run["states"][k0]) == golden.load(run["states"][k0])
    assert rtl.raw() == golden.raw()
    for j in range(min(ms, len(run["rows"]) - k0)):
        want, got = golden.step(float(u[k0 + j]), 1000), rtl.step(float(u[k0 + j]), 1000)
        assert got == want and rtl.raw() == golden.raw(), f"window from {k0} ms differs after {j + 1} ms"
        assert all(rtl.raw()[p] == run["rows"][k0 + j][p] for p in ("x", "dx", "theta", "dtheta"))


def test_the_minute_of_full_scale_switching_stays_on_the_track(rig, minute):
    _, build = rig
    _, run = minute
    assert len(run["rows"]) == MINUTE * 1000 and run["overflows"] == {}     # no node left its range
    x = np.array([r["x"] for r in run["rows"]]) * build.graph.output("x").qformat.lsb
    assert np.max(np.abs(x)) <= X_STOPS and np.max(np.abs(x)) > 0.375     # it hit the stops
    # the hits on the stops shake the pendulum hard; theta stays continuous (turns: the spin)
    theta = np.array([r["theta"] for r in run["rows"]]) * build.graph.output("theta").qformat.lsb
    assert np.max(np.abs(theta)) > 0.3 and np.max(np.abs(np.diff(theta))) < 0.05


@needs_verilator
def test_windows_of_the_minute_are_bit_exact_in_verilator(rig, minute):
    model, build = rig
    u, run = minute
    golden = GoldenPlant(model, build=build)
    with VerilatorCppPlant(model, build=build, loadable=True) as rtl:
        for k0 in _windows(run, 10):
            _run_window(rtl, golden, u, run, k0, WINDOW_MS["verilator"])


@needs_icarus
def test_windows_of_the_minute_and_the_spin_are_bit_exact_in_icarus(rig, minute, spin_golden):
    model, build = rig
    u, run = minute
    golden = GoldenPlant(model, build=build)
    with RtlPlant(model, "icarus", build=build, schedule={"preset": "comb"}) as rtl:
        for k0 in _windows(run, 4)[:2]:          # the largest |x| and the fastest theta
            _run_window(rtl, golden, u, run, k0, WINDOW_MS["icarus"])
        v_off, spin = spin_golden
        k0 = len(spin["rows"]) - WINDOW_MS["icarus"]       # the 20th turn
        _run_window(rtl, golden, np.full(len(spin["rows"]) + 1, v_off), spin, k0, WINDOW_MS["icarus"])
