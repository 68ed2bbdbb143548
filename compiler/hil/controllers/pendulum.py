"""Reference controllers of a pendulum plant: energy swing-up, LQR balance and the supervisor
that switches.

A controller is any object with ``reset()`` and ``step(measurement) -> volts``; it sees only
what the rig's controller sees, a :class:`~pendc.hil.controllers.measurement.Measurement`.
Velocities come from a filtered difference of the positions.

The controllers here drive any plant that is one pendulum on one driven coordinate (a
cart-pendulum, a Furuta pendulum's rotary arm): they address its states by role
(:mod:`pendc.hil.controllers.pendulum_roles`: the actuated coordinate, the pendulum angle, counted from
hanging down, upright half a turn away), and every gain in volts comes from the model's own
linearisation (:mod:`pendc.hil.controllers.linearize`). The swing-up is pendulum physics: the energy of
the pendulum swinging about its pivot with the actuated coordinate held, per unit of its
inertia, and the push on the pivot that changes it.

Conventions (which way is positive, which input pushes which way) are each plant file's;
nothing here depends on them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...model.plant import PlantModel
from .linearize import DiscreteLqr, UprightLinearModel, design_lqr, linearise_at_rest
from .measurement import FilteredDifference, Measurement, wrap_upright
from .numeric_model import NumericModel
from .pendulum_roles import PendulumRoles, pendulum_roles

FRICTION_SMOOTHING = 0.05     # V, width of the smoothed sign in the friction compensation
# LQR weights: 1/(acceptable excursion)^2 for the actuated position, its rate, the angle from
# the upright, its rate and the input (each in its state's unit, the input in volts)
LQR_Q = (1 / 0.01**2, 1 / 0.5**2, 1 / 0.02**2, 1 / 0.5**2)
LQR_R = 1 / 1.0**2
# an actuated coordinate that must move more than this many times as far as the pendulum it
# balances (1 / |coupling|: a reaction wheel's 188 rad per rad; a cart's 0.22 m, a Furuta arm's
# 1.01 rad) stores momentum rather than positions the pivot: its excursions are the lever times
# the weights' (a 0.01 rad weight on a wheel caught at 250 rad/s spent the whole input on an angle
# nothing depends on, and lost every catch)
MOMENTUM_LEVER = 10.0
# supervisor: switch to balance within CATCH_ANGLE (rad) of the upright below CATCH_RATE (rad/s),
# back to swinging beyond DROP_ANGLE
CATCH_ANGLE, CATCH_RATE, DROP_ANGLE = 0.4, 5.0, 0.8
# swing-up, in units of gravity's pull as the pendulum feels a push of its pivot (on a cart,
# g = 9.80665 m/s^2 of cart acceleration): the peak push, 5 m/s^2 on a cart, and the push per
# unit of missing energy (as a fraction of the upright's), 100 m/s^2 per J on a pendulum whose
# m L is 0.581 kg x 0.138867 m (the values the swing-up was first tuned with)
SWING_PIVOT_ACCEL = 5.0 / 9.80665
SWING_GAIN = 100 * 0.581 * 0.138867
# a momentum store pumps by its speed (see EnergySwingUp): at PACE_SPEED of its no-load speed,
# full while PACE_SHARE x the missing share of the energy reaches 1, through a speed servo of
# PACE_SERVO x the pendulum's natural frequency
PACE_SPEED, PACE_SHARE, PACE_SERVO = 0.9, 5.0, 10.0


@dataclass(frozen=True)
class PendulumConstants:
    """What the controllers need of the model: the coordinates by role, the linearisation at
    the upright, the pendulum's physics with the actuated coordinate held (``omega0_sq``, the
    square of its natural frequency, rad²/s²) and ``coupling``, the pendulum's angular
    acceleration per unit acceleration of the actuated coordinate when hanging (it goes with
    the cosine of the angle), the input's range (volts, low and high) and the model's own
    equations (``numeric``) for :meth:`input_for`."""

    roles: PendulumRoles
    lin: UprightLinearModel
    omega0_sq: float
    coupling: float
    input_range: tuple
    numeric: NumericModel | None = None

    @property
    def actuated(self) -> str:
        """The measured position the input drives (a cart's, an arm's)."""
        return self.roles.actuated.position

    @property
    def angle(self) -> str:
        """The measured pendulum angle."""
        return self.roles.pendulum.position

    def input_for(self, accel: float, position: float, rate: float, angle: float, angle_rate: float) -> float:
        """The input that gives the actuated coordinate the acceleration ``accel`` in this state,
        by the model's own nonlinear equations (the pendulum's reaction, the drive's back-EMF,
        friction, as the file declares them; states the controller does not see at zero). The
        acceleration is affine in the input for every drive law the catalogue offers, so two
        evaluations give it; without ``numeric`` the linearisation at the hanging rest does."""
        if self.numeric is None:
            return self.lin.u0 + (accel - self.lin.A[1, 1] * rate) / self.lin.B[1, 0]
        r = self.roles
        x = np.zeros(len(self.numeric.names))
        x[[r.actuated.index, r.actuated.rate_index, r.pendulum.index, r.pendulum.rate_index]] = \
            position, rate, angle, angle_rate
        u0 = self.lin.u0
        a0 = self.numeric.derivatives(x, u0)[r.actuated.rate_index]
        per_unit = self.numeric.derivatives(x, u0 + 1.0)[r.actuated.rate_index] - a0
        return u0 + (accel - a0) / per_unit

    def upright_error(self, angle: float) -> float:
        """The pendulum's angle from the upright, in (-period/2, period/2]."""
        return wrap_upright(angle, self.roles.pendulum.period)

    @classmethod
    def from_model(cls, model: PlantModel, numeric: NumericModel | None = None) -> "PendulumConstants":
        """Find the roles, linearise the model at the upright and at the hanging rest (``numeric``:
        the model's equations if already made)."""
        numeric = numeric or NumericModel.of(model)
        roles = pendulum_roles(model, numeric)
        hanging = linearise_at_rest(numeric, roles, 0.0)
        return cls(roles=roles, lin=linearise_at_rest(numeric, roles, roles.upright),
                   omega0_sq=held_pendulum_stiffness(hanging), coupling=float(hanging.B[3, 0] / hanging.B[1, 0]),
                   input_range=(model.interface.input.lo, model.interface.input.hi), numeric=numeric)


