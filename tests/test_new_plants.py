"""The two plants added as files only (issue 21): the Quanser IP02 + DBPEN-LIN double inverted
pendulum on a cart (mechanical form, three encoders) and the Quanser SRV02 + Rotary Flexible
Joint two-mass drive (state equations). Each is checked against what its sources say and run
through a short build: 10 us steps and a small fraction of the training stimuli (cached on
disk like every build), so the float model and the bit-exact golden model are compared within
the error budget, and the double pendulum's upright is balanced by an LQR designed at the
file's operating point, on the golden model. The cocotb runs are not here (make sim)."""

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import sympy as sp

import pendc
from pendc.caching.build_cache import compile_cached
from pendc.golden import GoldenModel
from pendc.ir.nodes import Kind
from pendc.hil.controllers.measurement import FilteredDifference
from pendc.hil.loop import run_closed_loop
from pendc.hil.controllers.numeric_model import NumericModel
from pendc.hil.plants.plant import make_plant
from pendc.hil.controllers.position_hold import PositionHold
from pendc.model.expressions import parse_expression
from pendc.passes.pipeline import BuildOptions

from cli_capture import run_cli

MODELS = Path(__file__).resolve().parents[1] / "models"
DBPEN = MODELS / "double_pendulum_cart.toml"
TWO_MASS = MODELS / "two_mass_drive.toml"
DT = 1e-5
SHORT = BuildOptions(dt=DT, training_scale=0.02, check_seconds=0.05)


@pytest.fixture(scope="module")
def dbpen():
    return pendc.load_model(DBPEN)


@pytest.fixture(scope="module")
def two_mass():
    return pendc.load_model(TWO_MASS)


# -- the double pendulum on a cart -------------------------------------------------------------

def test_dbpen_plant_check_names_its_states_and_three_encoders(capsys):
    rc, out, err = run_cli(capsys, "plant", "check", DBPEN)
    assert rc == 0, err
    assert "mechanical form" in out and "core dbpen_core" in out
    for line in ("x [m] cart position", "alpha [rad] bottom link angle from hanging down",
                 "beta [rad] top link angle relative to the bottom link", "u [V] motor voltage",
                 "enc_x: x, 1024 lines", "enc_alpha: alpha, 1024 lines", "enc_beta: beta, 1024 lines"):
        assert line in out, line
    # both angles periodic (read off the geometry), the cart not
    assert out.count("period 6.28319") == 2
    # a sine of the links' absolute angle is written in the coordinates' own: every factor a
    # function of one coordinate, which is what the hardware tabulates
    assert "alpha + beta" not in out


def test_dbpen_sources_numbers(dbpen):
    """The values the file cites (Quanser config_ip02.m, config_sp.m, setup_ip02_dbpen.m)."""
    p = dict(zip([s.name for s in dbpen.equations.params], dbpen.parameter_vector()))
    inch, oz = 0.0254, 0.2780139
    assert p["M_c"] == 0.57 and p["M_h"] == 0.170 and p["m_1"] == 0.097 and p["m_2"] == 0.127
    assert p["L_1"] == pytest.approx((7 + 7 / 8) * inch) and p["l_2"] == pytest.approx((6 + 1 / 8) * inch)
    assert p["J_1"] == pytest.approx(0.097 * p["L_1"] ** 2 / 12, rel=1e-4)
    assert p["J_2"] == pytest.approx(0.127 * (13.25 * inch) ** 2 / 12, rel=1e-4)
    assert p["k_t"] == pytest.approx(1.088 * oz * inch, rel=1e-4)
    assert p["k_m"] == pytest.approx(0.804e-3 * 60 / (2 * math.pi), rel=1e-4)
    assert p["J_m"] == pytest.approx(5.523e-5 * oz * inch, rel=1e-4)
    # Quanser's lumped cart mass, Mc + eta_g Kg^2 Jm / r_mp^2 = 0.7031 kg, is the cart's inertia here
    lumped = p["M_c"] + p["eta_g"] * p["K_g"] ** 2 * p["J_m"] / p["r_mp"] ** 2
    assert lumped == pytest.approx(0.7031, abs=1e-4)
    # the cart encoder: 22.7485 um per count (config_ip02.m)
    assert dbpen.interface.sensor_of("x").resolution == pytest.approx(22.7485e-6, rel=1e-5)
    assert dbpen.interface.sensor_of("beta").resolution == pytest.approx(2 * math.pi / 4096)


