"""Each catalogue effect contributes exactly its spec §8 term to the equations."""

import pytest
import sympy as sp

from pendc.errors import PendcError
from plants import CATALOGUE, TANK_FILE, sct_model
from pendc.model.plant import PlantModel

PLANT = {"g": 9.80665, "M": 103.205, "m": 0.581, "L": 0.138867, "I": 6.21034e-3}
DRIVE = {"alpha": 260.0, "V_off": 5.0}

S = {n: sp.Symbol(n, real=True) for n in
     "x dx theta dtheta u F_N alpha V_off b_x mu_c mu_s v_s gamma v_stick d_mu b_theta tau_c "
     "v_max F_max u_dz tau_d tau_m k_c x_0 F_m".split()}


def model(**effects):
    return sct_model(plant=dict(PLANT), effects={"drive": dict(DRIVE), **effects})


def cart_terms(m):
    """F_cart with F_in and F_fric inlined, as a function of states, u and parameters."""
    eq = m.equations
    return sp.expand(eq.inline(sp.Symbol("F_cart", real=True)))


def base_cart():
    return cart_terms(model())


def test_catalogue_names_are_the_spec_interface():
    assert set(CATALOGUE) >= {
        "drive", "viscous_cart", "coulomb_cart", "static_cart", "stribeck_cart", "asymmetric_cart",
        "viscous_pendulum", "coulomb_pendulum", "velocity_limit", "force_limit", "drive_deadzone",
        "input_delay", "motor_lag", "cart_spring"}
    spec_params = {
        "drive": {"alpha", "V_off"}, "viscous_cart": {"b_x"}, "coulomb_cart": {"mu_c"},
        "static_cart": {"mu_s", "v_stick"}, "stribeck_cart": {"mu_c", "mu_s", "v_s", "gamma"},
        "asymmetric_cart": {"d_mu"}, "viscous_pendulum": {"b_theta"}, "coulomb_pendulum": {"tau_c"},
        "velocity_limit": {"v_max"}, "force_limit": {"F_max"}, "drive_deadzone": {"u_dz"},
        "input_delay": {"tau_d"}, "motor_lag": {"tau_m"}, "cart_spring": {"k_c", "x_0"}}
    for name, params in spec_params.items():
        declared = {p.name for p in CATALOGUE[name].params}
        assert params <= declared, name
        for p in CATALOGUE[name].params:
            assert p.unit and p.description and p.lo <= p.default <= p.hi
        assert CATALOGUE[name].summary


def test_drive_force():
    eq = model().equations
    assert sp.simplify(eq.assignment("F_in") - S["alpha"] * (S["u"] - S["V_off"])) == 0
    assert sp.simplify(base_cart() - S["alpha"] * (S["u"] - S["V_off"])) == 0


@pytest.mark.parametrize("effect, params, term", [
    ("viscous_cart", {"b_x": 100.0}, -S["b_x"] * S["dx"]),
    ("coulomb_cart", {"mu_c": 0.03}, -S["mu_c"] * S["F_N"] * sp.sign(S["dx"])),
    ("cart_spring", {"k_c": 10.0, "x_0": 0.1}, -S["k_c"] * (S["x"] - S["x_0"])),
])
def test_additive_cart_forces(effect, params, term):
    m = model(**{effect: params})
    diff = sp.simplify(cart_terms(m) - base_cart() - m.equations.inline(term))
    assert diff == 0


@pytest.mark.parametrize("effect, params, term", [
    ("viscous_pendulum", {"b_theta": 0.01}, -S["b_theta"] * S["dtheta"]),
    ("coulomb_pendulum", {"tau_c": 0.001}, -S["tau_c"] * sp.sign(S["dtheta"])),
])
def test_pendulum_torques(effect, params, term):
    assert model().equations.assignment("tau_pend") == 0
    assert sp.simplify(model(**{effect: params}).equations.assignment("tau_pend") - term) == 0