def held_pendulum_stiffness(hanging: UprightLinearModel) -> float:
    """omega0^2 of the pendulum with the actuated coordinate held, from the free linearisation
    at the hanging rest. With mass matrix M and gravity stiffness k on the angle alone, the
    angle column of A is -k M^-1 e2 and B is b M^-1 e1; M^-1 being symmetric, they give k M^-1,
    and the held pendulum's k / M22 is det(k M^-1) / (k M^-1)11 = -A[3,2] + A[1,2] B[3] / B[1]."""
    A, B = hanging.A, hanging.B[:, 0]
    return float(-A[3, 2] + A[1, 2] * B[3] / B[1])


class _VelocityObserver:
    """Actuated and pendulum rates from the encoder positions, as a real controller must get them."""

    def __init__(self, period: float):
        self.actuated_rate = FilteredDifference(period)
        self.angle_rate = FilteredDifference(period)

    def reset(self) -> None:
        """Back to the initial state (velocity filters empty)."""
        self.actuated_rate.reset()
        self.angle_rate.reset()

    def observe(self, meas: Measurement) -> tuple[float, float]:
        """Update the velocity filters; return (actuated rate, pendulum rate)."""
        return (self.actuated_rate.update(meas.position(self.c.actuated)),
                self.angle_rate.update(meas.position(self.c.angle)))