def _energy(model, state):
    """T + V of the mechanism from the file's own geometry (an independent evaluation: the
    bodies' velocities by finite differences of their positions along the motion)."""
    p = dict(zip([s.name for s in model.equations.params], model.parameter_vector()))
    x, dx, a, da, b, db = state
    l1, L1, l2 = p["l_1"], p["L_1"], p["l_2"]

    def pos(x, a, b):
        return (np.array([x + l1 * math.sin(a), -l1 * math.cos(a)]),
                np.array([x + L1 * math.sin(a), -L1 * math.cos(a)]),
                np.array([x + L1 * math.sin(a) + l2 * math.sin(a + b), -L1 * math.cos(a) - l2 * math.cos(a + b)]))

    h = 1e-7
    now, later = pos(x, a, b), pos(x + h * dx, a + h * da, b + h * db)
    v = [(q1 - q0) / h for q0, q1 in zip(now, later)]
    masses = (p["m_1"], p["M_h"], p["m_2"])
    T = 0.5 * (p["M_c"] + p["J_m"] * p["K_g"] ** 2 / p["r_mp"] ** 2) * dx ** 2
    T += sum(0.5 * m * float(vi @ vi) for m, vi in zip(masses, v))
    T += 0.5 * p["J_1"] * da ** 2 + 0.5 * p["J_2"] * (da + db) ** 2
    V = p["g"] * sum(m * q[1] for m, q in zip(masses, now))
    return T + V


def test_dbpen_equations_conserve_energy_without_damping_or_drive(dbpen):
    """With the viscous effects and the motor (its back-EMF brakes the cart) gone, the derived
    equations conserve the energy of the file's geometry through a chaotic tumble (RK4)."""
    free = dbpen
    for name in ("motor_drive", "viscous_cart", "viscous_lower", "viscous_upper"):
        free = free.without_effect(name)
    _, f = _rhs(free)
    s0 = np.array([0.0, 0.0, 2.5, 0.0, 1.0, 0.0])      # both links high up, released
    end, h = s0.copy(), 2e-4
    for _ in range(1500):                               # 0.3 s, RK4
        k1 = f(end, 0.0)
        k2 = f(end + 0.5 * h * k1, 0.0)
        k3 = f(end + 0.5 * h * k2, 0.0)
        k4 = f(end + h * k3, 0.0)
        end = end + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert abs(end[4] - 1.0) > 0.2 or abs(end[2] - 2.5) > 0.2          # it moved a lot
    e0 = _energy(free, s0)
    assert abs(_energy(free, end) - e0) < 1e-6 * max(1.0, abs(e0))


_RHS = {}


def _rhs(model):
    """(state names, f(state, u) -> derivatives) of ``model``, lambdified once per model; the
    Jacobians below are central differences (differentiating the double pendulum symbolically
    takes longer than this whole file may)."""
    if id(model) not in _RHS:
        eq = model.equations
        values = dict(zip(eq.params, model.parameter_vector()))
        f = sp.lambdify(list(eq.states) + [eq.input], [eq.inline(d).subs(values) for d in eq.derivatives],
                        modules=["numpy"])
        _RHS[id(model)] = (model, tuple(s.name for s in eq.states), lambda s, u: np.array(f(*s, u), dtype=float))
    return _RHS[id(model)][1:]


def _jacobian(model, s, u=0.0, h=1e-6):
    names, f = _rhs(model)
    cols = []
    for i in range(len(names) + 1):
        e = np.zeros(len(names) + 1)
        e[i] = h
        cols.append((f(s + e[:-1], u + e[-1]) - f(s - e[:-1], u - e[-1])) / (2 * h))
    return np.array(cols).T


def _upright_linearisation(model, point="upright"):
    """The rest state at the file's operating point and A, B there (states in the file's order)."""
    names, f = _rhs(model)
    s = np.zeros(len(names))
    for name, value in model.definition.operating_points[point]:
        s[names.index(name)] = float(parse_expression(value, {}, f"operating_points.{point}.{name}"))
    assert np.allclose(f(s, 0.0), 0.0, atol=1e-9)                       # an equilibrium
    J = _jacobian(model, s)
    return s, J[:, :len(names)], J[:, len(names):]


def test_dbpen_upright_is_an_unstable_equilibrium_and_hanging_a_stable_one(dbpen):
    _, A, _ = _upright_linearisation(dbpen, "upright")
    assert sum(ev.real > 1e-6 for ev in np.linalg.eigvals(A)) == 2          # two links falling
    _, A, B = _upright_linearisation(dbpen, "hanging")
    assert np.all(np.linalg.eigvals(A).real <= 1e-9)
    # Quanser's force law at rest: F/u = eta_g Kg kt eta_m / (Rm r_mp) = 1.726 N/V on the lumped cart
    names, _ = _rhs(dbpen)
    assert B[names.index("dx"), 0] * 0.7031 == pytest.approx(1.726, rel=0.05)


@pytest.fixture(scope="module")
def dbpen_build(dbpen):
    return compile_cached(dbpen, SHORT)


