"""A controller for any plant: hold one measured position at a set point (PD on its encoder).

The builtin swing-up and balance controllers are the cart-pendulum's; this one only needs
the plant interface: the position it holds is an encoder-read state (default: the first),
its rate is the state the interface names as that position's derivative. The gains come
from the model itself, so they mean the same on any drive: at rest, the rate's derivative
responds to the input as ``b (u - u0) + a v`` (``u0`` the input that holds the plant still,
``b`` and ``a`` the mean slopes around it), and the PD places the held coordinate's poles at
a natural frequency ``omega`` with damping ``zeta``:

    u = u0 + (-omega^2 (p - target) - 2 zeta omega v - a v) / b

Other coordinates (a pendulum hanging from the held arm) are left to themselves.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ...errors import PendcError
from ...model.plant import PlantModel
from ...model.modes import without_delta
from .measurement import FilteredDifference, Measurement
from .linearize import U_SPAN, _solve_hold_input

HOLD_OMEGA = 8.0          # rad/s: natural frequency of the held coordinate
HOLD_ZETA = 0.8           # damping ratio
HOLD_VELOCITY_TAU = 0.02  # s: velocity filter of the encoder position (coarse encoders need more)


def rest_response(model: PlantModel, rate: str) -> tuple[float, float, float]:
    """``(u0, b, a)`` of the rate's derivative at rest (every state 0): the input that holds it
    still, its slope in the input and in the rate (mean of the two one-sided slopes)."""
    eq = model.equations
    names = [s.name for s in eq.states]
    values = dict(zip(eq.params, model.parameter_vector()))
    f = without_delta(eq.inline(eq.derivatives[names.index(rate)]).subs(values))
    args = list(eq.states) + [eq.input]
    f_num = sp.lambdify(args, f, modules=["numpy"])
    dfdv = sp.lambdify(args, without_delta(sp.diff(f, eq.states[names.index(rate)])), modules=["numpy"])

    def at(u: float, v: float = 0.0) -> list:
        s = [0.0] * len(names)
        s[names.index(rate)] = v
        return s + [u]

    u0 = _solve_hold_input(lambda u: float(f_num(*at(u))))
    b = float(f_num(*at(u0 + U_SPAN)) - f_num(*at(u0 - U_SPAN))) / (2 * U_SPAN)
    a = 0.5 * sum(float(dfdv(*at(u0, sg * 1e-6))) for sg in (1.0, -1.0))
    if not (np.isfinite(b) and b != 0.0 and np.isfinite(a)):
        raise PendcError(f"the input does not move '{rate}' at rest in this model: nothing to hold")
    return u0, b, a


class PositionHold:
    """PD hold of one encoder-read position of any plant (see the module docstring).

    ``state``: the position to hold (default: the first one an encoder reads); ``target``: its
    set point (a number, or a function of time); ``omega``, ``zeta``: the closed loop's poles.
    ``input_range`` (the loop's DAC span) is the input's full scale either way, or ``input_range``
    if given."""

    mode = "hold"

    def __init__(self, model: PlantModel, period: float = 1e-3, state: str | None = None, target=0.0,
                 omega: float = HOLD_OMEGA, zeta: float = HOLD_ZETA, tau: float = HOLD_VELOCITY_TAU,
                 input_range: tuple | None = None):
        iface = model.interface
        scale = iface.input.full_scale
        self.input_range = tuple(input_range) if input_range is not None else (-scale, scale)
        read = [s.state for s in iface.sensors]
        if not read:
            raise PendcError(f"plant '{iface.name}' has no encoder: no position to hold")
        self.state = read[0] if state is None else state
        if self.state not in read:
            raise PendcError(f"no encoder reads '{self.state}' (measured: {', '.join(read)})")
        rate = next((s.name for s in iface.states if s.derivative_of == self.state), None)
        if rate is None:
            raise PendcError(f"--controller hold holds a measured position through its rate (a PD on its "
                             f"acceleration); plant '{iface.name}' measures '{self.state}', which is no state's "
                             f"rate_of (a first-order plant: use --controller lqr at an operating point)")
        self.u0, self.b, self.a = rest_response(model, rate)
        self.omega, self.zeta = float(omega), float(zeta)
        self.target = target if callable(target) else (lambda t, v=float(target): v)
        self.velocity = FilteredDifference(period, tau)

    def reset(self) -> None:
        """Forget the velocity history."""
        self.velocity.reset()

    def step(self, meas: Measurement) -> float:
        """One control period: volts from the held position and its filtered rate."""
        p = meas.position(self.state)
        v = self.velocity.update(p)
        accel = -self.omega ** 2 * (p - self.target(meas.t)) - 2 * self.zeta * self.omega * v
        return self.u0 + (accel - self.a * v) / self.b
