"""Acceptance checks of the compiled default model (issue 3): bit-accurate vs float,
encoders decoded x4 against the states, and the compiled fast path vs the interpreter."""

import numpy as np
import pytest

from pendc import Simulator, load_model
from pendc.caching.build_cache import compile_cached
from pendc.errors import PendcError
from pendc.golden import GoldenModel
from pendc.ir.interpret import FixedInterpreter
from pendc.passes.ranges import per_step
from plants import THETA_COUNT, X_COUNT
from plants import chirp, swing_up

DT = 1e-6


@pytest.fixture(scope="module")
def build():
    return compile_cached(load_model())


@pytest.fixture(scope="module")
def golden(build):
    return GoldenModel(build.graph, DT)


def decode_x4(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Counts of a x4 quadrature decoder (relative to the first sample); a skipped quarter is an error."""
    quarter = np.select([(a == 1) & (b == 0), (a == 1) & (b == 1), (a == 0) & (b == 1)], [0, 1, 2], 3)
    step = np.diff(quarter) % 4
    assert not np.any(step == 2), "the encoder skipped a quarter period between two samples"
    return np.concatenate([[0], np.cumsum(np.where(step == 1, 1, np.where(step == 3, -1, 0)))])


@pytest.mark.parametrize("name, stimulus", [("chirp", chirp(duration=2.0)), ("swing_up", swing_up())])
def test_fixed_point_tracks_float_within_one_count_for_two_seconds(golden, build, name, stimulus):
    t, u = stimulus
    fixed = golden(t, u)
    assert not fixed.overflows, f"overflow in {fixed.overflows}"
    ref = Simulator(build.model, dt=DT)(t, u)
    first = t <= 2.0 + 1e-9
    dx = np.max(np.abs(fixed.result["x"][first] - ref["x"][first]))
    dth = np.max(np.abs(fixed.result["theta"][first] - ref["theta"][first]))
    print(f"{name}: max |dx| {dx:.3g} m, max |dtheta| {dth:.3g} rad over 2 s")
    assert dx <= X_COUNT and dth <= THETA_COUNT


@pytest.mark.parametrize("name, stimulus", [("chirp", chirp(duration=2.0)), ("swing_up", swing_up())])
def test_encoders_decode_to_the_states(golden, name, stimulus):
    t, u = stimulus
    trace = golden.run_steps(per_step(u, t, DT))
    assert not [n for n in trace.overflows if "enc" in n], "an encoder step crossed more than two bands"
    g = golden.graph
    for port, state, count in (("enc_x", "x", X_COUNT), ("enc_theta", "theta", THETA_COUNT)):
        value = trace.outputs[state] * g.output(state).qformat.lsb
        # a decoder's best estimate is the middle of the current count
        decoded = (decode_x4(trace.outputs[f"{port}_a"], trace.outputs[f"{port}_b"]) + 0.5) * count
        err = np.max(np.abs(decoded - value))
        assert np.ptp(value) > 20 * count, "the run should move the axis"
        assert err <= count, f"{port}: decoded position off by {err / count:.2f} counts"


@pytest.mark.parametrize("stimulus", ["chirp_low", "chirp_high", "steps", "swing_up", "random"])
def test_fast_path_is_the_interpreter_bit_for_bit(build, golden, stimulus):
    from plants import STIMULI
    t, u = STIMULI.named()[stimulus]
    steps = per_step(u, t, DT)
    start = len(steps) // 3          # from the middle of the run, where everything moves
    ints = golden.quantize_input(steps[start:start + 10_000])
    fast = golden.run_steps(ints)
    slow = FixedInterpreter(build.graph).run({"u": [int(v) for v in ints]})
    for port in fast.outputs:
        assert np.array_equal(np.asarray(fast.outputs[port], np.int64), np.asarray(slow.outputs[port], np.int64)), port
    assert fast.overflows == slow.overflows


@pytest.mark.parametrize("stimulus", ["chirp_high", "steps", "random"])
def test_input_integers_are_every_steps_value_quantised(golden, stimulus):
    """Each held sample quantised once and held: the integers of quantising every step's value
    (the golden vectors' inputs); sample times off the step grid are refused."""
    from plants import STIMULI
    t, u = STIMULI.named()[stimulus]
    ints = golden.input_integers(t, u)
    assert ints.dtype == np.int64 and np.array_equal(ints, golden.quantize_input(per_step(u, t, DT)))
    with pytest.raises(PendcError, match="whole multiples"):
        golden.input_integers(t + 0.3 * DT * np.arange(len(t)), u)


def test_long_runs_go_sample_by_sample_with_the_same_integers(golden, monkeypatch):
    """Beyond LONG_RUN_STEPS the golden model continues its kernel sample by sample (memory
    independent of the length); the results are those of one trace, also for uneven sampling."""
    import pendc.golden as golden_module
    t = np.array([0.0, 1e-3, 3e-3, 3.5e-3, 0.2, 0.2005])
    u = np.array([10.0, 0.0, 5.0, 7.0, 2.0, 2.0])
    one_trace = golden(t, u)
    monkeypatch.setattr(golden_module, "LONG_RUN_STEPS", 10)
    by_sample = golden(t, u)
    for s in ("x", "dx", "theta", "dtheta"):
        np.testing.assert_array_equal(by_sample.result[s], one_trace.result[s])
    assert np.ptp(one_trace.result["x"]) > 0
    assert not by_sample.marked_rows().any()


def test_a_run_started_turns_away_is_the_same_motion(golden):
    """A start two turns and more beyond the upright holds its whole turns in the counter
    (register_integers), so the phase the tables read starts within half a turn (from a counter
    at zero it was far outside its format): the motion of a start a turn below, but for the
    rounding of the two start angles."""
    t = np.arange(0, 0.0201, 0.001)
    u = np.full(t.size, 5.2646)                      # the drive's zero force
    far = golden(t, u, initial=(0.0, 0.0, 3.2 + 4 * np.pi, 5.0))
    near = golden(t, u, initial=(0.0, 0.0, 3.2 - 2 * np.pi, 5.0))
    assert not far.overflows and far.result["theta"][0] == pytest.approx(3.2 + 4 * np.pi)
    for state in ("x", "dx", "dtheta"):
        np.testing.assert_allclose(far.result[state], near.result[state], rtol=0, atol=1e-6, err_msg=state)
    np.testing.assert_allclose(far.result["theta"] - near.result["theta"], 6 * np.pi, rtol=0, atol=1e-7)


def test_the_first_overflow_of_a_step_is_the_node_the_step_computes_first():
    """Two nodes overflow in one step: the message names the one computed first (the partial sum
    whose wrap the next node inherits), not the one first by name."""
    from pendc.golden import first_overflow
    from pendc.ir.graph import Graph
    from pendc.ir.nodes import Kind, make
    g = Graph.build("tie", [make("u", Kind.INPUT, port="u"), make("ddx1_acc", Kind.GAIN, ["u"], value=2.0),
                            make("ddx1", Kind.GAIN, ["ddx1_acc"], value=0.5)], [("ddx1", "ddx1")])
    overflows = {"ddx1": 7, "ddx1_acc": 7, "u": 9}
    assert first_overflow(overflows, g) == ("ddx1_acc", 7)
    assert first_overflow(overflows) == ("ddx1", 7)                 # without the graph: by name
    assert first_overflow({}) is None


def test_an_overflow_of_a_periodic_register_says_to_raise_its_turns():
    """A reaction wheel that spins past its 256 turns overflowed 'phi_sum' with nothing said of
    `turns` (the private check); a node of a state that is not periodic gets no such advice."""
    from pathlib import Path

    from pendc.golden import OverflowStop, overflow_hint
    from pendc.model.modelfile import load_model
    from pendc.sim.signals import signals_of
    wheel = signals_of(load_model(str(Path(__file__).parent / "data" / "reaction_wheel.toml")))
    assert "phi is periodic and its register holds 256 whole turns" in overflow_hint("phi_sum", wheel)
    assert overflow_hint("dphi_sum", wheel) == ""
    assert "larger `turns`" in str(OverflowStop("phi_sum", 10, 1e-6, signals=wheel))
    assert overflow_hint("x_sum", signals_of(load_model())) == ""
