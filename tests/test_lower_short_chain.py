"""The short-chain lowering (``lower_model(fold_dt, turns_phase, deep_last, narrow_abs, lookahead,
clamp_on_increment)``, BuildOptions.short_chain).

It changes the arithmetic, not the mathematics: in real numbers it computes the same step as
the default lowering (a second, independent code path), and its structure has no
``derivative x dt`` product on the integrators, the whole turns its periodic tables' address
subtracts come from a register, |dx| is taken of a cast of dx, each sum adds its latest
term last, the tables of the angle are registers read a step ahead and the velocity clamp
compares the increment with the room left."""

import numpy as np
import pytest

import pendc
from pendc.ir import lut as lut_sem
from pendc.ir.compare_ops import CompareOp
from pendc.ir.interpret import FloatInterpreter
from pendc.ir.verify import verify
from pendc.ir.nodes import Kind
from pendc.passes.fold_constants import fold_constants
from pendc.passes.lower import lower_model
from pendc.passes.pipeline import BuildOptions, preset_options, validate_options
from pendc.passes.step_bound import periodic_tables
from plants import swing_up

SHORT = {"fold_dt": True, "turns_phase": True, "deep_last": True, "narrow_abs": True, "lookahead": True,
         "clamp_on_increment": True, "sum_into_mux": True}


@pytest.fixture(scope="module")
def model():
    return pendc.load_model()


@pytest.fixture(scope="module")
def graphs(model):
    return fold_constants(lower_model(model)), fold_constants(lower_model(model, **SHORT))


def _started(graph, **state):
    """``graph`` with its registers reset to ``state`` (a step that starts mid-motion); tables
    read a step ahead start at their value there (the angle in turns: no whole turns yet)."""
    def reset(n):
        if n.name in state:
            return n.with_params(reset=state[n.name])
        src = graph[n.inputs[0]] if n.kind is Kind.REGISTER else None
        if src is not None and src.kind is Kind.LUT and src.param("periodic"):
            turns = state["theta"] / (2 * np.pi)
            return n.with_params(reset=float(lut_sem.evaluate(src.param("expr"), [turns])[0]))
        return n
    return graph.map_nodes(reset)


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
    """The friction force (tables of |dx|, compares, muxes) is the last term of F_cart, added in
    each branch of its selects (F_cart is the mux), and the F_cart term the last of the cart's
    increment."""
    _, short = graphs
    assert short["F_cart"].kind is Kind.MUX and "F_fric" not in short.by_name
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


def test_angle_tables_read_a_step_ahead(graphs):
    """Every table of the angle is a register loaded from its read for the next step, addressed
    by this step's phase in turns plus the angle's increment in turns less the turns gained (no
    product after the angle's sum or the turn counter); none reads this step's angle."""
    default, short = graphs
    assert any(n.param("periodic") for n in default.of_kind(Kind.LUT))
    periodic = [n for n in short.of_kind(Kind.LUT) if n.param("periodic")]
    assert periodic
    for lut in periodic:
        (reg,) = [n for n in short.of_kind(Kind.REGISTER) if n.inputs == (lut.name,)]
        assert reg.param("reset") == pytest.approx(lut_sem.evaluate(lut.param("expr"), [0.0])[0], abs=0.0)
        turns = short[lut.inputs[0]]
        assert turns.kind is Kind.ADD
        ahead, now = (short[i] for i in turns.inputs)
        assert now.kind is Kind.GAIN and now.inputs == ("theta_phase",)
        assert now.param("value") == pytest.approx(1 / (2 * np.pi))
        assert ahead.kind is Kind.SUB and ahead.inputs[1] == "theta_turn_step"
        moved = short[ahead.inputs[0]]
        assert moved.kind is Kind.GAIN and moved.inputs == ("dtheta",)
        assert moved.param("value") == pytest.approx(1e-6 / (2 * np.pi))
    # none is left for the step bound's lookahead what-if; the default build's are all candidates
    assert periodic_tables(short) == ()
    assert set(periodic_tables(default)) == {n.name for n in default.of_kind(Kind.LUT) if n.param("periodic")}


def test_clamp_compares_the_increment(graphs):
    """The clamp's compares read the increment and the room to each bound (bound - dx), not the
    56-bit sum; the muxes still select the sum."""
    _, short = graphs
    inc = _increment(short, "dx").name
    for flag, room in (("dx_over", "dx_room_up"), ("dx_under", "dx_room_down")):
        assert short[flag].inputs == (inc, room)
        assert short[room].kind is Kind.SUB and short[room].inputs[1] == "dx"
    assert "dx_sum" in short["dx_upper"].inputs


def test_friction_added_in_the_branches(graphs):
    """Under ``dx != 0`` the force is (dx < 0 ? acc - T : acc + T) of the friction table T: one
    adder and two muxes from the table to the force, no negation of T and no dx == 0 test."""
    _, short = graphs
    force = short["F_cart"]
    sel = short[force.inputs[0]]
    assert sel.kind is Kind.COMPARE and sel.inputs[0] == "dx" and sel.params.op is CompareOp.NE
    moving = short[force.inputs[2]]
    assert moving.kind is Kind.MUX and short[moving.inputs[0]].kind is Kind.SLICE
    plus, minus = (short[i] for i in moving.inputs[1:])
    (table,) = [n.name for n in short.of_kind(Kind.LUT) if not n.param("periodic")]
    assert (plus.kind, minus.kind) == (Kind.ADD, Kind.SUB)
    assert plus.inputs[1] == table == minus.inputs[1] and plus.inputs[0] == minus.inputs[0]
    assert not [n for n in short.nodes if n.kind is Kind.NEG and n.inputs == (table,)]


def test_lowered_graph_verifies(model):
    """Straight out of the lowering (before constant folding) the short chain passes the verifier:
    the table registers of a derivative that fold_dt leaves unread are swept with it."""
    verify(lower_model(model, **SHORT))


def test_lookahead_needs_the_turns_register(model):
    with pytest.raises(pendc.errors.PendcError, match="turns_phase"):
        lower_model(model, fold_dt=True, lookahead=True)


def test_option_and_presets():
    assert BuildOptions().short_chain is False                   # the default build is unchanged
    assert validate_options({"short_chain": True}).short_chain is True
    assert preset_options("fast") == {"short_chain": True} == preset_options("fmax")
    assert preset_options("default") == {} == preset_options(None) == preset_options("small")
    with pytest.raises(pendc.errors.PendcError, match="short_chain must be a bool"):
        validate_options({"short_chain": "yes"})
