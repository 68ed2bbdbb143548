"""Lowering a plant model into the untyped IR (pendc.passes.lower, lower_encoders)."""

import math
import os
import subprocess
import sys

import numpy as np
import pytest
import sympy as sp

import pendc
from pendc.errors import PendcError
from pendc.ir import lut as lut_sem
from pendc.ir.graph import Graph
from pendc.ir.interpret import FloatInterpreter
from pendc.ir.nodes import Kind, make
from pendc.ir.verify import verify
from plants import CATALOGUE, sct_model
from pendc.model.plant import PlantModel
from pendc.passes.lower import lower_model
from pendc.passes.ranges import per_step
from plants import swing_up, TANK_FILE

DT = 1e-6
STATES = ("x", "dx", "theta", "dtheta")
# spec section 4: x4 decoding gives 2000 counts per 5 mm spindle revolution and 20000 per pendulum turn
CART_COUNT = 5e-3 / 2000            # 2.5 um
PEND_COUNT = 2 * math.pi / 20000    # 0.314 mrad
PLANT = {"g": 9.80665, "M": 103.205, "m": 0.581, "L": 0.138867, "I": 6.21034e-3}
DRIVE = {"alpha": 260.78841, "V_off": 5.264616}
# non-default values, so that every effect really contributes a term
EFFECT_PARAMS = {
    "asymmetric_cart": {"d_mu": 0.2}, "static_cart": {"mu_s": 0.05, "v_stick": 0.001},
    "stribeck_cart": {"v_stick": 0.0005}, "cart_spring": {"k_c": 500.0, "x_0": 0.01},
    "drive_deadzone": {"u_dz": 0.3}, "force_limit": {"F_max": 300.0}, "motor_lag": {"tau_m": 5e-4},
    "coulomb_pendulum": {"tau_c": 0.01},
}
# an effect that only refines another one needs a partner
PARTNER = {"asymmetric_cart": "coulomb_cart", "static_cart": "coulomb_cart"}


@pytest.fixture(scope="module")
def model():
    return pendc.load_model()


@pytest.fixture(scope="module")
def graph(model):
    return lower_model(model, dt=DT)


def effect_model(name):
    m = sct_model(plant=dict(PLANT), effects={"drive": dict(DRIVE)})
    if name in PARTNER:
        m = m.with_effect(PARTNER[name])
    return m.with_effect(name, EFFECT_PARAMS.get(name))


def run_float(graph, u):
    return FloatInterpreter(graph).run({"u": np.asarray(u, float)})


def assert_matches_simulator(graph, model, u, rtol=1e-12):
    """The lowered graph in real arithmetic is the float simulator's 1 us Euler step."""
    trace = run_float(graph, u)
    assert not trace.overflows
    res = pendc.Simulator(model, dt=DT, method="euler")(np.arange(len(u)) * DT, u)
    for s in STATES:
        ref = res[s]
        scale = np.max(np.abs(ref))
        assert scale > 0, s
        np.testing.assert_allclose(trace.outputs[s], ref, rtol=0, atol=rtol * scale, err_msg=s)


# -- structure of the default model's graph --------------------------------------------------

def test_default_model_lowers_and_verifies(graph):
    verify(graph)
    assert graph.name == "pendulum_core"
    assert [p for p, _ in graph.outputs] == ["x", "dx", "theta", "dtheta", "enc_x_a", "enc_x_b",
                                            "enc_theta_a", "enc_theta_b"]
    for s in STATES:
        assert graph[s].kind is Kind.REGISTER and graph.output(s).name == s
        assert graph[s].param("reset") == 0.0
    (u,) = graph.of_kind(Kind.INPUT)
    assert u.param("port") == "u"
    assert dict(graph.info)["dt"] == DT
    assert all(n.qformat is None for n in graph.nodes)