def test_stribeck_moving_branch_and_sticking_rule():
    eq = model(stribeck_cart={"mu_c": 0.03, "mu_s": 0.04, "v_s": 0.1, "gamma": 2.0}).equations
    fric = eq.assignment("F_fric")
    assert isinstance(fric, sp.Piecewise)
    (moving, c1), (stick, c2), (breakaway, _) = fric.args
    w = sp.exp(-(sp.Abs(S["dx"]) / S["v_s"]) ** S["gamma"])
    expect = -(S["mu_c"] + (S["mu_s"] - S["mu_c"]) * w) * S["F_N"] * sp.sign(S["dx"])
    assert sp.simplify(moving - expect) == 0
    F_in = sp.Symbol("F_in", real=True)
    assert stick == -F_in and breakaway == -S["mu_s"] * S["F_N"] * sp.sign(F_in)
    assert c1.canonical == (sp.Abs(S["dx"]) > S["v_stick"]).canonical
    assert c2.canonical == (sp.Abs(F_in) < S["mu_s"] * S["F_N"]).canonical


def test_static_with_coulomb_gives_the_same_law_shape():
    eq = model(coulomb_cart={"mu_c": 0.03}, static_cart={"mu_s": 0.04}).equations
    (moving, _), (stick, _), _ = eq.assignment("F_fric").args
    assert sp.simplify(moving + S["mu_c"] * S["F_N"] * sp.sign(S["dx"])) == 0


def test_asymmetric_scales_the_moving_branch():
    eq = model(coulomb_cart={"mu_c": 0.03}, asymmetric_cart={"d_mu": 0.2}).equations
    expect = -S["mu_c"] * S["F_N"] * sp.sign(S["dx"]) * (1 + S["d_mu"] * sp.sign(S["dx"]))
    assert sp.simplify(eq.assignment("F_fric") - expect) == 0


def test_force_limit_and_deadzone_shape_the_drive():
    eq = model(force_limit={"F_max": 100.0}).equations
    F = eq.assignment("F_in")
    vals = {S["alpha"]: 260.0, S["V_off"]: 5.0, S["F_max"]: 100.0}
    assert F.subs({**vals, S["u"]: 9.0}) == 100.0
    assert F.subs({**vals, S["u"]: 1.0}) == -100.0
    assert float(F.subs({**vals, S["u"]: 5.1})) == pytest.approx(26.0)
    eq = model(drive_deadzone={"u_dz": 0.2}).equations
    F = eq.assignment("F_in")
    vals = {S["alpha"]: 260.0, S["V_off"]: 5.0, S["u_dz"]: 0.2}
    assert F.subs({**vals, S["u"]: 5.1}) == 0
    assert float(F.subs({**vals, S["u"]: 5.5})) == pytest.approx(260.0 * 0.3)
    assert float(F.subs({**vals, S["u"]: 4.5})) == pytest.approx(-260.0 * 0.3)


def test_motor_lag_adds_a_state_that_replaces_F_in():
    eq = model(motor_lag={"tau_m": 0.01}).equations
    assert [s.name for s in eq.states] == ["x", "dx", "theta", "dtheta", "F_m"]
    F_in = sp.Symbol("F_in", real=True)
    assert sp.simplify(eq.derivatives[4] - (F_in - S["F_m"]) / S["tau_m"]) == 0
    assert eq.assignment("F_cart") == S["F_m"]
    assert len(eq.initial) == 1


def test_delay_and_velocity_limit_are_carried_to_the_simulator():
    eq = model(input_delay={"tau_d": 0.003}, velocity_limit={"v_max": 0.5}).equations
    assert eq.delay == S["tau_d"] and eq.velocity_bound == S["v_max"]
    eq = model().equations
    assert eq.delay is None and eq.velocity_bound is None


def test_removing_an_effect_removes_its_term():
    m = model(viscous_cart={"b_x": 10.0}, viscous_pendulum={"b_theta": 0.01})
    m2 = m.without_effect("viscous_pendulum")
    assert m2.equations.assignment("tau_pend") == 0
    assert "b_theta" not in {s.name for s in m2.equations.params}


