"""The derived equations of motion equal the thesis' II.35/II.36 and II.46."""

import sympy as sp

from plants import derive_rigid_body


def _thesis_symbols(rb):
    c = rb.constants
    x, dx, theta, dtheta = rb.state
    return c["g"], c["M"], c["m"], c["L"], c["I"], x, dx, theta, dtheta


def test_lagrangian_is_II29():
    rb = derive_rigid_body()
    g, M, m, L, I, x, dx, theta, dtheta = _thesis_symbols(rb)
    II29 = (M * dx**2 / 2 + m * (dx**2 - 2 * dx * L * dtheta * sp.cos(theta) + L**2 * dtheta**2) / 2
            + I * dtheta**2 / 2 + m * g * L * sp.cos(theta))
    assert sp.simplify(rb.lagrangian - II29) == 0


def test_euler_lagrange_equals_II35_II36():
    rb = derive_rigid_body()
    g, M, m, L, I, x, dx, theta, dtheta = _thesis_symbols(rb)
    ddx, ddtheta = sp.symbols("ddx ddtheta", real=True)
    Xi_x, Xi_theta = rb.forces
    # II.35 and II.36 with the generalized forces on the right (viscous terms are part of Xi here)
    II35 = (M + m) * ddx - m * L * ddtheta * sp.cos(theta) + m * L * dtheta**2 * sp.sin(theta) - Xi_x
    II36 = (m * L**2 + I) * ddtheta - m * L * ddx * sp.cos(theta) + m * g * L * sp.sin(theta) - Xi_theta
    assert sp.simplify(rb.euler_lagrange[0] - II35) == 0
    assert sp.simplify(rb.euler_lagrange[1] - II36) == 0


def test_solution_satisfies_the_equations():
    rb = derive_rigid_body()
    ddx, ddtheta = sp.symbols("ddx ddtheta", real=True)
    sol = {ddx: rb.num_x / rb.k, ddtheta: rb.num_theta / rb.k}
    for eq in rb.euler_lagrange:
        assert sp.simplify(eq.subs(sol)) == 0


def test_determinant_is_II46_and_depends_on_theta_only():
    rb = derive_rigid_body()
    g, M, m, L, I, x, dx, theta, dtheta = _thesis_symbols(rb)
    II46 = (m * L**2 + I) * (M + m) - m**2 * L**2 * sp.cos(theta) ** 2
    assert sp.simplify(rb.k - II46) == 0
    state_vars = rb.k.free_symbols & {x, dx, theta, dtheta, *rb.forces}
    assert state_vars == {theta}


def test_solved_form_matches_II47():
    """II.47: theta'' written out by the thesis, with f_tot = Xi_x + b_x dx and b_theta as Xi_theta."""
    rb = derive_rigid_body()
    g, M, m, L, I, x, dx, theta, dtheta = _thesis_symbols(rb)
    b_x, b_theta, f_tot = sp.symbols("b_x b_theta f_tot", real=True)
    k = rb.k
    II47 = (-m**2 * L**2 * sp.cos(theta) * sp.sin(theta) / k * dtheta**2
            - m * L * sp.cos(theta) * b_x / k * dx + m * L * sp.cos(theta) / k * f_tot
            - (M + m) * m * g * L * sp.sin(theta) / k - (M + m) * b_theta / k * dtheta)
    ours = (rb.num_theta / k).subs({rb.forces[0]: f_tot - b_x * dx, rb.forces[1]: -b_theta * dtheta})
    assert sp.simplify(ours - II47) == 0
