"""Linearisation of a model at the upright equilibrium, from its own sympy equations.

The balance controller is designed on this linear model, so it follows whatever the
model file says (parameters and effects) instead of gains typed in for one rig.

Non-smooth terms need a rule. Coulomb and Stribeck friction jump at ẋ = 0 and the
sticking branch would make the cart look immovable (ẍ = 0 for any small input), so
the Jacobian is the mean of the two one-sided Jacobians with the cart moving slowly
left and right (ẋ = ±``EPS_V``): the Coulomb jumps cancel, the slopes (viscous,
Stribeck) stay. Extra states such as a motor lag are removed by residualisation
(their fast dynamics taken at steady state), because a controller cannot measure them.
An input delay and the velocity bound are not part of the linear model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import sympy as sp

from ..errors import PendcError
from ..model.plant import PlantModel

EPS_V = 1e-6   # m/s: "moving slowly" for the one-sided Jacobians
U_SPAN = 0.5   # V: the input gain is the mean slope over u0 +- U_SPAN (a dead zone has zero slope at u0)


@dataclass(frozen=True)
class UprightLinearModel:
    """ds/dt = A (s - s_up) + B (u - u0) about the upright, s = (x, dx, phi, dphi)
    with phi = theta - pi (theta = pi upright, angles as in the plant spec)."""

    A: np.ndarray
    B: np.ndarray
    u0: float
    u_coulomb: float = 0.0   # volts that balance the cart's dry friction when it moves slowly


@dataclass(frozen=True)
class DiscreteLqr:
    """Gain of u - u0 = -K (s - s_ref) for the sampled system, with the sampled matrices."""

    K: np.ndarray
    Ad: np.ndarray
    Bd: np.ndarray
    u0: float
    period: float


def _no_delta(expr: sp.Expr) -> sp.Expr:
    # d sign(v)/dv is a DiracDelta, zero away from v = 0 where the Jacobian is evaluated
    return expr.replace(lambda e: isinstance(e, sp.DiracDelta), lambda e: sp.Integer(0))


def mechanical_order(model: PlantModel) -> list:
    """Indices into the model's states of (translation, its rate, angle, its rate), from the
    plant interface (:func:`pendc.hil.controllers.measured_positions` names the two positions),
    followed by every other state (a motor lag...)."""
    from .controllers import measured_positions

    iface = model.interface
    cart, angle = measured_positions(iface)
    names = [s.name for s in model.equations.states]

    def rate_of(position):
        rate = next((s.name for s in iface.states if s.derivative_of == position), None)
        if rate is None:
            raise PendcError(f"the plant interface names no rate of '{position}'")
        return rate
    main = [names.index(n) for n in (cart, rate_of(cart), angle, rate_of(angle))]
    return main + [i for i in range(len(names)) if i not in main]


def linearise_upright(model: PlantModel) -> UprightLinearModel:
    """The model's linearisation at rest with the translation at 0 and the angle at pi (upright),
    with the input that holds it there; states ordered (translation, rate, angle, rate)."""
    eq = model.equations
    order = mechanical_order(model)
    states = [list(eq.states)[i] for i in order]
    derivatives = [list(eq.derivatives)[i] for i in order]
    values = dict(zip(eq.params, model.parameter_vector()))
    rhs = [eq.inline(d).subs(values) for d in derivatives]
    u = eq.input
    variables = states + [u]
    jac = [[_no_delta(sp.diff(f, v)) for v in variables] for f in rhs]
    f_num = sp.lambdify(variables, rhs, modules=["numpy"])
    j_num = sp.lambdify(variables, jac, modules=["numpy"])

    # extra states (motor lag ...) take their steady value for the held input, found by iteration
    def point(u_val: float, sign: float) -> list:
        s = [0.0, sign * EPS_V, math.pi, 0.0] + [0.0] * (len(states) - 4)
        for _ in range(50):
            d = f_num(*s, u_val)
            if len(states) == 4:
                break
            jj = np.array(j_num(*s, u_val), dtype=float)
            extra = slice(4, len(states))
            step = np.linalg.solve(jj[extra, extra], -np.array(d[4:], dtype=float))
            s[4:] = list(np.array(s[4:]) + step)
        return s

    def cart_acceleration(u_val: float) -> float:
        return 0.5 * sum(float(f_num(*point(u_val, sg), u_val)[1]) for sg in (1.0, -1.0))

    u0 = _solve_hold_input(cart_acceleration)
    a_left, a_right = (float(f_num(*point(u0, sg), u0)[1]) for sg in (1.0, -1.0))
    jacobians = [np.array(j_num(*point(u0, sg), u0), dtype=float) for sg in (1.0, -1.0)]
    J = 0.5 * (jacobians[0] + jacobians[1])
    if not np.all(np.isfinite(J)):
        raise PendcError("the model's linearisation at the upright is not finite (a non-smooth term at rest?)")
    n = len(states)
    A = J[:, :n]
    B = np.zeros((n, 1))
    for sg in (1.0, -1.0):
        s0 = point(u0, sg)
        up, down = (np.array(f_num(*s0, u0 + d), dtype=float) for d in (U_SPAN, -U_SPAN))
        B[:, 0] += 0.5 * (up - down) / (2 * U_SPAN)
    if n > 4:   # residualise the unmeasured fast states
        A22_inv = np.linalg.inv(A[4:, 4:])
        B = B[:4] - A[:4, 4:] @ A22_inv @ B[4:]
        A = A[:4, :4] - A[:4, 4:] @ A22_inv @ A[4:, :4]
    # the dry friction's jump between moving left and right, in volts of drive
    u_coulomb = max(0.0, -(a_left - a_right) / (2 * B[1, 0])) if B[1, 0] != 0 else 0.0
    return UprightLinearModel(A=A, B=B.reshape(4, 1), u0=float(u0), u_coulomb=float(u_coulomb))


def _solve_hold_input(cart_acceleration, lo: float = -20.0, hi: float = 30.0) -> float:
    """The input at which the cart, at rest under the upright pendulum, does not accelerate:
    the middle of the inputs that give zero acceleration (one point for a linear drive, the
    centre of a dead zone otherwise), found by bisecting for both of its edges."""
    f_lo, f_hi = cart_acceleration(lo), cart_acceleration(hi)
    if f_lo * f_hi > 0 or f_lo == f_hi:
        raise PendcError("no input holds the cart at rest under the upright pendulum in this model")
    rising = f_hi > f_lo

    def edge(strict_side: bool) -> float:
        # last input below (strict_side False) / first input above (True) the zero band
        a, b = lo, hi
        for _ in range(200):
            mid = 0.5 * (a + b)
            f = cart_acceleration(mid)
            below = (f < 0) if rising else (f > 0)
            above = (f > 0) if rising else (f < 0)
            if (above if strict_side else not below):
                b = mid
            else:
                a = mid
            if b - a < 1e-12:
                break
        return 0.5 * (a + b)

    return 0.5 * (edge(False) + edge(True))


def design_lqr(lin: UprightLinearModel, period: float, q_diag, r: float) -> DiscreteLqr:
    """Discrete LQR for the zero-order-hold sampled linear model (exact discretisation)."""
    n = lin.A.shape[0]
    big = np.zeros((n + 1, n + 1))
    big[:n, :n] = lin.A * period
    big[:n, n:] = lin.B * period
    e = scipy.linalg.expm(big)
    Ad, Bd = e[:n, :n], e[:n, n:]
    Q = np.diag(np.asarray(q_diag, dtype=float))
    R = np.array([[float(r)]])
    try:
        P = scipy.linalg.solve_discrete_are(Ad, Bd, Q, R)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise PendcError(f"no LQR gain for this model at the upright: {exc}") from None
    K = np.linalg.solve(R + Bd.T @ P @ Bd, Bd.T @ P @ Ad)
    return DiscreteLqr(K=K.ravel(), Ad=Ad, Bd=Bd, u0=lin.u0, period=float(period))
