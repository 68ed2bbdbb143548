"""Equations of motion of the cart-pendulum, derived from the Lagrangian (spec §2, II.29).

Nothing of the result is typed in: the kinetic and potential energies are written
from the geometry of II.23 (the pendulum's centre of mass), Euler-Lagrange gives
the two equations of motion with generalized forces ``Xi_x`` (cart) and
``Xi_theta`` (pivot), and Cramer's rule solves the linear system in the
accelerations. The determinant of the mass matrix is k(theta) of II.46; that the
accelerations are ``numerator / k`` is what lets the hardware multiply by a
tabulated 1/k(theta) instead of dividing.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import sympy as sp


@dataclass(frozen=True)
class RigidBody:
    """The solved rigid-body dynamics in plain symbols.

    ``ddx = num_x / k`` and ``ddtheta = num_theta / k``; ``euler_lagrange`` holds the
    two equations (left side - generalized force, each = 0) before solving.
    """

    constants: dict          # name -> symbol, for g M m L I
    state: tuple             # x, dx, theta, dtheta
    forces: tuple            # Xi_x, Xi_theta
    lagrangian: sp.Expr
    euler_lagrange: tuple    # (expr_x, expr_theta), each "= 0"
    k: sp.Expr               # determinant of the mass matrix
    num_x: sp.Expr
    num_theta: sp.Expr
    periods: tuple = ()      # (coordinate name, period or None): read off the geometry (period_of)


# What each generalized coordinate and its rate are, in words and units (the plant interface's
# states read this): (coordinate, body, (quantity, unit, meaning) of the position, then of the rate)
COORDINATES = (
    ("x", "cart", ("position", "m", "cart position (m)"), ("velocity", "m/s", "cart velocity (m/s)")),
    ("theta", "pendulum", ("angle", "rad", "pendulum angle from hanging down (rad)"),
     ("angular velocity", "rad/s", "pendulum angular velocity (rad/s)")),
)


def period_of(geometry, q: sp.Symbol):
    """2*pi if ``q`` is an angle, else None.

    ``geometry`` is the mechanism's kinematic map (a matrix of the coordinates of its points,
    the positions its energies are built from) or any expression of the coordinates. ``q`` is
    an angle when the map depends on it and one turn of it (q -> q + 2*pi) brings every point
    back to where it was. Periodicity is a property of the geometry, so it is read off, never
    declared: the cart's x moves the cart (a translation, whatever the energies say: the track
    is the same everywhere), the pendulum's theta and the Furuta arm's phi_r are rotations. The
    arm's angle never appears in the Furuta's Lagrangian (a cyclic coordinate, like x), which is
    why the test is on the points, not on the energies. A map that does not contain ``q`` at
    all says nothing of it: None."""
    entries = list(geometry) if isinstance(geometry, sp.MatrixBase) else [sp.sympify(geometry)]
    if not any(q in e.free_symbols for e in entries):
        return None
    turned = [sp.simplify(sp.expand_trig(e.subs(q, q + 2 * sp.pi) - e)) for e in entries]
    return 2 * sp.pi if all(d == 0 for d in turned) else None


@lru_cache(maxsize=1)
def derive_rigid_body() -> RigidBody:
    """Derive and solve the cart-pendulum equations of motion (cached: the result is immutable)."""
    t = sp.Symbol("t")
    g, M, m, L, I = sp.symbols("g M m L I", positive=True)
    Xi_x, Xi_theta = sp.symbols("Xi_x Xi_theta", real=True)
    xf = sp.Function("x")(t)
    thf = sp.Function("theta")(t)

    # II.23: centre of mass of the pendulum; x positive left, theta clockwise from hanging down
    r_c = sp.Matrix([-(xf - L * sp.sin(thf)), -L * sp.cos(thf)])
    v_c = r_c.diff(t)
    T = sp.Rational(1, 2) * M * xf.diff(t) ** 2 + sp.Rational(1, 2) * m * (v_c.T * v_c)[0] \
        + sp.Rational(1, 2) * I * thf.diff(t) ** 2
    V = m * g * r_c[1]
    lag = sp.simplify(T - V)

    def euler_lagrange(q, force):
        return sp.diff(lag.diff(q.diff(t)), t) - lag.diff(q) - force

    eqs = [sp.expand(sp.simplify(euler_lagrange(xf, Xi_x))), sp.expand(sp.simplify(euler_lagrange(thf, Xi_theta)))]

    x, dx, theta, dtheta, ddx, ddtheta = sp.symbols("x dx theta dtheta ddx ddtheta", real=True)
    plain = {
        xf.diff(t, 2): ddx, thf.diff(t, 2): ddtheta,
        xf.diff(t): dx, thf.diff(t): dtheta,
        xf: x, thf: theta,
    }
    eqs = [e.subs(plain) for e in eqs]

    # The equations are linear in the accelerations: A [ddx, ddtheta]^T = b
    A, b = sp.linear_eq_to_matrix(eqs, [ddx, ddtheta])
    k = sp.factor_terms(sp.expand(A.det()))
    adj = A.adjugate()
    num = [sp.expand(sum(adj[i, j] * b[j] for j in range(2))) for i in range(2)]
    plain_lag = lag.subs(plain)
    points = sp.Matrix([-xf, 0, r_c[0], r_c[1]]).subs(plain)    # the cart, the pendulum's centre
    return RigidBody(
        constants={"g": g, "M": M, "m": m, "L": L, "I": I},
        state=(x, dx, theta, dtheta),
        forces=(Xi_x, Xi_theta),
        lagrangian=plain_lag,
        euler_lagrange=tuple(eqs),
        k=k,
        num_x=num[0],
        num_theta=num[1],
        periods=tuple((q.name, period_of(points, q)) for q in (x, theta)),
    )
