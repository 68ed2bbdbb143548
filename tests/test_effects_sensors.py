"""The effects real rigs add (air drag, end stops, sensor offsets) and the experiments'
equations (held cart, removed pendulum), checked against hand-written physics."""

import math

import numpy as np
import pytest
import sympy as sp

from pendc.errors import PendcError
from plants import CATALOGUE, sct_model
from pendc.model.plant import PlantModel
from pendc.sim.simulator import Simulator

PLANT = {"g": 9.80665, "M": 103.205, "m": 0.581, "L": 0.138867, "I": 6.21034e-3}
DRIVE = {"alpha": 260.0, "V_off": 5.0}
S = {n: sp.Symbol(n, real=True) for n in "x dx theta dtheta c_theta x_end k_end b_end".split()}


def model(**effects):
    return sct_model(plant=dict(PLANT), effects={"drive": dict(DRIVE), **effects})


def test_spec_names_and_parameters():
    spec = {"quadratic_pendulum": {"c_theta"}, "theta_offset": {"theta_off"}, "x_offset": {"x_off"},
            "end_stops": {"x_end", "k_end", "b_end"}}
    for name, params in spec.items():
        assert {p.name for p in CATALOGUE[name].params} == params
        for p in CATALOGUE[name].params:
            assert p.unit and p.description and p.lo <= p.default <= p.hi and p.lo < p.hi
    assert {p.name: p.default for p in CATALOGUE["end_stops"].params}["x_end"] == 0.375


def test_quadratic_drag_torque():
    tau = model(quadratic_pendulum={"c_theta": 1e-3}).equations.assignment("tau_pend")
    assert sp.simplify(tau + S["c_theta"] * S["dtheta"] * sp.Abs(S["dtheta"])) == 0


def test_end_stops_push_back_only_beyond_x_end():
    m = model(end_stops={"x_end": 0.3, "k_end": 1e4, "b_end": 50.0})
    f = m.equations.inline(sp.Symbol("F_cart", real=True)) - model().equations.inline(sp.Symbol("F_cart", real=True))
    values = {sp.Symbol("x_end", real=True): 0.3, sp.Symbol("k_end", real=True): 1e4,
              sp.Symbol("b_end", real=True): 50.0}
    at = lambda x, dx: float(f.subs(values).subs({S["x"]: x, S["dx"]: dx}))
    assert at(0.2, 0.1) == 0.0 and at(-0.29, -0.3) == 0.0
    assert at(0.31, 0.1) == pytest.approx(-1e4 * 0.01 - 50.0 * 0.1)
    assert at(-0.32, -0.2) == pytest.approx(-1e4 * (-0.02) + 50.0 * 0.2)


def test_sensor_offsets_change_the_reading_not_the_motion():
    t = np.arange(1001) * 1e-3
    u = 5.0 + 1.5 * np.sin(2 * np.pi * 2 * t)
    plain = model(viscous_cart={"b_x": 200.0})
    shifted = plain.with_effect("theta_offset", {"theta_off": 0.05}).with_effect("x_offset", {"x_off": -0.01})
    eq = shifted.equations
    assert dict((n, str(e)) for n, e in eq.sensor_offsets) == {"theta": "theta_off", "x": "x_off"}
    # a measurement's effect: the offsets never enter the dynamics
    used = set().union(*(e.free_symbols for _, e in eq.assignments), *(d.free_symbols for d in eq.derivatives))
    assert not {"theta_off", "x_off"} & {s.name for s in used}
    a = Simulator(plain, dt=1e-4, method="rk4")(t, u, x0=(0.0, 0.0, 0.3, 0.0))
    b = Simulator(shifted, dt=1e-4, method="rk4")(t, u, x0=(0.0, 0.0, 0.3, 0.0))
    assert np.array_equal(a["x"], b["x"]) and np.array_equal(a["theta"], b["theta"])
    assert np.allclose(b.measured("theta"), a["theta"] + 0.05) and np.allclose(b.measured("x"), a["x"] - 0.01)
    sim = Simulator(shifted)
    assert np.allclose(sim.true_state([0.02, 0.1, 0.35, 0.0]), [0.03, 0.1, 0.30, 0.0])


def test_held_cart_is_a_pendulum_on_a_fixed_pivot():
    m = model(viscous_pendulum={"b_theta": 0.002}).for_experiment("cart_held")
    t = np.arange(2001) * 1e-3
    res = Simulator(m, dt=1e-4, method="rk4")(t, np.full_like(t, 8.0), x0=(0.02, 0.0, 0.4, 0.0))
    assert np.all(res["x"] == 0.02) and np.all(res["dx"] == 0.0)   # 8 V would drive a free cart hard
    # hand-written pendulum: (m L^2 + I) th'' = -m g L sin th - b th'
    J, mgl = PLANT["m"] * PLANT["L"] ** 2 + PLANT["I"], PLANT["m"] * PLANT["g"] * PLANT["L"]
    th, w, h = 0.4, 0.0, 1e-5
    for _ in range(200000):
        w += h * (-mgl * math.sin(th) - 0.002 * w) / J
        th += h * w
    assert res["theta"][-1] == pytest.approx(th, abs=2e-3)
    assert m.equations.outputs() == ("theta",)
    assert [s.name for s in m.equations.params] == [s.name for s in m.for_experiment("free").equations.params]


def test_removed_pendulum_leaves_the_cart_alone_with_Mg_normal_force():
    m = model(viscous_cart={"b_x": 600.0}, coulomb_cart={"mu_c": 0.03}).for_experiment("pendulum_removed")
    t = np.arange(3001) * 1e-3
    res = Simulator(m, dt=1e-4, method="rk4")(t, np.full_like(t, 6.0), x0=(0.0, 0.0, 0.2, 0.0))
    v_end = (260.0 * 1.0 - 0.03 * PLANT["M"] * PLANT["g"]) / 600.0   # alpha (u - V_off) = mu_c M g + b_x v
    assert res["dx"][-1] == pytest.approx(v_end, rel=1e-4)
    assert np.all(res["theta"] == 0.2)
    assert m.equations.outputs() == ("x",)


def test_unknown_experiment_is_refused():
    with pytest.raises(PendcError, match="unknown experiment"):
        model().for_experiment("upside_down")
