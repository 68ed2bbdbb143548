"""The short-chain lowering (``lower_model(fold_dt, turns_phase, deep_last)``, BuildOptions.short_chain).

It changes the arithmetic, not the mathematics: in real numbers it computes the same step as
the default lowering (a second, independent code path), and its structure has no
``derivative x dt`` product on the integrators, the whole turns its periodic tables' address
subtracts come from a register, |dx| is taken of a cast of dx, and each sum adds its latest
term last."""

import numpy as np
import pytest

import pendc
from pendc.ir.interpret import FloatInterpreter
from pendc.ir.nodes import Kind
from pendc.passes.fold_constants import fold_constants
from pendc.passes.lower import lower_model
from pendc.passes.pipeline import BuildOptions, preset_options, validate_options
from pendc.sim.stimuli import swing_up

SHORT = {"fold_dt": True, "turns_phase": True, "deep_last": True, "narrow_abs": True}


@pytest.fixture(scope="module")
def model():
    return pendc.load_model()


@pytest.fixture(scope="module")
def graphs(model):
    return fold_constants(lower_model(model)), fold_constants(lower_model(model, **SHORT))


def _started(graph, **state):
    """``graph`` with its registers reset to ``state`` (a step that starts mid-motion)."""
    return graph.map_nodes(lambda n: n.with_params(reset=state[n.name]) if n.name in state else n)


def test_same_step_in_real_numbers(graphs):
    """Both lowerings integrate the same trajectory to float rounding, started just short of
    half a turn of the angle (so the turn counter steps and the periodic tables wrap) with the
    cart near its velocity clamp, under a swing-up drive."""
    _, u = swing_up()
    n = 4000
    u = np.repeat(u[::40], 40)[:n]
    start = {"theta": 3.13, "dtheta": 10.0, "dx": 0.54}
    runs = [FloatInterpreter(_started(g, **start)).run({_port(g): u}) for g in graphs]
    for state in ("x", "dx", "theta", "dtheta"):
        a, b = runs[0].outputs[state], runs[1].outputs[state]
        scale = max(float(np.max(np.abs(a))), 1e-9)
        assert np.max(np.abs(a - b)) <= 1e-9 * scale, state
    assert runs[1].outputs["theta"][-1] > np.pi        # past half a turn: the counter stepped
    assert np.ptp(runs[1].outputs["dx"]) > 0


def _port(graph):
    (node,) = graph.of_kind(Kind.INPUT)
    return node.params.port


def _increment(graph, state):
    """The node a state's integrator adds to it (the second input of ``<state>_sum``)."""
    total = graph[f"{state}_sum"]
    assert total.inputs[0] == state
    return graph[total.inputs[1]]


def test_no_dt_product_on_the_integrators(graphs):
    default, short = graphs
    # the default: the derivative times dt, a gain on the integrator's input
    assert _increment(default, "dx").kind is Kind.GAIN
    assert _increment(default, "dx").param("value") == pytest.approx(1e-6)
    # short chain: the increment is the sum itself, its tables carry dt
    inc = _increment(short, "dx")
    assert inc.kind in (Kind.ADD, Kind.SUB)
    assert "ddx" not in short.by_name         # the acceleration itself is never formed
    luts = [n for n in short.of_kind(Kind.LUT) if n.name.startswith("dx_inc")]
    assert luts and all("e-" in n.param("expr") for n in luts)


def test_latest_term_added_last(graphs):
    """The friction force (tables of |dx|, compares, muxes) is the last term of F_cart, and the
    F_cart term the last of the cart's increment."""
    _, short = graphs
    assert "F_fric" in short["F_cart"].inputs
    last = short[_increment(short, "dx").inputs[1]]
    assert last.kind is Kind.MUL and "F_cart" in last.inputs


def test_abs_of_a_cast(graphs):
    """|dx| negates and selects a cast of dx (rounded once), not the 56-bit state."""
    default, short = graphs
    (abs_default,) = [n for n in default.of_kind(Kind.MUX) if n.name.startswith("abs_dx")]
    (abs_short,) = [n for n in short.of_kind(Kind.MUX) if n.name.startswith("abs_dx")]
    assert abs_default.inputs[1] == "dx"
    cast = short[abs_short.inputs[1]]
    assert cast.kind is Kind.CAST and cast.inputs == ("dx",)
    assert short[abs_short.inputs[2]].inputs == (cast.name,)


def test_whole_turns_come_from_a_register(graphs):
    """The phase subtracts a register of period x turns, loaded from the counter's next value
    (the default: a product of the counter in the step itself)."""
    default, short = graphs
    assert default["theta_whole_turns"].kind is Kind.GAIN
    assert default["theta_whole_turns"].inputs == ("theta_turn",)
    phase = short["theta_phase"]
    assert phase.kind is Kind.SUB and phase.inputs == ("theta", "theta_whole_turns")
    whole = short["theta_whole_turns"]
    assert whole.kind is Kind.REGISTER
    loaded = short[whole.inputs[0]]
    assert loaded.kind is Kind.GAIN and loaded.inputs == ("theta_turn_next",)
    assert loaded.param("value") == pytest.approx(2 * np.pi)


def test_option_and_presets():
    assert BuildOptions().short_chain is False                   # the default build is unchanged
    assert validate_options({"short_chain": True}).short_chain is True
    assert preset_options("fast") == {"short_chain": True} == preset_options("fmax")
    assert preset_options("default") == {} == preset_options(None) == preset_options("small")
    with pytest.raises(pendc.errors.PendcError, match="short_chain must be a bool"):
        validate_options({"short_chain": "yes"})