def test_no_division(graph):
    """No node kind divides; the determinant k(theta) only appears inside tables of theta."""
    assert not {k.name for k in Kind} & {"DIV", "DIVIDE", "RECIP"}
    v = sp.Symbol("v", real=True)
    divided = 0
    for n in graph.of_kind(Kind.LUT):
        expr = sp.sympify(n.param("expr"), locals={"v": v})
        if any(isinstance(a, sp.Pow) and a.exp.is_negative and v in a.base.free_symbols
               for a in sp.preorder_traversal(expr)):
            divided += 1
            assert n.param("periodic") and n.inputs == ("theta_turns",), n.name
    assert divided >= 4      # every coefficient of ddx and ddtheta carries 1/k(theta)


def test_every_table_is_a_function_of_one_variable(graph):
    v = sp.Symbol("v", real=True)
    luts = graph.of_kind(Kind.LUT)
    assert len(luts) >= 5
    for n in luts:
        expr = sp.sympify(n.param("expr"), locals={"v": v})
        assert expr.free_symbols <= {v}, n.name
        assert len(n.inputs) == 1
        assert n.param("interpolate") in (True, False) and n.param("addr_bits") >= 1


def test_theta_tables_are_periodic_over_turns(graph):
    turns = graph["theta_turns"]
    assert turns.kind is Kind.GAIN and turns.inputs == ("theta_phase",)
    phase = graph["theta_phase"]
    assert phase.kind is Kind.SUB and phase.inputs == ("theta", "theta_whole_turns")
    assert turns.param("value") == pytest.approx(1 / (2 * math.pi), rel=1e-15)
    periodic = [n for n in graph.of_kind(Kind.LUT) if n.param("periodic")]
    assert len(periodic) >= 4
    grid = np.linspace(0.0, 1.0, 97)
    for n in periodic:
        assert n.inputs == ("theta_turns",), n.name
        assert (n.param("lo"), n.param("hi")) == (0.0, 1.0)
        a = lut_sem.evaluate(n.param("expr"), grid)
        for k in (1, -1, 3):
            np.testing.assert_allclose(lut_sem.evaluate(n.param("expr"), grid + k), a, rtol=1e-9, atol=1e-12)
    # every table of theta alone is addressed in turns
    for n in graph.of_kind(Kind.LUT):
        if n.inputs == ("theta",):
            pytest.fail(f"{n.name} reads theta in radians")


def test_non_periodic_tables_have_no_domain_yet(graph):
    for n in graph.of_kind(Kind.LUT):
        if not n.param("periodic"):
            assert n.param("lo") is None and n.param("hi") is None


# -- float semantics ----------------------------------------------------------------------------

def test_float_interpreter_equals_float_simulator(graph, model):
    t, u = swing_up()
    steps = per_step(u, t, DT)[:4000]
    assert len(set(steps.tolist())) >= 3        # the input changes within the window
    assert_matches_simulator(graph, model, steps)


def test_float_interpreter_equals_simulator_with_every_effect():
    """All lowerable effects at once (non-trivial parameters), from rest at u = V_off."""
    m = pendc.load_model()
    for name in ("force_limit", "drive_deadzone", "motor_lag", "coulomb_pendulum", "cart_spring", "asymmetric_cart"):
        m = m.with_effect(name, EFFECT_PARAMS.get(name))
    g = lower_model(m, dt=DT)
    verify(g)
    u = np.concatenate([np.full(500, DRIVE["V_off"]), np.full(1500, 7.5), np.full(1500, 2.0)])
    assert_matches_simulator(g, m, u)


def test_motor_lag_state_starts_like_the_simulator():
    m = effect_model("motor_lag")
    g = lower_model(m, dt=DT)
    u = np.full(1000, 7.5)                       # F_in(u0) = alpha * (7.5 - V_off) != 0
    assert_matches_simulator(g, m, u)


# -- determinism ------------------------------------------------------------------------------