class EnergySwingUp(_VelocityObserver):
    """Energy pumping (Åström–Furuta) on the pendulum's energy per unit inertia with the
    actuated coordinate held, E = ½ w² - omega0² cos(a) (a the angle from hanging, w its rate;
    upright at rest: E = omega0²). An acceleration a_c of the actuated coordinate changes it
    at dE/dt = coupling cos(a) w a_c, so the push is ``gain`` (1 - E / omega0²) sign(coupling
    w cos a), saturated at ``accel_max``, plus a spring and damper that keep the actuated
    coordinate near 0. Both are in the actuated coordinate's unit/s² (defaults
    ``SWING_GAIN`` and ``SWING_PIVOT_ACCEL`` times gravity as the pivot feels it,
    omega0² / |coupling|). The acceleration is turned into the input by the model's own
    equations (:meth:`PendulumConstants.input_for`: the pendulum's reaction on a light rotary
    arm matters as much as the drive), so the gains mean the same on any drive.

    A momentum store (a reaction wheel: :data:`MOMENTUM_LEVER`) pumps by its speed instead
    (:func:`wheel_pace`): a speed target of sign(coupling) sign(sin a) times its pace, scaled by
    the missing energy, which the servo reaches in tens of milliseconds: the wheel's speed turns
    where the pendulum passes the bottom, fastest, so each turn gives it the most energy."""

    mode = "swing"

    def __init__(self, consts: PendulumConstants, period: float = 1e-3, gain: float | None = None,
                 accel_max: float | None = None, centre_k: float = 12.0, centre_d: float = 6.0):
        self.c = consts
        self.period = period
        self.input_range = consts.input_range
        # the pendulum feels coupling * a_c as gravity feels omega0^2: gravity in the actuated unit/s^2
        gravity = consts.omega0_sq / abs(consts.coupling)
        self.gain = SWING_GAIN * gravity if gain is None else gain
        self.accel_max = SWING_PIVOT_ACCEL * gravity if accel_max is None else accel_max
        self.centre_k, self.centre_d = centre_k, centre_d
        self.pace = wheel_pace(consts)
        super().__init__(period)

    def energy(self, angle: float, rate: float) -> float:
        """The pendulum's energy per unit inertia, zero at the pivot height (upright at rest: omega0²)."""
        phase = 2 * math.pi * angle / self.c.roles.pendulum.period
        return 0.5 * rate**2 - self.c.omega0_sq * math.cos(phase)

    def command(self, meas: Measurement, actuated_rate: float, angle_rate: float) -> float:
        """Volts for the filtered state (used by the supervisor too)."""
        angle, position = meas.position(self.c.angle), meas.position(self.c.actuated)
        c = math.cos(2 * math.pi * angle / self.c.roles.pendulum.period)
        # at rest (no angle rate) push anyway: energy pumping needs a first swing to work on
        direction = -1.0 if self.c.coupling * angle_rate * c < 0 else 1.0
        missing = 1.0 - self.energy(angle, angle_rate) / self.c.omega0_sq
        if self.pace is not None:
            # a wheel reaches its no-load speed in tens of ms, so a push that turns at the swing's ends
            # (where the rate is zero) is spent before it can pump; its speed turns at the bottom
            # instead, where the swing is fastest, and shrinks with the missing energy, so the wheel
            # is slow, and the balance has torque, when the pendulum arrives at the top
            speed, servo = self.pace
            side = 1.0 if math.sin(2 * math.pi * angle / self.c.roles.pendulum.period) >= 0 else -1.0
            target = math.copysign(speed, self.c.coupling) * side * max(-1.0, min(1.0, PACE_SHARE * missing))
            return self.c.input_for(servo * (target - actuated_rate), position, actuated_rate, angle, angle_rate)
        pump = max(-self.accel_max, min(self.accel_max, self.gain * missing * direction))
        accel = pump - self.centre_k * position - self.centre_d * actuated_rate
        return self.c.input_for(accel, position, actuated_rate, angle, angle_rate)

    def step(self, meas: Measurement) -> float:
        """One control period."""
        return self.command(meas, *self.observe(meas))


