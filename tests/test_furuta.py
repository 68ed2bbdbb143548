"""The rotary (Furuta) pendulum: the derived equations against a published form, energy, the
plant interface, effects, experiments and model-file errors.

The independent source is Cazzolato & Prime (2011), "On the dynamics of the Furuta pendulum",
J. Control Science and Engineering, article 528341: their equations of motion for a slender,
symmetric pendulum (the simplified form of their eqs. 33-34), transcribed below in their
symbols (theta1 = arm, theta2 = pendulum from hanging down, L1 = arm length to the hinge,
l2 = hinge to the pendulum's centre of mass, J0h = arm inertia about the axis + m2 L1^2,
J2h = pendulum inertia about its hinge) and solved numerically, never through pendc's code.
"""

import math

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import pendc
from plants import derive_furuta
from pendc.model.plant import PlantModel

QUBE = "models/furuta_qube.toml"


@pytest.fixture(scope="module")
def qube():
    return pendc.load_model(QUBE)


def flow(model):
    """f(state, u) -> the state derivatives of ``model``'s equations, evaluated by sympy's
    lambdify with every named intermediate inlined (xreplace: exact and quick)."""
    eq = model.equations
    values = dict(zip(eq.params, (sp.Float(v) for v in model.parameter_vector())))
    derivs = []
    for d in eq.derivatives:
        for sym, value in reversed(eq.assignments):
            d = d.xreplace({sym: value})
        derivs.append(d.xreplace(values))
    return sp.lambdify((eq.states, eq.input), derivs, "math")


def cazzolato_prime(q, dq, tau, b, c):
    """Accelerations (theta1'', theta2'') of Cazzolato & Prime's slender-pendulum equations:

        (J0h + J2h sin^2 th2) th1'' + m2 L1 l2 cos th2 th2'' - m2 L1 l2 sin th2 th2'^2
            + J2h sin(2 th2) th1' th2' + b1 th1' = tau1
        m2 L1 l2 cos th2 th1'' + J2h th2'' - 1/2 J2h sin(2 th2) th1'^2 + b2 th2'
            + g m2 l2 sin th2 = tau2
    """
    th2 = q[1]
    m2, L1, l2, J0h, J2h, g = c["m2"], c["L1"], c["l2"], c["J0h"], c["J2h"], c["g"]
    M = np.array([[J0h + J2h * math.sin(th2) ** 2, m2 * L1 * l2 * math.cos(th2)],
                  [m2 * L1 * l2 * math.cos(th2), J2h]])
    rhs = np.array([
        tau[0] - b[0] * dq[0] + m2 * L1 * l2 * math.sin(th2) * dq[1] ** 2 - J2h * math.sin(2 * th2) * dq[0] * dq[1],
        tau[1] - b[1] * dq[1] + 0.5 * J2h * math.sin(2 * th2) * dq[0] ** 2 - g * m2 * l2 * math.sin(th2),
    ])
    return np.linalg.solve(M, rhs)


def paper_constants(plant: dict) -> dict:
    """The paper's constants from a Furuta model's (a uniform thin rod for the pendulum)."""
    m2, L_p = plant["m_p"], plant["L_p"]
    l2 = L_p / 2
    J2 = m2 * L_p ** 2 / 12                                # slender rod about its centre of mass
    return {"m2": m2, "L1": plant["L_r"], "l2": l2, "J0h": plant["J_r"] + m2 * plant["L_r"] ** 2,
            "J2h": J2 + m2 * l2 ** 2, "g": plant["g"]}