def test_text_is_identical_across_lowerings(graph, model):
    assert lower_model(model, dt=DT).text() == graph.text()
    assert lower_model(pendc.load_model(), dt=DT).text() == graph.text()


def test_text_is_identical_across_hash_seeds(graph):
    code = ("import sys, pendc\nfrom pendc.passes.lower import lower_model\n"
            "sys.stdout.write(lower_model(pendc.load_model(), dt=1e-6).text())\n")
    texts = []
    for seed in ("0", "4242"):
        env = dict(os.environ, PYTHONHASHSEED=seed)
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120,
                             check=True)
        texts.append(out.stdout)
    assert texts[0] == texts[1] == graph.text()


# -- effects --------------------------------------------------------------------------------

LOWERABLE = [n for n in CATALOGUE if n not in ("drive", "input_delay")]


@pytest.mark.parametrize("name", LOWERABLE)
def test_each_effect_lowers_and_verifies(name):
    m = effect_model(name)
    g = lower_model(m, dt=DT)
    verify(g)
    base = lower_model(effect_model(PARTNER[name]) if name in PARTNER else
                       sct_model(plant=dict(PLANT), effects={"drive": dict(DRIVE)}), dt=DT)
    if CATALOGUE[name].acts_on in ("x", "theta"):
        # a sensor offset changes what a recording reads, not the motion; the encoders count
        # from power-on, so the hardware has no form of it
        assert g.text() == base.text(), f"sensor effect {name} changed the dynamics"
        return
    assert g.text() != base.text(), f"effect {name} left no trace in the graph"
    trace = run_float(g, np.concatenate([np.full(100, DRIVE["V_off"]), np.full(200, 8.0)]))
    assert not trace.overflows
    assert all(np.all(np.isfinite(v)) for v in trace.outputs.values())
    assert trace.outputs["x"][-1] > 0           # pushed by u > V_off
    if name == "motor_lag":
        assert g["F_m"].kind is Kind.REGISTER


def test_input_delay_is_refused_by_name():
    m = sct_model(plant=dict(PLANT), effects={"drive": dict(DRIVE)}).with_effect("input_delay")
    with pytest.raises(PendcError, match="input_delay"):
        lower_model(m)


def test_velocity_limit_is_a_clamp_after_integration(graph):
    nxt = graph["dx"].inputs[0]
    assert graph[nxt].kind is Kind.MUX
    compares = {n.param("op") for n in graph.of_kind(Kind.COMPARE) if "dx_sum" in n.inputs}
    assert compares == {"gt", "lt"}


# -- encoders -------------------------------------------------------------------------------

_GRAY = {(1, 0): 0, (1, 1): 1, (0, 1): 2, (0, 0): 3}     # A leads B when the position grows


def decode_x4(a, b):
    """A x4 quadrature decoder: +-1 count per edge of either channel, 0 at the first sample."""
    phase = np.array([_GRAY[(int(p), int(q))] for p, q in zip(a, b)])
    step = np.diff(phase) % 4
    assert not np.any(step == 2), "a step skipped a quadrature state"
    return np.concatenate([[0], np.cumsum(np.where(step == 1, 1, np.where(step == 3, -1, 0)))])


def constant_speed(graph, dx, dtheta):
    """The lowered graph with the velocity registers replaced by constants, pruned to what the
    position registers and encoders need."""
    nodes = [make(n.name, Kind.CONST, value=dx) if n.name == "dx" else
             make(n.name, Kind.CONST, value=dtheta) if n.name == "dtheta" else n for n in graph.nodes]
    by_name = {n.name: n for n in nodes}
    keep = ["x", "theta"] + [n for p, n in graph.outputs if p.startswith("enc_")]
    live, todo = {"u"}, list(keep)
    while todo:
        name = todo.pop()
        if name not in live:
            live.add(name)
            todo.extend(by_name[name].inputs)
    outputs = [(p, n) for p, n in graph.outputs if n in live]
    return Graph.build("encoders", [n for n in nodes if n.name in live], outputs)


