"""Reference controllers: energy swing-up, LQR balance and the supervisor that switches.

A controller is any object with ``reset()`` and ``step(measurement) -> volts``; it sees
only what the rig's controller sees, a :class:`Measurement` (time and the ×4 encoder
counts, also converted to positions). An optional ``mode`` attribute (a short word)
is logged per period. Velocities come from a filtered difference of the positions.

The controllers here are the cart-pendulum's (energy swing-up, LQR about the upright):
their physics is that plant's, but they name its states as its plant interface does
(:attr:`PendulumConstants.cart`, :attr:`PendulumConstants.angle`), never by literals.

Conventions (plant spec §1): x positive to the left, theta from hanging, clockwise
positive, upright at theta = ±pi; u > V_off pushes the cart to +x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.plant import PlantModel
from .linearize import DiscreteLqr, UprightLinearModel, design_lqr, linearise_upright

U_MIN, U_MAX = 0.0, 10.0       # V, the driver's input range
FRICTION_SMOOTHING = 0.05     # V, width of the smoothed sign in the friction compensation
VELOCITY_TAU = 0.004           # s, time constant of the velocity filter
# LQR weights: 1/(acceptable excursion)^2 for x, dx, phi, dphi and the input
LQR_Q = (1 / 0.01**2, 1 / 0.5**2, 1 / 0.02**2, 1 / 0.5**2)
LQR_R = 1 / 1.0**2
# supervisor: switch to balance within CATCH_ANGLE (rad) of the upright below CATCH_RATE (rad/s),
# back to swinging beyond DROP_ANGLE
CATCH_ANGLE, CATCH_RATE, DROP_ANGLE = 0.4, 5.0, 0.8


@dataclass(frozen=True)
class Measurement:
    """What a controller gets each period: time and each encoder's ×4 count since reset.

    ``counts`` are ``(encoder, count)`` pairs and ``encoders`` the encoders' descriptions
    (:class:`~pendc.hil.core_ports.EncoderPorts`: the state each reads, its resolution), both
    in the plant interface's order. :meth:`position` converts a count to its state's unit; an
    encoder's name reads as its count and a measured state's name as its position
    (``meas.<state>``), so a controller names the plant's states as its interface does."""

    t: float
    counts: tuple
    encoders: tuple = ()

    @classmethod
    def of(cls, t: float, state, ports) -> "Measurement":
        """The measurement of a plant state (:class:`~pendc.hil.plant.PlantState`) at time ``t``."""
        return cls(t=t, counts=tuple((e.name, int(state.count(e.name))) for e in ports.encoders),
                   encoders=ports.encoders)

    def count(self, encoder: str) -> int:
        """The ×4 count since reset of the encoder called ``encoder``."""
        return dict(self.counts)[encoder]

    def position(self, state: str) -> float:
        """The measured position of ``state``: its encoder's count times the encoder's resolution."""
        for e in self.encoders:
            if e.state == state:
                return self.count(e.name) * e.resolution
        raise KeyError(f"no encoder reads '{state}'")

    def __getattr__(self, name: str):
        # only reached when ordinary lookup fails: an encoder's count or a measured state's position
        for e in self.__dict__.get("encoders", ()):
            if e.name == name:
                return self.count(name)
            if e.state == name:
                return self.position(name)
        raise AttributeError(f"the measurement has no '{name}'")


def wrap_upright(theta: float) -> float:
    """Angle from the upright, in (-pi, pi]: 0 at theta = ±pi, ±3pi ..."""
    return math.pi - (math.pi - (theta - math.pi)) % (2 * math.pi)


class FilteredDifference:
    """Velocity of a quantised position: first difference through a first-order low-pass."""

    def __init__(self, period: float, tau: float = VELOCITY_TAU):
        self.period = period
        self.gain = period / (tau + period)
        self.reset()

    def reset(self) -> None:
        """Forget the history (the next sample gives velocity 0)."""
        self.last = None
        self.value = 0.0

    def update(self, position: float) -> float:
        """Feed one sample, return the filtered velocity."""
        if self.last is not None:
            self.value += self.gain * ((position - self.last) / self.period - self.value)
        self.last = position
        return self.value


@dataclass(frozen=True)
class PendulumConstants:
    """What the controllers need of the model: energy terms, the cart's linear response and the
    names of the two measured positions (from the plant interface)."""

    mgl: float        # m g L, the potential energy from hanging to the pivot height (J)
    inertia: float    # m L^2 + I about the pivot (kg m^2)
    lin: UprightLinearModel
    cart: str = ""    # the measured translation (the interface's encoder-read, non-periodic position)
    angle: str = ""   # the measured pendulum angle (its encoder-read periodic position)

    @classmethod
    def from_model(cls, model: PlantModel) -> "PendulumConstants":
        """Read the constants and linearise the model at the upright."""
        p = model.parameter_values()
        cart, angle = measured_positions(model.interface)
        return cls(mgl=p["m"] * p["g"] * p["L"], inertia=p["m"] * p["L"] ** 2 + p["I"],
                   lin=linearise_upright(model), cart=cart, angle=angle)


def measured_positions(iface) -> tuple[str, str]:
    """(translation, angle): the encoder-read non-periodic and periodic states of a cart-pendulum
    interface; a plant without exactly one of each is not one these controllers can drive."""
    from ..errors import PendcError
    read = [iface.state(s.state) for s in iface.sensors]
    linear = [s.name for s in read if not s.periodic]
    angles = [s.name for s in read if s.periodic]
    if len(linear) != 1 or len(angles) != 1:
        raise PendcError(f"the builtin controllers drive a cart-pendulum (one measured translation, one measured "
                         f"angle); plant '{iface.name}' measures {', '.join(s.name for s in read) or 'nothing'}")
    return linear[0], angles[0]


