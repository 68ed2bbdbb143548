"""Equations of motion of the rotary (Furuta) pendulum, derived from its Lagrangian.

The second plant of pendc, derived by the same route as the cart-pendulum
(:mod:`pendc.model.lagrangian`): the geometry gives the positions of every point of the
mechanism, the energies follow from them, Euler-Lagrange gives the two equations with
generalized torques ``Xi_phi_r`` (arm) and ``Xi_alpha_p`` (pendulum pivot), and Cramer's rule
solves them for the accelerations. The determinant of the mass matrix depends on the
pendulum angle alone, so the hardware multiplies by a tabulated 1/det(alpha_p) as it does by
1/k(theta) for the cart.

Geometry (z up; the Quanser QUBE-Servo 2 as its workbook draws it):

* the **arm** turns about the vertical motor axis by ``phi_r`` (counter-clockwise seen from
  above); everything that turns with it (rod, hub, the pendulum's encoder housing) is one
  inertia ``J_r`` about that axis; the pendulum's hinge sits at ``L_r`` from the axis, its
  hinge axis along the arm;
* the **pendulum** is a uniform thin rod of mass ``m_p`` and length ``L_p`` swinging in the
  vertical plane across the arm's end; ``alpha_p`` is its angle from hanging down, positive
  when its tip moves the way the arm turns with positive ``phi_r``.

The pendulum's kinetic and potential energies are integrated along the rod (a line of mass
points), so its inertia about its hinge (m_p L_p^2 / 3) and about the vertical axis
(the sin^2 term Quanser's workbook leaves out, Cazzolato & Prime 2011) both come out of
the geometry rather than being typed in.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import sympy as sp

from .lagrangian import period_of

# What each generalized coordinate and its rate are, in words and units (the plant interface's
# states read this): (coordinate, body, (quantity, unit, meaning) of the position, then of the rate)
COORDINATES = (
    ("phi_r", "arm", ("angle", "rad", "rotary arm angle, counter-clockwise seen from above (rad)"),
     ("angular velocity", "rad/s", "rotary arm angular velocity (rad/s)")),
    ("alpha_p", "pendulum", ("angle", "rad", "pendulum angle from hanging down (rad)"),
     ("angular velocity", "rad/s", "pendulum angular velocity (rad/s)")),
)

# The rigid-body constants of a Furuta model file's [plant] table: unit and meaning
CONSTANTS = {
    "g": ("m/s^2", "gravitational acceleration"),
    "J_r": ("kg*m^2", "inertia of everything turning with the arm, about the motor axis"),
    "L_r": ("m", "motor axis to the pendulum's hinge"),
    "m_p": ("kg", "pendulum mass (uniform thin rod)"),
    "L_p": ("m", "pendulum length (hinge to tip)"),
}


@dataclass(frozen=True)
class FurutaBody:
    """The solved rigid-body dynamics of the Furuta pendulum in plain symbols.

    ``dd[i] = numerators[i] / det`` for the accelerations of ``state[1]`` and ``state[3]``;
    ``euler_lagrange`` holds the two equations (left side - generalized torque, each = 0)
    before solving; ``points`` is the kinematic map (hinge and a point at ``s`` along the
    pendulum) the energies were built from; ``periods`` is read off it.
    """

    constants: dict          # name -> symbol, for g J_r L_r m_p L_p
    state: tuple             # phi_r, dphi_r, alpha_p, dalpha_p
    accelerations: tuple     # ddphi_r, ddalpha_p (the symbols the equations are linear in)
    forces: tuple            # Xi_phi_r, Xi_alpha_p
    lagrangian: sp.Expr
    kinetic: sp.Expr
    potential: sp.Expr
    euler_lagrange: tuple
    mass_matrix: sp.Matrix
    det: sp.Expr
    numerators: tuple
    points: sp.Matrix
    periods: tuple = ()


def _pythagoras(expr, angles) -> sp.Expr:
    """``expr`` expanded with sin(a)^2 written as 1 - cos(a)^2 for each angle ``a``: a canonical
    form in which equal trigonometric polynomials are equal, at a fraction of simplify's cost."""
    expr = sp.expand(expr)
    for a in angles:
        expr = sp.expand(expr.subs(sp.sin(a) ** 2, 1 - sp.cos(a) ** 2))
    return expr


@lru_cache(maxsize=1)
def derive_furuta() -> FurutaBody:
    """Derive and solve the Furuta pendulum's equations of motion (cached: immutable result)."""
    t = sp.Symbol("t")
    s = sp.Symbol("s", nonnegative=True)          # distance along the pendulum from its hinge
    g, J_r, L_r, m_p, L_p = sp.symbols("g J_r L_r m_p L_p", positive=True)
    Xi_phi, Xi_alpha = sp.symbols("Xi_phi_r Xi_alpha_p", real=True)
    phf = sp.Function("phi_r")(t)
    alf = sp.Function("alpha_p")(t)

    radial = sp.Matrix([sp.cos(phf), sp.sin(phf), 0])        # along the arm
    tangent = sp.Matrix([-sp.sin(phf), sp.cos(phf), 0])      # the way the arm turns
    up = sp.Matrix([0, 0, 1])
    hinge = L_r * radial
    point = hinge + s * (sp.sin(alf) * tangent - sp.cos(alf) * up)
    velocity = point.diff(t)
    density = m_p / L_p
    angles = (phf, alf)
    T = sp.Rational(1, 2) * J_r * phf.diff(t) ** 2 \
        + sp.integrate(sp.Rational(1, 2) * density * _pythagoras((velocity.T * velocity)[0], angles), (s, 0, L_p))
    V = sp.integrate(density * g * point[2], (s, 0, L_p))
    T, V = _pythagoras(T, angles), sp.expand(V)
    lag = T - V

    def euler_lagrange(q, force):
        return _pythagoras(sp.diff(lag.diff(q.diff(t)), t) - lag.diff(q), angles) - force

    eqs = [euler_lagrange(phf, Xi_phi), euler_lagrange(alf, Xi_alpha)]
    phi, dphi, alpha, dalpha, ddphi, ddalpha = sp.symbols("phi_r dphi_r alpha_p dalpha_p ddphi_r ddalpha_p",
                                                           real=True)
    plain = {phf.diff(t, 2): ddphi, alf.diff(t, 2): ddalpha, phf.diff(t): dphi, alf.diff(t): dalpha,
             phf: phi, alf: alpha}
    eqs = [e.subs(plain) for e in eqs]

    # The equations are linear in the accelerations: A [ddphi, ddalpha]^T = b
    A, b = sp.linear_eq_to_matrix(eqs, [ddphi, ddalpha])
    det = sp.factor_terms(_pythagoras(A.det(), (alpha,)))
    adj = A.adjugate()
    num = tuple(sp.expand(sum(adj[i, j] * b[j] for j in range(2))) for i in range(2))
    points = sp.Matrix.vstack(hinge, point).subs(plain)
    return FurutaBody(
        constants={"g": g, "J_r": J_r, "L_r": L_r, "m_p": m_p, "L_p": L_p},
        state=(phi, dphi, alpha, dalpha),
        accelerations=(ddphi, ddalpha),
        forces=(Xi_phi, Xi_alpha),
        lagrangian=lag.subs(plain),
        kinetic=T.subs(plain),
        potential=V.subs(plain),
        euler_lagrange=tuple(eqs),
        mass_matrix=A,
        det=det,
        numerators=num,
        points=points,
        periods=tuple((q.name, period_of(points, q)) for q in (phi, alpha)),
    )
