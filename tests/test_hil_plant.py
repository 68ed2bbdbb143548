"""The stepping plant API: the float plant against the batch simulator, encoder counts, errors."""

import numpy as np
import pytest

from pendc.errors import PendcError
from pendc.hil.plants.plant import FloatPlant, Plant, PlantState, make_plant
from pendc.model.modelfile import load_model
from plants import THETA_COUNT, X_COUNT
from pendc.sim.encoders import counts
from pendc.sim.simulator import Simulator


@pytest.fixture(scope="module")
def model():
    return load_model()


def _switching_input(seed, n, levels=(0.0, 10.0)):
    return np.random.default_rng(seed).choice(levels, size=n)


def test_float_plant_follows_the_batch_simulator(model):
    plant = make_plant("float", model)
    assert isinstance(plant, Plant)
    us = _switching_input(3, 300)
    states = [plant.step(u, 1000) for u in us]
    t = np.arange(len(us) + 1) * 1e-3
    ref = Simulator(model)(t, np.append(us, us[-1]))
    for name in ("x", "dx", "theta", "dtheta"):
        got = np.array([getattr(s, name) for s in states])
        # the batch run's step is span/1000, equal to 1 us only up to rounding of t
        np.testing.assert_allclose(got, ref[name][1:], rtol=0, atol=1e-9)
    assert states[-1].t == pytest.approx(0.3)
    np.testing.assert_array_equal([s.enc_x for s in states], counts(ref["x"], X_COUNT)[1:])
    np.testing.assert_array_equal([s.enc_theta for s in states], counts(ref["theta"], THETA_COUNT)[1:])


def test_step_size_does_not_change_the_trajectory(model):
    a, b = FloatPlant(model), FloatPlant(model)
    for u in _switching_input(4, 20):
        one = a.step(u, 1000)
        for _ in range(10):
            many = b.step(u, 100)
        assert one == many   # same Euler steps from the same state: identical floats


def test_reset_starts_over_from_rest(model):
    plant = FloatPlant(model)
    first = [plant.step(u, 500) for u in _switching_input(5, 50)]
    assert plant.reset() == PlantState.at_rest(plant.ports)
    again = [plant.step(u, 500) for u in _switching_input(5, 50)]
    assert first == again
    assert first[-1].enc_x != 0


def test_extra_states_and_input_delay_carry_over_between_steps(model):
    lagged = model.with_effect("motor_lag", {"tau_m": 0.004}).with_effect("input_delay", {"tau_d": 0.0023})
    plant = FloatPlant(lagged)
    us = _switching_input(6, 200)
    states = [plant.step(u, 1000) for u in us]
    t = np.arange(len(us) + 1) * 1e-3
    ref = Simulator(lagged)(t, np.append(us, us[-1]))
    np.testing.assert_allclose([s.x for s in states], ref["x"][1:], rtol=0, atol=1e-9)
    np.testing.assert_allclose([s.theta for s in states], ref["theta"][1:], rtol=0, atol=1e-8)


@pytest.mark.parametrize("kind, n, u, message", [
    ("spice", 1, 0.0, "unknown plant 'spice'"),
    ("float", 0, 5.0, "number of steps must be in"),
    ("float", 2.5, 5.0, "number of steps must be an integer"),
    ("float", 1, float("nan"), "plant input must be finite"),
    ("float", 1, "five", "plant input must be a number"),
])
def test_bad_requests_are_one_line_errors(model, kind, n, u, message):
    with pytest.raises(PendcError, match=message):
        make_plant(kind, model).step(u, n)


# -- the golden plant ------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def build(model):
    from pendc.caching.build_cache import compile_cached
    return compile_cached(model)


def _batch(build, us, n):
    """The batch golden model's integers at every step for inputs held n steps each."""
    from pendc.golden import GoldenModel
    golden = GoldenModel(build.graph, 1e-6)
    per_step = np.append(np.repeat(golden.quantize_input(us), n), 0)
    return golden.run_steps(per_step).outputs


def test_golden_plant_continues_the_batch_run_bit_for_bit(model, build):
    from pendc.hil.plants.plant import x4_count_delta
    us = _switching_input(7, 150, levels=(0.0, 10.0, 3.3, 7.1))
    plant = make_plant("golden", model, build=build)
    ref = _batch(build, us, 1000)
    for i, u in enumerate(us):
        s = plant.step(u, 1000)
        row = 1000 * (i + 1)
        assert plant.raw()["x"] == ref["x"][row] and plant.raw()["theta"] == ref["theta"][row]
        assert plant.raw()["dx"] == ref["dx"][row] and plant.raw()["dtheta"] == ref["dtheta"][row]
    lsb = build.graph.output("x").qformat.lsb
    assert s.x == ref["x"][-1] * lsb and s.t == pytest.approx(0.15)
    assert s.enc_x == x4_count_delta(ref["enc_x_a"], ref["enc_x_b"]) != 0
    assert s.enc_theta == x4_count_delta(ref["enc_theta_a"], ref["enc_theta_b"]) != 0
    assert not plant.overflows


def test_golden_plant_step_size_and_reset(model, build):
    a = make_plant("golden", model, build=build)
    b = make_plant("golden", model, build=build)
    for u in _switching_input(8, 30):
        one = a.step(u, 1000)
        for _ in range(4):
            many = b.step(u, 250)
        assert one == many and a.raw() == b.raw()
    assert b.reset() == PlantState.at_rest(b.ports)
    assert b.step(10.0, 1000) == make_plant("golden", model, build=build).step(10.0, 1000)


def test_golden_plant_counts_match_the_float_plant(model, build):
    """Different arithmetic, same encoders: the counts agree within one count after 0.5 s."""
    g, f = make_plant("golden", model, build=build), make_plant("float", model)
    for u in _switching_input(9, 500):
        sg, sf = g.step(u, 1000), f.step(u, 1000)
        assert abs(sg.enc_x - sf.enc_x) <= 1 and abs(sg.enc_theta - sf.enc_theta) <= 1


def test_golden_plant_stops_at_an_overflow_naming_node_and_time(model, build):
    from pendc.golden import OverflowStop
    # Table 14 has no end stops: pushed full scale from 0.1 m below the end of x's format
    start = (build.graph.output("x").qformat.max_value - 0.1, 0.0, 0.0, 0.0)
    plant = make_plant("golden", model, build=build, initial=start)
    with pytest.raises(OverflowStop, match=r"node 'x\w*' left its Q-format range at t = 0\.\d+ s") as err:
        for _ in range(1000):
            plant.step(10.0, 1000)
    assert 0.1 < err.value.time < 0.5     # 0.1 m at up to 0.55 m/s
    marking = make_plant("golden", model, build=build, initial=start, on_overflow="mark")
    for _ in range(500):
        marking.step(10.0, 1000)
    assert min(marking.overflows.values()) == err.value.step