class _VelocityObserver:
    """Cart and pendulum rates from the encoder positions, as a real controller must get them."""

    def __init__(self, period: float):
        self.vx = FilteredDifference(period)
        self.vth = FilteredDifference(period)

    def reset(self) -> None:
        """Back to the initial state (velocity filters empty)."""
        self.vx.reset()
        self.vth.reset()

    def observe(self, meas: Measurement) -> tuple[float, float]:
        """Update the velocity filters; return (dx, dtheta)."""
        return self.vx.update(meas.position(self.c.cart)), self.vth.update(meas.position(self.c.angle))


class EnergySwingUp(_VelocityObserver):
    """Energy pumping (Åström–Furuta): a cart acceleration k (E_up - E) sign(dtheta cos theta),
    saturated, plus a spring and damper that keep the cart near the track centre. The
    acceleration is turned into volts by inverting the model's linear cart response
    (a = A[1,1] dx + B[1] (u - u0)), so the gains mean the same on any drive."""

    mode = "swing"

    def __init__(self, consts: PendulumConstants, period: float = 1e-3, gain: float = 100.0,
                 accel_max: float = 5.0, centre_k: float = 12.0, centre_d: float = 6.0):
        self.c = consts
        self.period = period
        self.gain, self.accel_max = gain, accel_max
        self.centre_k, self.centre_d = centre_k, centre_d
        super().__init__(period)

    def energy(self, theta: float, dtheta: float) -> float:
        """Pendulum energy, zero at the pivot height (upright at rest has E = m g L)."""
        return 0.5 * self.c.inertia * dtheta**2 - self.c.mgl * math.cos(theta)

    def command(self, meas: Measurement, dx: float, dtheta: float) -> float:
        """Volts for the filtered state (used by the supervisor too)."""
        theta, x = meas.position(self.c.angle), meas.position(self.c.cart)
        c = math.cos(theta)
        # at rest (dtheta = 0) push anyway: energy pumping needs a first swing to work on
        direction = -1.0 if dtheta * c < 0 else 1.0
        pump = self.gain * (self.c.mgl - self.energy(theta, dtheta)) * direction
        pump = max(-self.accel_max, min(self.accel_max, pump))
        accel = pump - self.centre_k * x - self.centre_d * dx
        a11, b1 = self.c.lin.A[1, 1], self.c.lin.B[1, 0]
        return self.c.lin.u0 + (accel - a11 * dx) / b1

    def step(self, meas: Measurement) -> float:
        """One control period."""
        dx, dtheta = self.observe(meas)
        return self.command(meas, dx, dtheta)


class LqrBalance(_VelocityObserver):
    """Discrete LQR about the upright on (x - x_ref, dx, phi, dphi), phi = theta - pi wrapped.
    The gain comes from the model's own linearisation (see :mod:`pendc.hil.linearize`).
    ``x_ref`` may be a float or a function of time (the 4 cm step scenario)."""

    mode = "balance"

    def __init__(self, consts: PendulumConstants, period: float = 1e-3, x_ref=0.0,
                 q_diag=LQR_Q, r: float = LQR_R):
        self.c = consts
        self.period = period
        self.lqr: DiscreteLqr = design_lqr(consts.lin, period, q_diag, r)
        self.x_ref = x_ref if callable(x_ref) else (lambda t, v=float(x_ref): v)
        super().__init__(period)

    def command(self, meas: Measurement, dx: float, dtheta: float) -> float:
        """Volts for the filtered state."""
        err = np.array([meas.position(self.c.cart) - self.x_ref(meas.t), dx,
                        wrap_upright(meas.position(self.c.angle)), dtheta])
        du = -float(self.lqr.K @ err)
        # dry friction compensation: add the volts that the friction eats in the commanded direction
        return self.lqr.u0 + du + self.c.lin.u_coulomb * math.tanh(du / FRICTION_SMOOTHING)

    def step(self, meas: Measurement) -> float:
        """One control period."""
        dx, dtheta = self.observe(meas)
        return self.command(meas, dx, dtheta)


class Supervisor:
    """Swing up, switch to the LQR when the pendulum is near the upright and slow enough,
    fall back to the swing-up when it leaves a wider window (hysteresis: no chattering).
    Both controllers see every sample, so their filters are warm at a switch."""

    def __init__(self, consts: PendulumConstants, period: float = 1e-3, x_ref=0.0,
                 catch_angle: float = CATCH_ANGLE, catch_rate: float = CATCH_RATE, drop_angle: float = DROP_ANGLE):
        self.swing = EnergySwingUp(consts, period)
        self.balance = LqrBalance(consts, period, x_ref=x_ref)
        self.catch_angle, self.catch_rate, self.drop_angle = catch_angle, catch_rate, drop_angle
        self.mode = "swing"

    def reset(self) -> None:
        """Back to swinging, filters empty."""
        self.swing.reset()
        self.balance.reset()
        self.mode = "swing"

    def step(self, meas: Measurement) -> float:
        """One control period: update the filters, pick the controller, command."""
        dx, dtheta = self.swing.observe(meas)
        self.balance.observe(meas)
        phi = wrap_upright(meas.position(self.swing.c.angle))
        if self.mode == "swing" and abs(phi) < self.catch_angle and abs(dtheta) < self.catch_rate:
            self.mode = "balance"
        elif self.mode == "balance" and abs(phi) > self.drop_angle:
            self.mode = "swing"
        active = self.balance if self.mode == "balance" else self.swing
        return active.command(meas, dx, dtheta)