@pytest.mark.parametrize("dx, dtheta", [(0.07, -2.3), (-0.045, 1.7)])
def test_encoders_decode_to_the_position_within_one_count(graph, dx, dtheta):
    g = constant_speed(graph, dx, dtheta)
    steps = 12000
    trace = run_float(g, np.zeros(steps))
    assert not trace.overflows, f"encoder FSM out of window: {trace.overflows}"
    x, theta = trace.outputs["x"], trace.outputs["theta"]
    assert abs(x[-1]) > 100 * CART_COUNT and abs(theta[-1]) > 50 * PEND_COUNT   # many counts travelled
    for (a, b), pos, count in (((trace.outputs["enc_x_a"], trace.outputs["enc_x_b"]), x, CART_COUNT),
                               ((trace.outputs["enc_theta_a"], trace.outputs["enc_theta_b"]), theta, PEND_COUNT)):
        counts = decode_x4(a, b)
        assert np.sign(counts[-1]) == np.sign(pos[-1])
        err = counts * count - pos
        # the decoder counts floor(position / count): 0 <= pos - counts*count < one count
        # (up to the float phase accumulator's rounding)
        tol = 1e-6 * count
        assert np.all(err <= tol) and np.all(err > -count - tol), (err.min() / count, err.max() / count)
        assert np.max(np.abs(err)) <= count * (1 + 1e-6)


def test_encoder_channels_start_at_the_documented_levels(graph):
    trace = run_float(graph, np.full(3, DRIVE["V_off"]))
    for enc in ("enc_x", "enc_theta"):
        assert trace.outputs[f"{enc}_a"][0] == 1 and trace.outputs[f"{enc}_b"][0] == 0


# -- a pendulum that spins, a cart that hits the ends ------------------------------------------

def test_theta_stays_continuous_while_the_tables_read_its_phase(model):
    """Started spinning at 30 rad/s: theta runs over many turns in the graph (real arithmetic)
    exactly as in the float simulator, the turn counter follows and the phase stays within
    one turn of zero; theta's declared range holds the interface's turns."""
    g = lower_model(model, dt=DT)
    spinning = g.map_nodes(lambda n: n.with_params(reset=30.0) if n.name == "dtheta" else n)
    u = np.full(600_000, DRIVE["V_off"])
    from pendc.ir.compiled import CompiledGraph
    trace = CompiledGraph(spinning, "float").run({"u": u}, record=("theta_phase", "theta_turn"), every=1000)
    res = pendc.Simulator(model, dt=DT)(np.arange(len(u)) * DT, u, x0=(0.0, 0.0, 0.0, 30.0))
    np.testing.assert_allclose(trace.outputs["theta"], res["theta"][::1000], rtol=1e-9, atol=1e-9)
    assert trace.outputs["theta"][-1] > 2 * 2 * math.pi                       # over two turns
    np.testing.assert_allclose(trace.outputs["theta_phase"] + 2 * math.pi * trace.outputs["theta_turn"],
                               trace.outputs["theta"], rtol=0, atol=1e-9)
    assert np.all(np.abs(trace.outputs["theta_phase"]) <= math.pi + 30 * DT)
    assert g["theta"].param("max_abs") == pytest.approx(2 * math.pi * model.interface.state("theta").turns)


def test_end_stops_lower_to_compare_and_mux_and_match_the_simulator():
    m = pendc.load_model().with_effect("end_stops", {"x_end": 0.01, "k_end": 2e5, "b_end": 2e3})
    g = lower_model(m, dt=DT)
    verify(g)
    u = np.full(120_000, 10.0)                # reaches the stop 1 cm away within about 80 ms
    from pendc.ir.compiled import CompiledGraph
    trace = CompiledGraph(g, "float").run({"u": u})
    res = pendc.Simulator(m, dt=DT)(np.arange(len(u)) * DT, u)
    np.testing.assert_allclose(trace.outputs["x"], res["x"], rtol=0, atol=1e-12)
    assert res["x"].max() > 0.01 and res["dx"][-1] < 0.5 * res["dx"].max()   # the stop holds it back



