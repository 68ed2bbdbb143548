"""The effect catalogue of spec §8: each physical effect is one small object.

An effect declares its parameters (name, unit, default, physical bounds) and
contributes to the equations through *hooks* that :func:`pendc.model.cart.build_cart_equations`
calls in one fixed order::

    input delay -> drive force -> drive reshaping -> force shaping -> motor lag
    -> moving friction -> friction scaling -> sticking rule
    -> other cart forces -> pendulum torques -> velocity bound -> sensor offsets

A hook that an effect does not override leaves the equations unchanged, so the
plant is exactly the rigid body plus whatever the listed effects add.
Every hook receives ``s``, a :class:`Symbols` table with the state, the input,
the rigid-body constants, the normal force ``F_N`` and every parameter of the
model by its bare name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import sympy as sp


@dataclass(frozen=True)
class Param:
    """One effect parameter: SI unit, default (the fit's starting value) and physical bounds."""

    name: str
    unit: str
    default: float
    lo: float
    hi: float
    description: str
    optional: bool = False  # may be left out of a model file; the default then holds


@dataclass(frozen=True)
class Symbols:
    """Symbol table handed to the hooks. ``p`` maps parameter names to symbols."""

    x: sp.Symbol
    dx: sp.Symbol
    theta: sp.Symbol
    dtheta: sp.Symbol
    u: sp.Symbol
    F_N: sp.Symbol
    p: dict


class Effect:
    """Base class of an effect: hooks default to "contributes nothing"."""

    name: ClassVar[str]
    summary: ClassVar[str]
    # what the effect touches: "cart" (cart equation or drive), "pendulum" (pivot torque),
    # "x" / "theta" (that sensor only); identification skips effects no measured output can see
    acts_on: ClassVar[str] = "cart"
    params: ClassVar[tuple[Param, ...]] = ()
    # each inner tuple is a set of alternatives of which one must be present
    requires: ClassVar[tuple[tuple[str, ...], ...]] = ()

    def input_delay(self, s: Symbols):
        """Transport delay of the input in seconds, or None."""
        return None

    def drive_force(self, s: Symbols):
        """Force that the input voltage produces on the cart, or None."""
        return None

    def reshape_drive(self, s: Symbols, force):
        """Replace the drive law (e.g. a dead zone); receives the current drive force."""
        return force

    def shape_force(self, s: Symbols, force):
        """Limit or otherwise shape the drive force after the drive law."""
        return force

    def lag_state(self, s: Symbols, force):
        """An extra state that filters the drive force: ``(symbol, derivative, initial)`` or None."""
        return None

    def moving_friction(self, s: Symbols):
        """Friction force on the moving cart without the viscous part, or None."""
        return None

    def scale_moving_friction(self, s: Symbols, force):
        return force

    def sticking_rule(self, s: Symbols):
        """``(mu_s, v_stick)`` of the sticking rule of spec §2, or None."""
        return None

    def cart_force(self, s: Symbols):
        return sp.Integer(0)

    def pendulum_torque(self, s: Symbols):
        return sp.Integer(0)

    def velocity_bound(self, s: Symbols):
        """Bound on |dx| applied after integration, or None."""
        return None

    def sensor_offset(self, s: Symbols):
        """``(state name, offset)``: the sensor of that position reads state + offset, or None.
        The motion is unchanged; only what is measured moves."""
        return None


_MU = dict(unit="-", lo=0.0, hi=2.0)


class Drive(Effect):
    name = "drive"
    summary = "servo drive: force proportional to the input voltage offset, F_in = alpha (u - V_off)"
    params = (
        Param("alpha", "N/V", 51.525, 1e-3, 1e5, "voltage-to-force factor"),
        Param("V_off", "V", 5.0, 0.0, 10.0, "input voltage that gives zero force"),
    )

    def drive_force(self, s):
        return s.p["alpha"] * (s.u - s.p["V_off"])


class DriveDeadzone(Effect):
    name = "drive_deadzone"
    summary = "dead zone of the drive: no force while |u - V_off| <= u_dz"
    params = (Param("u_dz", "V", 0.05, 0.0, 2.0, "half-width of the dead zone"),)
    requires = (("drive",),)

    def reshape_drive(self, s, force):
        e = s.u - s.p["V_off"]
        u_dz = s.p["u_dz"]
        return sp.Piecewise((s.p["alpha"] * (e - u_dz * sp.sign(e)), sp.Abs(e) > u_dz), (0, True))


class ForceLimit(Effect):
    name = "force_limit"
    summary = "drive current limit: F_in clamped to +-F_max"
    params = (Param("F_max", "N", 300.0, 1e-3, 1e5, "largest force the drive delivers"),)
    requires = (("drive",),)

    def shape_force(self, s, force):
        return sp.Max(-s.p["F_max"], sp.Min(s.p["F_max"], force))


class InputDelay(Effect):
    name = "input_delay"
    summary = "transport delay: the plant sees u(t - tau_d)"
    params = (Param("tau_d", "s", 0.002, 0.0, 0.5, "input transport delay"),)

    def input_delay(self, s):
        return s.p["tau_d"]


class MotorLag(Effect):
    name = "motor_lag"
    summary = "first-order lag of the drive force: tau_m dF/dt = F_in - F"
    params = (Param("tau_m", "s", 0.005, 1e-5, 1.0, "time constant of the force build-up"),)
    requires = (("drive",),)

    def lag_state(self, s, force):
        # starts from zero force, like the drive at power-on (and the hardware after reset)
        F_m = sp.Symbol("F_m", real=True)
        return F_m, (force - F_m) / s.p["tau_m"], sp.Integer(0)


class ViscousCart(Effect):
    name = "viscous_cart"
    summary = "viscous friction on the cart, -b_x dx"
    params = (Param("b_x", "N*s/m", 155.1574, 0.0, 1e5, "viscous coefficient of the cart"),)

    def cart_force(self, s):
        return -s.p["b_x"] * s.dx


class CoulombCart(Effect):
    name = "coulomb_cart"
    summary = "Coulomb friction on the cart, -mu_c F_N sgn(dx)"
    params = (Param("mu_c", **_MU, default=0.0292, description="Coulomb friction coefficient"),)

    def moving_friction(self, s):
        return -s.p["mu_c"] * s.F_N * sp.sign(s.dx)


class StaticCart(Effect):
    name = "static_cart"
    summary = "static friction: the cart sticks while |dx| <= v_stick and |F_in| < mu_s F_N"
    params = (
        Param("mu_s", **_MU, default=0.03709, description="static friction coefficient"),
        Param("v_stick", "m/s", 0.0, 0.0, 0.05, "speed below which the cart counts as stuck (0 = exact zero test)", optional=True),
    )

    def sticking_rule(self, s):
        return s.p["mu_s"], s.p["v_stick"]


class StribeckCart(Effect):
    name = "stribeck_cart"
    summary = "Stribeck friction law II.106: static, Coulomb and a velocity-weakening transition"
    params = (
        Param("mu_c", **_MU, default=0.0292, description="Coulomb friction coefficient"),
        Param("mu_s", **_MU, default=0.03709, description="static friction coefficient"),
        Param("v_s", "m/s", 0.105, 1e-4, 10.0, "Stribeck velocity"),
        Param("gamma", "-", 2.0, 0.2, 5.0, "Stribeck form factor"),
        Param("v_stick", "m/s", 0.0, 0.0, 0.05, "speed below which the cart counts as stuck (0 = exact zero test)", optional=True),
    )

    def moving_friction(self, s):
        p = s.p
        weight = sp.exp(-((sp.Abs(s.dx) / p["v_s"]) ** p["gamma"]))
        return -(p["mu_c"] + (p["mu_s"] - p["mu_c"]) * weight) * s.F_N * sp.sign(s.dx)

    def sticking_rule(self, s):
        return s.p["mu_s"], s.p["v_stick"]


class AsymmetricCart(Effect):
    name = "asymmetric_cart"
    summary = "direction-dependent friction: the moving-branch friction times (1 + d_mu sgn(dx))"
    params = (Param("d_mu", "-", 0.0, -0.9, 0.9, "relative friction difference between directions"),)
    requires = (("coulomb_cart", "stribeck_cart"),)

    def scale_moving_friction(self, s, force):
        return force * (1 + s.p["d_mu"] * sp.sign(s.dx))


class ViscousPendulum(Effect):
    name = "viscous_pendulum"
    acts_on = "pendulum"
    summary = "viscous damping at the pivot, -b_theta dtheta"
    params = (Param("b_theta", "N*m*s/rad", 0.01, 0.0, 10.0, "viscous coefficient of the pivot"),)

    def pendulum_torque(self, s):
        return -s.p["b_theta"] * s.dtheta


class CoulombPendulum(Effect):
    name = "coulomb_pendulum"
    acts_on = "pendulum"
    summary = "dry friction at the pivot, -tau_c sgn(dtheta)"
    params = (Param("tau_c", "N*m", 1e-3, 0.0, 1.0, "dry friction torque of the pivot"),)

    def pendulum_torque(self, s):
        return -s.p["tau_c"] * sp.sign(s.dtheta)


class VelocityLimit(Effect):
    name = "velocity_limit"
    summary = "velocity saturation: |dx| clamped to v_max after integration"
    params = (Param("v_max", "m/s", 0.55, 1e-3, 10.0, "largest cart speed"),)

    def velocity_bound(self, s):
        return s.p["v_max"]


class CartSpring(Effect):
    name = "cart_spring"
    summary = "spring or cable pulling the cart, -k_c (x - x_0)"
    params = (
        Param("k_c", "N/m", 100.0, 0.0, 1e6, "spring rate"),
        Param("x_0", "m", 0.0, -0.5, 0.5, "rest position of the spring"),
    )

    def cart_force(self, s):
        return -s.p["k_c"] * (s.x - s.p["x_0"])


class QuadraticPendulum(Effect):
    name = "quadratic_pendulum"
    summary = "air drag on the pendulum, -c_theta dtheta |dtheta|"
    acts_on = "pendulum"
    params = (Param("c_theta", "N*m*s^2", 1e-4, 0.0, 1.0, "quadratic drag coefficient of the swing"),)

    def pendulum_torque(self, s):
        return -s.p["c_theta"] * s.dtheta * sp.Abs(s.dtheta)


class EndStops(Effect):
    name = "end_stops"
    summary = "stiff, damped stops at the track ends: for |x| > x_end, -k_end (x - sgn(x) x_end) - b_end dx"
    # the thesis gives no figures for the stops: the defaults are a stiff rubber buffer
    params = (
        Param("x_end", "m", 0.375, 0.01, 1.0, "where the stops begin (half the 750 mm track)"),
        Param("k_end", "N/m", 1e5, 0.0, 1e8, "stiffness of a stop"),
        Param("b_end", "N*s/m", 1e3, 0.0, 1e6, "damping of a stop"),
    )

    def cart_force(self, s):
        p = s.p
        push = -p["k_end"] * (s.x - sp.sign(s.x) * p["x_end"]) - p["b_end"] * s.dx
        return sp.Piecewise((push, sp.Abs(s.x) > p["x_end"]), (0, True))


class ThetaOffset(Effect):
    """No hardware form by nature: the encoders count from power-on, so an offset of the
    zero exists only in a recording, never in the plant the FPGA models."""

    name = "theta_offset"
    summary = "the angle sensor reads theta + theta_off: its zero is not the hanging rest"
    acts_on = "theta"
    params = (Param("theta_off", "rad", 0.0, -math.pi, math.pi, "angle the sensor reads at the hanging rest"),)

    def sensor_offset(self, s):
        return "theta", s.p["theta_off"]


class XOffset(Effect):
    """No hardware form by nature: the encoders count from power-on, so an offset of the
    zero exists only in a recording, never in the plant the FPGA models. Data show it only
    through physics that depends on where the cart is (end stops, a spring): identification
    starts every segment from the measured state, and nothing else moves with the offset."""

    name = "x_offset"
    summary = "the position sensor reads x + x_off: its zero is not the track centre"
    acts_on = "x"
    params = (Param("x_off", "m", 0.0, -0.5, 0.5, "position the sensor reads at the track centre"),)

    def sensor_offset(self, s):
        return "x", s.p["x_off"]


CATALOGUE: dict[str, type[Effect]] = {
    cls.name: cls
    for cls in (
        Drive, ViscousCart, CoulombCart, StaticCart, StribeckCart, AsymmetricCart,
        ViscousPendulum, CoulombPendulum, VelocityLimit, ForceLimit, DriveDeadzone,
        InputDelay, MotorLag, CartSpring, QuadraticPendulum, EndStops, ThetaOffset, XOffset,
    )
}

# Pairs that both define the same part of the friction law.
CONFLICTS: tuple[tuple[str, str, str], ...] = (
    ("coulomb_cart", "stribeck_cart", "moving-branch friction"),
    ("static_cart", "stribeck_cart", "sticking rule"),
)
