"""Linearisation of a pendulum model at rest, upright or hanging, from its own sympy equations.

The balance controller is designed on this linear model, so it follows whatever the
model file says (parameters and effects) instead of gains typed in for one rig. The states
are addressed by role (:mod:`pendc.hil.controllers.pendulum_roles`: the actuated coordinate, a cart or a
rotary arm, and the pendulum's angle), so one linearisation serves every such plant.

Non-smooth terms need a rule. Coulomb and Stribeck friction jump at zero velocity of the
actuated coordinate and the sticking branch would make it look immovable (no acceleration for
any small input), so the Jacobian is the mean of the two one-sided Jacobians with it moving
slowly either way (rate ±``EPS_V``): the Coulomb jumps cancel, the slopes (viscous,
Stribeck) stay. Extra states such as a motor lag are removed by residualisation
(their fast dynamics taken at steady state), because a controller cannot measure them.
An input delay and the velocity bound are not part of the linear model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ...errors import PendcError
from ...model.interface import with_unit
from ...model.plant import PlantModel
from .numeric_model import NumericModel
from .pendulum_roles import PendulumRoles, pendulum_roles, restoring_stiffness

EPS_V = 1e-6   # "moving slowly" for the one-sided Jacobians (the actuated rate's unit: m/s, rad/s)
U_SPAN = 0.5   # V: the input gain is the mean slope over u0 +- U_SPAN (a dead zone has zero slope at u0)


@dataclass(frozen=True)
class UprightLinearModel:
    """ds/dt = A (s - s_0) + B (u - u0) about a rest point, s = (p, v, phi, dphi): the actuated
    position and its rate, the pendulum angle from the point (phi = angle - upright for the
    upright) and its rate."""

    A: np.ndarray
    B: np.ndarray
    u0: float
    u_coulomb: float = 0.0   # volts that balance the actuated coordinate's dry friction when it moves slowly


@dataclass(frozen=True)
class DiscreteLqr:
    """Gain of u - u0 = -K (s - s_ref) for the sampled system, with the sampled matrices."""

    K: np.ndarray
    Ad: np.ndarray
    Bd: np.ndarray
    u0: float
    period: float


def mechanical_order(model: PlantModel) -> list:
    """Indices into the model's states of (actuated position, its rate, pendulum angle, its
    rate), by role (:func:`pendc.hil.controllers.pendulum_roles.pendulum_roles`), followed by every other
    state (a motor lag...)."""
    return pendulum_roles(model).order(len(model.equations.states))


def linearise_upright(model: PlantModel, numeric: NumericModel | None = None,
                      roles: PendulumRoles | None = None) -> UprightLinearModel:
    """The model's linearisation at rest with the actuated position at 0 and the pendulum
    upright, with the input that holds it there; states ordered (p, v, phi, dphi)."""
    numeric = numeric or NumericModel.of(model)
    roles = roles or pendulum_roles(model, numeric)
    return linearise_at_rest(numeric, roles, roles.upright)


def linearise_at_rest(numeric: NumericModel, roles: PendulumRoles, angle: float) -> UprightLinearModel:
    """The linearisation at rest with the actuated position at 0 and the pendulum at ``angle``
    (0 hanging, ``roles.upright`` upright), with the input that holds the actuated coordinate
    still; a one-line :class:`PendcError` if that is no equilibrium of the pendulum."""
    n = len(numeric.names)
    order = roles.order(n)
    act_rate, pend_rate = roles.actuated.rate_index, roles.pendulum.rate_index

    # extra states (motor lag ...) take their steady value for the held input, found by iteration
    def point(u_val: float, sign: float) -> np.ndarray:
        s = np.zeros(n)
        s[act_rate] = sign * EPS_V
        s[roles.pendulum.index] = angle
        extra = order[4:]
        for _ in range(50 if extra else 0):
            d = numeric.derivatives(s, u_val)
            jj = numeric.jacobian(s, u_val)
            step = np.linalg.solve(jj[np.ix_(extra, extra)], -d[extra])
            s[extra] += step
            if np.all(np.abs(step) <= 1e-13 * (1.0 + np.abs(s[extra]))):   # a linear lag: one step
                break
        return s

    def acceleration(u_val: float, sign: float, of: int = act_rate) -> float:
        return float(numeric.derivatives(point(u_val, sign), u_val)[of])

    def mean_acceleration(u_val: float) -> float:
        return 0.5 * sum(acceleration(u_val, sg) for sg in (1.0, -1.0))

    u0 = _solve_hold_input(mean_acceleration)
    a_left, a_right = (acceleration(u0, sg) for sg in (1.0, -1.0))
    tilt = 0.5 * sum(acceleration(u0, sg, pend_rate) for sg in (1.0, -1.0))
    if not abs(tilt) < 1e-6 * max(1.0, abs(restoring_stiffness(numeric, roles.pendulum))):
        raise PendcError(f"the pendulum of plant '{roles.plant}' is not at rest at "
                         f"{with_unit(f'{angle:g}', roles.pendulum.unit)} (angular acceleration {tilt:.3g})")
    J = 0.5 * sum(numeric.jacobian(point(u0, sg), u0) for sg in (1.0, -1.0))
    J = J[np.ix_(order, order + [n])]
    if not np.all(np.isfinite(J)):
        raise PendcError("the model's linearisation at rest is not finite (a non-smooth term at rest?)")
    A = J[:, :n]
    B = np.zeros((n, 1))
    for sg in (1.0, -1.0):
        s0 = point(u0, sg)
        up, down = (numeric.derivatives(s0, u0 + d)[order] for d in (U_SPAN, -U_SPAN))
        B[:, 0] += 0.5 * (up - down) / (2 * U_SPAN)
    if n > 4:   # residualise the unmeasured fast states
        A22_inv = np.linalg.inv(A[4:, 4:])
        B = B[:4] - A[:4, 4:] @ A22_inv @ B[4:]
        A = A[:4, :4] - A[:4, 4:] @ A22_inv @ A[4:, :4]
    # the dry friction's jump between moving either way, in volts of drive
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