@pytest.mark.parametrize("effects, message", [
    ({"coulomb_cart": {"mu_c": 0.1}, "stribeck_cart": {"mu_c": 0.1, "mu_s": 0.1, "v_s": 0.1, "gamma": 1.0}},
     "moving-branch"),
    ({"static_cart": {"mu_s": 0.1}, "stribeck_cart": {"mu_c": 0.1, "mu_s": 0.1, "v_s": 0.1, "gamma": 1.0}},
     "sticking rule"),
    ({"asymmetric_cart": {"d_mu": 0.1}}, "needs one of"),
    ({"bogus_effect": {}}, "unknown effect 'bogus_effect'"),
    ({"viscous_cart": {"b_y": 1.0}}, "has no parameter 'b_y'"),
    ({"viscous_cart": {}}, "lacks parameter 'b_x'"),
    ({"viscous_cart": {"b_x": -1.0}}, "outside its physical range"),
    ({"viscous_cart": {"b_x": "a"}}, "must be a number"),
    ({"viscous_cart": {"b_x": float("nan")}}, "must be finite"),
])
def test_invalid_effect_sets(effects, message):
    with pytest.raises(PendcError, match=message):
        model(**effects)


def test_with_effect_uses_defaults_and_with_params_changes_values():
    m = model().with_effect("cart_spring")
    assert m.effects["cart_spring"] == {"k_c": 100.0, "x_0": 0.0}
    m2 = m.with_params({"k_c": 5.0})
    assert m2.effects["cart_spring"]["k_c"] == 5.0 and m.effects["cart_spring"]["k_c"] == 100.0
    with pytest.raises(PendcError, match="unknown parameter"):
        m.with_params({"nope": 1.0})
    with pytest.raises(PendcError, match="already"):
        m.with_effect("cart_spring")


def test_new_parameter_values_keep_the_derived_equations():
    """The equations are symbolic in the parameters: a copy with other values shares the ones
    already derived (not derived again), equal to the copy's own derivation; its values differ."""
    m = model().with_effect("cart_spring")
    fresh = m.with_params({"k_c": 5.0})            # before m derived anything: derives its own
    eq = m.equations
    m2 = m.with_params({"k_c": 5.0})
    assert m2.equations is eq and fresh.equations is not eq
    assert fresh.equations == eq and m2.parameter_vector() == fresh.parameter_vector() != m.parameter_vector()
    assert m2.with_effect("viscous_pendulum").equations != eq       # another structure derives its own


def test_an_input_saturation_acts_where_a_state_equation_uses_the_input_itself():
    """A plant with no drive (a converter's switch in its state equation): the saturation of its
    input shapes the input where the equations read it (it was listed and silently ignored)."""
    from pendc.model.modelfile import parse_model

    text = TANK_FILE + """
[catalogue.pump_limit]
kind = "saturation"
on = "u"
low = "u_lo"
high = "u_hi"
params.u_lo = { unit = "m/s", meaning = "least inflow", default = 0.0, bounds = [0.0, 0.5] }
params.u_hi = { unit = "m/s", meaning = "most inflow", default = 0.6, bounds = [0.5, 1.0] }
[effects.pump_limit]
u_lo = 0.0
u_hi = 0.6
"""
    eq = parse_model(text, "tank.toml").equations
    u, h, lo, hi = sp.symbols("u h u_lo u_hi", real=True)
    assert eq.input == u
    d = eq.inline(eq.derivatives[0]).subs({s: 0 for s in eq.params if s.name in ("k", "L")})  # no outflow
    assert d.subs({h: 0, lo: 0.0, hi: 0.6, u: 0.9}) == pytest.approx(0.6)
    assert d.subs({h: 0, lo: 0.0, hi: 0.6, u: 0.3}) == pytest.approx(0.3)