def test_solved_body_matches_cazzolato_prime_at_random_states():
    rb = derive_furuta()
    phi, dphi, alpha, dalpha = rb.state
    rng = np.random.default_rng(12)
    names = ("g", "J_r", "L_r", "m_p", "L_p")
    acc = sp.lambdify((phi, dphi, alpha, dalpha, *rb.forces, *(rb.constants[n] for n in names)),
                      [rb.numerators[0] / rb.det, rb.numerators[1] / rb.det], "math")
    for _ in range(40):
        plant = dict(zip(names, rng.uniform([9.0, 1e-5, 0.05, 0.01, 0.05], [10.0, 5e-4, 0.3, 0.2, 0.4])))
        q = rng.uniform(-math.pi, math.pi, 2)
        dq = rng.uniform(-20, 20, 2)
        tau = rng.uniform(-0.1, 0.1, 2)
        ours = acc(q[0], dq[0], q[1], dq[1], tau[0], tau[1], *plant.values())
        theirs = cazzolato_prime(q, dq, tau, (0.0, 0.0), paper_constants(plant))
        assert np.allclose(ours, theirs, rtol=1e-9, atol=1e-9), (plant, q, dq, tau)


def test_model_equations_with_motor_and_damping_match_the_paper(qube):
    """The shipped model's accelerations (motor with back-EMF, both viscous dampings) equal the
    paper's equations with tau1 = k_t (u - k_m dphi) / R_m, b1 = D_r, b2 = D_p."""
    acc = flow(qube)
    v = qube.parameter_values()
    c = paper_constants(qube.plant)
    rng = np.random.default_rng(3)
    for _ in range(30):
        q, dq, u = rng.uniform(-4, 4, 2), rng.uniform(-30, 30, 2), rng.uniform(-10, 10)
        d = acc((q[0], dq[0], q[1], dq[1]), u)
        tau1 = v["k_t"] * (u - v["k_m"] * dq[0]) / v["R_m"]
        theirs = cazzolato_prime(q, dq, (tau1, 0.0), (v["D_r"], v["D_p"]), c)
        assert d[0] == pytest.approx(dq[0]) and d[2] == pytest.approx(dq[1])
        assert np.allclose([d[1], d[3]], theirs, rtol=1e-9, atol=1e-9)


def test_determinant_depends_on_the_pendulum_angle_alone():
    rb = derive_furuta()
    phi, dphi, alpha, dalpha = rb.state
    assert rb.det.free_symbols & {phi, dphi, alpha, dalpha, *rb.forces} == {alpha}
    assert sp.simplify(rb.det - rb.mass_matrix.det()) == 0
    assert not rb.det.has(phi)                    # the arm angle is cyclic: absent from the energies
    assert phi not in rb.lagrangian.free_symbols


def _undamped_rhs(model):
    f = flow(model)
    return lambda t, y: f(y, 0.0)


def test_energy_of_the_undamped_body_is_conserved(qube):
    """No effects at all: T + V is constant along a wild swing (scipy's DOP853, not pendc's
    integrator), to the integrator's tolerance."""
    bare = PlantModel(plant=qube.plant, effects={}, definition=qube.definition)
    rb = derive_furuta()
    constants = {rb.constants[k]: v for k, v in bare.plant.items()}
    energy = sp.lambdify([rb.state], (rb.kinetic + rb.potential).subs(constants), "math")
    y0 = [0.3, 12.0, 2.5, -9.0]
    sol = solve_ivp(_undamped_rhs(bare), (0.0, 2.0), y0, method="DOP853", rtol=1e-11, atol=1e-11,
                    dense_output=True)
    assert sol.success
    e = np.array([energy(y) for y in sol.sol(np.linspace(0, 2.0, 400)).T])
    scale = abs(float(rb.potential.subs(constants).subs(rb.state[2], 0)))   # m_p g L_p / 2
    assert np.max(np.abs(e - e[0])) < 1e-8 * scale
    assert np.ptp(sol.sol(np.linspace(0, 2.0, 400))[2]) > 1.0          # it did swing