class LqrBalance(_VelocityObserver):
    """Discrete LQR about the upright on (p - p_ref, v, phi, dphi): the actuated position (a
    rotor's wrapped to within half a turn) and its rate, the angle from the upright (wrapped) and
    its rate (weights: :func:`balance_weights` unless ``q_diag``). The gain comes from the
    model's own linearisation (see :mod:`pendc.hil.controllers.linearize`). ``position_ref`` (the actuated
    coordinate's set point) may be a float or a function of time (the 4 cm step scenario)."""

    mode = "balance"

    def __init__(self, consts: PendulumConstants, period: float = 1e-3, position_ref=0.0,
                 q_diag=None, r: float = LQR_R):
        self.c = consts
        self.period = period
        self.input_range = consts.input_range
        self.lqr: DiscreteLqr = design_lqr(consts.lin, period, q_diag or balance_weights(consts), r)
        self.position_ref = position_ref if callable(position_ref) else (lambda t, v=float(position_ref): v)
        super().__init__(period)

    def command(self, meas: Measurement, actuated_rate: float, angle_rate: float) -> float:
        """Volts for the filtered state."""
        offset = meas.position(self.c.actuated) - self.position_ref(meas.t)
        turn = self.c.roles.actuated.period
        if turn is not None:
            offset = wrap_upright(offset + 0.5 * turn, turn)
        err = np.array([offset, actuated_rate,
                        self.c.upright_error(meas.position(self.c.angle)), angle_rate])
        du = -float(self.lqr.K @ err)
        # dry friction compensation: add the volts that the friction eats in the commanded direction
        return self.lqr.u0 + du + self.c.lin.u_coulomb * math.tanh(du / FRICTION_SMOOTHING)

    def step(self, meas: Measurement) -> float:
        """One control period."""
        return self.command(meas, *self.observe(meas))


def wheel_pace(consts: PendulumConstants) -> tuple | None:
    """(speed, servo gain) of a momentum store's pumping (None for a pivot the input positions):
    :data:`PACE_SPEED` of the speed at which the drive's back-EMF takes the input's whole reach,
    and a speed servo of :data:`PACE_SERVO` times the pendulum's natural frequency (1/s)."""
    if 1.0 / abs(consts.coupling) <= MOMENTUM_LEVER:
        return None
    lo, hi = consts.input_range
    reach = min(abs(hi - consts.lin.u0), abs(lo - consts.lin.u0))
    per_rate = abs(consts.input_for(0.0, 0.0, 1.0, 0.0, 0.0) - consts.input_for(0.0, 0.0, 0.0, 0.0, 0.0))
    return PACE_SPEED * reach / max(per_rate, 1e-12), PACE_SERVO * math.sqrt(consts.omega0_sq)


def balance_weights(consts: PendulumConstants) -> tuple:
    """The LQR weights of the balance: :data:`LQR_Q`, the actuated coordinate's excursions times
    its lever where that exceeds :data:`MOMENTUM_LEVER` (a reaction wheel)."""
    lever = 1.0 / abs(consts.coupling)
    if lever <= MOMENTUM_LEVER:
        return LQR_Q
    return (LQR_Q[0] / lever**2, LQR_Q[1] / lever**2) + LQR_Q[2:]


class Supervisor:
    """Swing up, switch to the LQR when the pendulum is near the upright and slow enough,
    fall back to the swing-up when it leaves a wider window (hysteresis: no chattering).
    Both controllers see every sample, so their filters are warm at a switch."""

    def __init__(self, consts: PendulumConstants, period: float = 1e-3, position_ref=0.0,
                 catch_angle: float = CATCH_ANGLE, catch_rate: float = CATCH_RATE, drop_angle: float = DROP_ANGLE):
        self.swing = EnergySwingUp(consts, period)
        self.balance = LqrBalance(consts, period, position_ref=position_ref)
        self.input_range = consts.input_range
        self.catch_angle, self.catch_rate, self.drop_angle = catch_angle, catch_rate, drop_angle
        self.mode = "swing"

    def reset(self) -> None:
        """Back to swinging, filters empty."""
        self.swing.reset()
        self.balance.reset()
        self.mode = "swing"

    def step(self, meas: Measurement) -> float:
        """One control period: update the filters, pick the controller, command."""
        actuated_rate, angle_rate = self.swing.observe(meas)
        self.balance.observe(meas)
        phi = self.swing.c.upright_error(meas.position(self.swing.c.angle))
        if self.mode == "swing" and abs(phi) < self.catch_angle and abs(angle_rate) < self.catch_rate:
            self.mode = "balance"
        elif self.mode == "balance" and abs(phi) > self.drop_angle:
            self.mode = "swing"
        active = self.balance if self.mode == "balance" else self.swing
        return active.command(meas, actuated_rate, angle_rate)
