"""Equations of motion of a mechanism, derived from its Lagrangian.

Nothing of the result is typed in: a plant file gives the positions of its bodies (point
masses with an inertia turning with an angle, uniform rods between two points) or its
kinetic and potential energies directly; the energies follow, Euler-Lagrange gives one
equation per generalized coordinate with a symbolic generalized force ``Xi_<q>``, and
Cramer's rule solves the linear system in the accelerations. Every acceleration is a
numerator over the determinant of the mass matrix; that this determinant depends on a few
angles only is what lets the hardware multiply by a tabulated inverse instead of dividing.

Trigonometric polynomials are kept in one canonical form (expanded, sin(a)^2 written as
1 - cos(a)^2 for every coordinate): equal expressions are then equal symbolically, at a
fraction of ``simplify``'s cost, and the same geometry always derives the same equations.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import sympy as sp



@dataclass(frozen=True)
class Mechanism:
    """The solved dynamics in plain symbols: ``accelerations[i] = numerators[i] / det``;
    ``euler_lagrange[i]`` is the equation of coordinate ``i`` (left side minus ``forces[i]``,
    = 0) before solving; ``points`` the kinematic map the energies were built from."""

    coordinates: tuple
    rates: tuple
    accelerations: tuple
    forces: tuple
    kinetic: sp.Expr
    potential: sp.Expr
    euler_lagrange: tuple
    mass_matrix: sp.Matrix
    det: sp.Expr
    numerators: tuple
    points: sp.Matrix
    periods: tuple

    @property
    def lagrangian(self) -> sp.Expr:
        """T - V in plain symbols."""
        return self.kinetic - self.potential

    @property
    def state(self) -> tuple:
        """Each coordinate followed by its rate."""
        return tuple(v for pair in zip(self.coordinates, self.rates) for v in pair)


def canonical(expr, angles) -> sp.Expr:
    """``expr`` expanded with sin(a)^2 written as 1 - cos(a)^2 for each of ``angles``; a sine or
    cosine of a sum of angles (a link's absolute angle in a chain, ``q1 + q2``) is first
    written in the angles' own sines and cosines, so every factor is a function of one
    coordinate (what the hardware tabulates) and the identities between them cancel."""
    expr = sp.expand(expr)
    sums = {f: sp.expand_trig(f) for f in expr.atoms(sp.sin, sp.cos)
            if isinstance(f.args[0], sp.Add) and sum(f.args[0].has(a) for a in angles) > 1}
    if sums:
        expr = sp.expand(expr.xreplace(sums))
    for a in angles:
        expr = sp.expand(expr.subs(sp.sin(a) ** 2, 1 - sp.cos(a) ** 2))
    return expr


def period_of(geometry, q: sp.Symbol):
    """2*pi if ``q`` is an angle, else None.

    ``geometry`` is the mechanism's kinematic map (the coordinates of its points) or any
    expression of the coordinates. ``q`` is an angle when the map depends on it and one turn
    (q -> q + 2*pi) brings every point back: periodicity is a property of the geometry, read
    off, never declared. A cyclic coordinate (one the energies do not contain, like a cart's
    position or a rotary arm's angle) is why the test is on the points, not the energies."""
    entries = list(geometry) if isinstance(geometry, sp.MatrixBase) else [sp.sympify(geometry)]
    if not any(q in e.free_symbols for e in entries):
        return None
    turned = [sp.simplify(sp.expand_trig(e.subs(q, q + 2 * sp.pi) - e)) for e in entries]
    return 2 * sp.pi if all(d == 0 for d in turned) else None


def derive(coordinates, bodies, gravity, kinetic=None, potential=None) -> Mechanism:
    """Derive and solve the equations of motion.

    ``coordinates`` are plain symbols; ``bodies`` a tuple of ``(kind, mass, inertia,
    rotation, position, start, end)`` of sympy values in those symbols (see
    :class:`~pendc.model.definition.BodyDecl`); ``gravity`` the acceleration vector;
    ``kinetic``/``potential`` energies given directly (in the coordinates and their rates
    ``d<q>``) instead of bodies. Cached: the same mechanism derives once per process."""
    return _derive(tuple(coordinates), tuple(bodies), tuple(gravity), kinetic, potential)


@lru_cache(maxsize=32)
def _derive(qs, bodies, gravity, kinetic, potential) -> Mechanism:
    t = sp.Symbol("t")
    funcs = {q: sp.Function(q.name)(t) for q in qs}
    rates = tuple(sp.Symbol(f"d{q.name}", real=True) for q in qs)
    accels = tuple(sp.Symbol(f"dd{q.name}", real=True) for q in qs)
    in_time = {**funcs, **{d: funcs[q].diff(t) for q, d in zip(qs, rates)}}
    angles = tuple(funcs.values())
    T, V = sp.Integer(0), sp.Integer(0)
    g = sp.Matrix(gravity) if gravity else None
    points = []
    s = sp.Symbol("s", nonnegative=True)   # position along a rod, 0 at its start, 1 at its end
    for kind, mass, inertia, rotation, position, start, end in bodies:
        if kind == "point":
            if mass is not None:
                r = sp.Matrix(position).subs(funcs)
                v = r.diff(t)
                T += sp.Rational(1, 2) * mass * (v.T * v)[0]
                V += -mass * (g.T * r)[0]
            if inertia is not None:
                T += sp.Rational(1, 2) * inertia * sp.sympify(rotation).subs(funcs).diff(t) ** 2
            if position:
                points.extend(position)
        else:
            a, b = sp.Matrix(start).subs(funcs), sp.Matrix(end).subs(funcs)
            r = a + s * (b - a)
            v = r.diff(t)
            T += sp.integrate(sp.Rational(1, 2) * mass * canonical((v.T * v)[0], angles), (s, 0, 1))
            V += sp.integrate(-mass * (g.T * r)[0], (s, 0, 1))
            points.extend(start)
            points.extend(end)
    if kinetic is not None:
        T += sp.sympify(kinetic).subs(in_time)
        V += sp.sympify(potential).subs(in_time) if potential is not None else 0
    T, V = canonical(T, angles), sp.expand(V)
    lag = T - V
    forces = tuple(sp.Symbol(f"Xi_{q.name}", real=True) for q in qs)
    plain = {}
    for q, d, dd in zip(qs, rates, accels):
        plain[funcs[q].diff(t, 2)] = dd
    for q, d in zip(qs, rates):
        plain[funcs[q].diff(t)] = d
    plain.update({funcs[q]: q for q in qs})
    eqs = [canonical(sp.diff(lag.diff(funcs[q].diff(t)), t) - lag.diff(funcs[q]), angles) - F
           for q, F in zip(qs, forces)]
    eqs = [e.subs(plain) for e in eqs]
    A, b = sp.linear_eq_to_matrix(eqs, list(accels))
    det = sp.factor_terms(canonical(A.det(), qs))
    adj = A.adjugate()
    n = len(qs)
    num = tuple(sp.expand(sum(adj[i, j] * b[j] for j in range(n))) for i in range(n))
    points_m = sp.Matrix(points).subs(plain) if points else sp.Matrix([lag.subs(plain)])
    return Mechanism(
        coordinates=qs, rates=rates, accelerations=accels, forces=forces,
        kinetic=T.subs(plain), potential=V.subs(plain), euler_lagrange=tuple(eqs), mass_matrix=A, det=det,
        numerators=num, points=points_m, periods=tuple((q.name, period_of(points_m, q)) for q in qs))