def test_damping_and_the_motor_do_the_work_they_should(qube):
    """dE/dt along the flow equals the generalized torques' power: tau_arm dphi + tau_pivot dalpha."""
    rb = derive_furuta()
    eq = qube.equations
    values = dict(zip(eq.params, qube.parameter_vector()))
    constants = {rb.constants[k]: v for k, v in qube.plant.items()}
    E = (rb.kinetic + rb.potential).subs(constants)
    grad = sp.lambdify([rb.state], [E.diff(s) for s in rb.state], "math")
    f = flow(qube)
    power = sp.lambdify((eq.states, eq.input), [eq.inline(sp.Symbol(n, real=True)).subs(values)
                                                for n in ("tau_arm", "tau_pivot")], "math")
    rng = np.random.default_rng(5)
    for _ in range(20):
        y, u = rng.uniform(-5, 5, 4), rng.uniform(-10, 10)
        dEdt = float(np.dot(grad(y), f(y, u)))
        tau = power(y, u)
        assert dEdt == pytest.approx(tau[0] * y[1] + tau[1] * y[3], rel=1e-9, abs=1e-12)


# -- the plant interface -----------------------------------------------------------------------

def test_interface_states_input_and_core(qube):
    iface = qube.interface
    assert [s.name for s in iface.states] == ["phi_r", "dphi_r", "alpha_p", "dalpha_p"]
    assert [s.unit for s in iface.states] == ["rad", "rad/s", "rad", "rad/s"]
    assert iface.outputs == ("phi_r", "dphi_r", "alpha_p", "dalpha_p")
    assert iface.state("dphi_r").derivative_of == "phi_r" and iface.state("dalpha_p").derivative_of == "alpha_p"
    assert iface.state("phi_r").label == "arm angle" and iface.state("dalpha_p").label == "pendulum angular velocity"
    assert all(s.meaning.endswith(f"({s.unit})") for s in iface.states)
    assert (iface.input.name, iface.input.unit, iface.input.full_scale) == ("u", "V", 10.0)
    assert iface.core == "furuta_core" and iface.name == "furuta"
    assert all(s.velocity_bound is None for s in iface.states)          # nothing clamps a rate


def test_both_angles_are_rotations(qube):
    """The arm's angle never enters the Lagrangian, yet a turn of it brings every point of the
    mechanism back: it is periodic, as the pendulum's angle is (the rule of period_of)."""
    iface = qube.interface
    assert [s.name for s in iface.periodic] == ["phi_r", "alpha_p"]
    for s in iface.periodic:
        assert s.period == 2 * math.pi and s.capacity == pytest.approx(2 * math.pi * s.turns)
    assert dict(derive_furuta().periods) == {"phi_r": 2 * sp.pi, "alpha_p": 2 * sp.pi}


def test_encoders_are_the_qube_servo_2s(qube):
    """User manual: 512 lines per revolution, 2048 counts in quadrature, 0.00307 rad per count."""
    iface = qube.interface
    for state, body in (("phi_r", "arm"), ("alpha_p", "pendulum")):
        enc = iface.sensor_of(state)
        assert (enc.name, enc.body, enc.lines, enc.bands_per_rev) == (f"enc_{state}", body, 512, 1024)
        assert enc.counts_per_unit * 2 * math.pi == pytest.approx(2048, rel=1e-12)
        assert enc.resolution == pytest.approx(0.00307, rel=1e-3)
        assert iface.budgets()[state] == pytest.approx(enc.resolution / 2, rel=1e-12)
    assert set(iface.budgets()) == {"phi_r", "alpha_p"}
    regs = iface.register_names()
    assert regs["enc_phi_r"] == ("ENC_PHI_R_COUNT",) and regs["alpha_p"] == ("ALPHA_P_LO", "ALPHA_P_HI")


def test_no_name_is_shared_with_the_cart_pendulum(qube):
    """A grep tells the plants apart: no state, encoder or named quantity of the Furuta is one of
    the cart-pendulum's (both read from their plant files' declarations)."""
    from plants import DEFAULT

    cart = DEFAULT.definition
    cart_names = {c.name for c in cart.coordinates} | {f"d{c.name}" for c in cart.coordinates}
    cart_names |= {s.name for s in cart.sensors} | {name for name, *_ in cart.quantities}
    furuta = qube.interface
    ours = {s.name for s in furuta.states} | {e.name for e in furuta.sensors} | {q.name for q in furuta.quantities}
    assert not ours & cart_names and "theta" in cart_names and len(ours) == 4 + 2 + 6
    assert furuta.meaning("det_furuta").startswith("determinant")