def test_dbpen_build_tabulates_one_reciprocal_of_the_determinant(dbpen_build):
    g = dbpen_build.graph
    assert g.name == "dbpen_core"
    assert [p for p, _ in g.outputs][:6] == ["x", "dx", "alpha", "dalpha", "beta", "dbeta"]
    # before Q-formats narrow the addresses: tables of the two angles in turns and of the
    # determinant (its reciprocal, times each force's coefficient), no divider
    assert {n.inputs[0] for n in dbpen_build.untyped.of_kind(Kind.LUT)} == {"alpha_turns", "beta_turns", "det_dbpen"}
    inverse = [n for n in g.of_kind(Kind.LUT) if not n.param("periodic")]
    assert inverse and all(n.inputs[0].startswith("det_dbpen") and n.param("lo") > 0 for n in inverse)


def test_dbpen_float_and_fixed_agree_within_the_budget(dbpen, dbpen_build):
    t = np.arange(0, 0.05 + 1e-12, 1e-3)
    u = np.where((np.arange(len(t)) // 10) % 2 == 0, 6.0, -6.0)
    fixed = GoldenModel(dbpen_build.graph, DT)(t, u).result
    ref = pendc.Simulator(dbpen, dt=DT)(t, u)
    budgets = dbpen.interface.budgets()
    for q in ("x", "alpha", "beta"):
        assert np.max(np.abs(fixed[q] - ref[q])) < budgets[q], q
    assert np.ptp(fixed["x"]) > 1e-3 and np.ptp(fixed["alpha"]) > 1e-3


class UprightLqr:
    """Discrete LQR at the file's 'upright' operating point, on the encoders' positions (offset
    by where the run started) and their filtered differences."""

    mode = "lqr"
    input_range = (-10.0, 10.0)

    def __init__(self, model, period, start):
        s0, A, B = _upright_linearisation(model)
        n = A.shape[0]
        big = np.zeros((n + 1, n + 1))
        big[:n, :n], big[:n, n:] = A * period, B * period
        e = scipy.linalg.expm(big)
        Ad, Bd = e[:n, :n], e[:n, n:]
        Q, R = np.diag([10.0, 0.1, 50.0, 0.1, 50.0, 0.1]), np.array([[0.01]])   # setup_ip02_dbpen.m's weights
        P = scipy.linalg.solve_discrete_are(Ad, Bd, Q, R)
        self.K = np.linalg.solve(R + Bd.T @ P @ Bd, Bd.T @ P @ Ad).ravel()
        self.names, _ = _rhs(model)
        self.s0, self.start = s0, dict(start)
        self.rates = {q: FilteredDifference(period, 0.005) for q in ("x", "alpha", "beta")}

    def reset(self):
        for f in self.rates.values():
            f.reset()

    def step(self, meas):
        s = np.zeros(len(self.names))
        for q in ("x", "alpha", "beta"):
            p = self.start[q] + meas.position(q)
            s[self.names.index(q)] = p
            s[self.names.index("d" + q)] = self.rates[q].update(p)
        return float(-self.K @ (s - self.s0))


def test_dbpen_lqr_balances_the_upright_on_the_golden_model(dbpen, dbpen_build):
    """Quanser's simulation start (both links 0.5 degree off the upright): the LQR at the file's
    operating point holds both links up on the bit-exact model (without control they fall: the
    upright's two unstable modes, test above)."""
    start = {"x": 0.0, "alpha": math.pi + math.radians(0.5), "beta": 0.0}
    initial = [start.get(n, 0.0) for n in ("x", "dx", "alpha", "dalpha", "beta", "dbeta")]
    plant = make_plant("golden", dbpen, dt=DT, build=dbpen_build, initial=initial, on_overflow="mark")
    run = run_closed_loop(plant, UprightLqr(dbpen, 1e-3, start), seconds=1.5, period=1e-3)
    assert run.stopped is None
    alpha = start["alpha"] + run.column("alpha")
    beta = run.column("beta")
    assert np.max(np.abs(alpha[-500:] - math.pi)) < math.radians(2) and np.max(np.abs(beta[-500:])) < math.radians(2)


# -- the two-mass drive ------------------------------------------------------------------------

def test_two_mass_plant_check(capsys):
    rc, out, err = run_cli(capsys, "plant", "check", TWO_MASS)
    assert rc == 0, err
    assert "state form" in out and "core two_mass_core" in out
    for line in ("theta [rad] servo output shaft angle", "alpha [rad] arm deflection from the hub",
                 "enc_theta: theta, 1024 lines", "enc_alpha: alpha, 1024 lines",
                 "tau_motor = K_g*eta_g*eta_m*k_t*(-K_g*dtheta*k_m + u)/R_m"):
        assert line in out, line


def test_two_mass_is_quansers_state_space_model(two_mass):
    """The file's equations at rest are setup_flexjoint_exp.m's A and B, entry by entry, with
    Quanser's stiffness and inertias computed by config_rotflex.m's and config_srv02.m's formulas."""
    inch, oz = 0.0254, 0.2780139
    L, Fr, K, d, R, r = 1.25 * inch, 1.33, 0.368e3 * 0.85, 1.0 * inch, 3.5 * inch, 1.25 * inch
    D = r ** 2 + (R - d) ** 2
    Ks = 2 * R / D ** 1.5 * (D * d - R * r ** 2) * Fr + 2 * R / D ** 1.5 * (D ** 1.5 * d - D * L * d + R * r ** 2 * L) * K
    Jl = 0.064 * (11.75 * inch) ** 2 / 3 + 0.03 * (6 * inch) ** 2 / 12 + 0.03 * (10 * inch) ** 2
    Jm = (5.523e-5 + 1e-5) * oz * inch
    gears = 0.005 * (0.25 * inch) ** 2 / 2 + 2 * 0.030 * (0.75 * inch) ** 2 / 2 + 0.083 * (1.25 * inch) ** 2 / 2
    Jeq = 70 ** 2 * Jm * 0.9 + gears + 0.0005
    kt, km, Rm, Kg, Beq = 1.088 * oz * inch, 0.804e-3 * 60 / (2 * math.pi), 2.6, 70, 0.015
    beta_m = 0.69 * 0.9 * kt * Kg / Rm
    A_q = np.array([[0, 0, 1, 0], [0, 0, 0, 1],
                    [0, Ks / Jeq, -(Beq + beta_m * km * Kg) / Jeq, 0],
                    [0, -Ks * (Jeq + Jl) / (Jeq * Jl), (Beq + beta_m * km * Kg) / Jeq, 0]])
    B_q = beta_m / Jeq * np.array([0, 0, 1, -1])
    num = NumericModel.of(two_mass)
    J = num.jacobian(np.zeros(4), 0.0)
    order = [num.index(n) for n in ("theta", "alpha", "dtheta", "dalpha")]   # Quanser's state order
    A = J[np.ix_(order, order)]
    B = J[order, 4]
    assert np.allclose(A, A_q, rtol=2e-4, atol=1e-9)
    assert np.allclose(B, B_q, rtol=2e-4)


def test_two_mass_load_friction_acts_in_the_joint(two_mass):
    """A catalogue effect on the load (the arm's bearing) adds to the joint's torque: it brakes
    the deflection rate, and the reaction on the hub shows in the servo's acceleration."""
    base = NumericModel.of(two_mass)
    rubbing = NumericModel.of(two_mass.with_effect("viscous_load", {"B_l": 0.01}))
    s = np.array([0.0, 0.0, 0.0, 1.0])          # theta, dtheta, alpha, dalpha: the arm swinging
    d0, d1 = base.derivatives(s, 0.0), rubbing.derivatives(s, 0.0)
    p = dict(zip([q.name for q in two_mass.equations.params], two_mass.parameter_vector()))
    assert d1[3] - d0[3] == pytest.approx(-0.01 * (1 / p["J_l"] + 1 / p["J_eq"]))
    assert d1[1] - d0[1] == pytest.approx(0.01 / p["J_eq"])


@pytest.fixture(scope="module")
def two_mass_build(two_mass):
    return compile_cached(two_mass, SHORT)


def test_two_mass_float_and_fixed_agree_within_the_budget(two_mass, two_mass_build):
    t = np.arange(0, 0.3 + 1e-12, 1e-3)
    u = np.where((np.arange(len(t)) // 50) % 2 == 0, 10.0, -10.0)
    fixed = GoldenModel(two_mass_build.graph, DT)(t, u).result
    ref = pendc.Simulator(two_mass, dt=DT)(t, u)
    budgets = two_mass.interface.budgets()
    for q in ("theta", "alpha"):
        assert np.max(np.abs(fixed[q] - ref[q])) < budgets[q], q
    assert np.ptp(fixed["theta"]) > 0.1 and np.ptp(fixed["alpha"]) > 0.01     # both moved


def test_two_mass_position_hold_on_the_golden_model(two_mass, two_mass_build):
    """`pendc hil --controller hold`: the PD hold moves the servo to a set point on the bit-exact
    model and the arm follows on its springs."""
    plant = make_plant("golden", two_mass, dt=DT, build=two_mass_build)
    hold = PositionHold(two_mass, 1e-3, target=1.0)
    run = run_closed_loop(plant, hold, seconds=1.5, period=1e-3)
    assert run.stopped is None
    theta, alpha = run.column("theta"), run.column("alpha")
    assert abs(theta[-1] - 1.0) < 0.05 and np.max(np.abs(alpha)) > 0.01 and abs(alpha[-1]) < 0.05