def test_a_constant_irrational_factor_is_folded_into_the_coefficient():
    """sympy splits sqrt(2*h*L) into sqrt(2)*sqrt(L)*sqrt(h) and keeps sqrt(2) apart from the value
    of L: it is a number, not a factor to multiply by (it stopped the build: "no dividers")."""
    model = pendc.parse_model(TANK_FILE, "tank.toml")
    graph = lower_model(model, dt=DT)
    verify(graph)
    u = np.full(2000, 0.3)
    trace = FloatInterpreter(graph).run({"u": u})
    res = pendc.Simulator(model, dt=DT, method="euler")(np.arange(len(u)) * DT, u)
    np.testing.assert_allclose(trace.outputs["h"], res["h"], rtol=0, atol=1e-12)
    assert res["h"][0] == 0.2


def test_a_state_nothing_reads_and_nothing_reports_is_a_one_line_error():
    text = TANK_FILE + '[states.q]\nunit = "m"\nmeaning = "inflow so far"\nderivative = "u"\noutput = false\n'
    with pytest.raises(PendcError, match=r"^tank\.toml: states\.q: nothing reads it and it is not reported"):
        lower_model(pendc.parse_model(text, "tank.toml"), dt=DT)


PIPE = """
[plant]
name = "pipes"
a = 1.0
[constants]
a = { unit = "1/s", meaning = "rate" }
[intermediates]
q = { value = "FLOW", meaning = "flow" }
[states.x1]
unit = "1"
meaning = "level 1"
derivative = "u - q"
initial = 0.5
[states.x2]
unit = "1"
meaning = "level 2"
derivative = "q - a*x2"
initial = 0.2
[inputs.u]
unit = "1/s"
meaning = "inflow"
range = [0.0, 1.0]
"""


def _luts(flow: str):
    graph = lower_model(pendc.parse_model(PIPE.replace("FLOW", flow)), dt=DT)
    verify(graph)
    return graph, graph.of_kind(Kind.LUT)


def test_a_function_of_a_difference_is_a_table_of_the_difference():
    """A flow through a pipe between two levels, smooth at zero (the private check's three
    tanks): one table of x1 - x2, not the expansion's table of x1^2 - 2 x1 x2 + x2^2 (steep and
    cancelling near equal levels; the build was refused as a function of several variables)."""
    graph, luts = _luts("a*(x1 - x2)/((x1 - x2)**2 + 1e-6)**(1/4)")
    assert len(luts) == 1
    source = graph[luts[0].inputs[0]]
    assert source.kind is Kind.SUB and set(source.inputs) == {"x1", "x2"}
    assert not graph.of_kind(Kind.MUL) or all("x1" not in n.inputs or "x2" not in n.inputs
                                               for n in graph.of_kind(Kind.MUL))
    interp = FloatInterpreter(graph)
    out = interp.run({"u": np.zeros(3)})
    d = 0.5 - 0.2
    q = d / (d * d + 1e-6) ** 0.25
    assert out.outputs["x1"][1] == pytest.approx(0.5 - DT * q, abs=1e-12)


def test_a_function_of_a_computed_argument_is_a_table_of_it():
    """A smooth function of one argument that is not a difference (x1 x2 + 1): the argument is
    computed, the function is a table of it; a function of two arguments is one line naming
    where it was."""
    graph, luts = _luts("a*sqrt(x1*x2 + 1)")
    assert len(luts) == 1 and graph[luts[0].inputs[0]].kind in (Kind.ADD, Kind.MUL, Kind.GAIN)
    with pytest.raises(PendcError, match=r"cannot lower .*\(in q\): a smooth function of several variables"):
        _luts("a*atan2(x1, x2 + 1)")
