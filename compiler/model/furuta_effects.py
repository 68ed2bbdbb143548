"""The Furuta pendulum's effect catalogue: each physical effect is one small object.

As for the cart-pendulum (:mod:`pendc.model.effects`), an effect declares its parameters
(name, unit, default = a fit's starting value, physical bounds) and contributes through
hooks that :func:`pendc.model.furuta_plant.build_furuta_equations` calls in one fixed order::

    amplifier voltage -> motor torque -> other arm torques -> pivot torques -> sensor offsets

A hook an effect does not override contributes nothing. Every hook receives ``s``, a
:class:`FurutaSymbols` table with the state, the input and every parameter by its bare name.
The defaults are the Quanser QUBE-Servo 2's published figures (``models/furuta_qube.toml``
cites them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import sympy as sp

from .effects import Param


@dataclass(frozen=True)
class FurutaSymbols:
    """Symbol table handed to the hooks. ``p`` maps parameter names to symbols."""

    phi_r: sp.Symbol
    dphi_r: sp.Symbol
    alpha_p: sp.Symbol
    dalpha_p: sp.Symbol
    u: sp.Symbol
    p: dict


class FurutaEffect:
    """Base class of a Furuta effect: hooks default to "contributes nothing".

    ``acts_on`` says what the effect touches: "arm" (the arm's equation or the drive),
    "pendulum" (the pivot torque), or a position's name (that sensor only); identification
    skips effects no measured output can see. ``requires`` lists sets of alternatives of
    which one must be in the model."""

    name: ClassVar[str]
    summary: ClassVar[str]
    acts_on: ClassVar[str] = "arm"
    params: ClassVar[tuple[Param, ...]] = ()
    requires: ClassVar[tuple[tuple[str, ...], ...]] = ()

    def shape_voltage(self, s: FurutaSymbols, voltage):
        """The voltage the motor sees, given the commanded one (an amplifier's limits)."""
        return voltage

    def motor_torque(self, s: FurutaSymbols, voltage):
        """Torque the motor puts on the arm at ``voltage``, or None."""
        return None

    def arm_torque(self, s: FurutaSymbols):
        """Another torque on the arm (friction at its bearing)."""
        return sp.Integer(0)

    def pivot_torque(self, s: FurutaSymbols):
        """A torque at the pendulum's hinge."""
        return sp.Integer(0)

    def sensor_offset(self, s: FurutaSymbols):
        """``(state name, offset)``: the sensor of that angle reads state + offset, or None."""
        return None


class MotorDrive(FurutaEffect):
    """The amplifier drives the DC motor on the arm; the back-EMF brakes it with speed."""

    name = "motor_drive"
    summary = "DC motor from the amplifier's voltage, back-EMF included: tau = k_t (u - k_m dphi_r) / R_m"
    # The QUBE-Servo 2's motor (Quanser's qube2_rotpen_param.m): R_m 8.4 ohm, k_t 0.042 N*m/A,
    # k_m 0.042 V/(rad/s); the armature inductance (1.16 mH, an electrical time constant of
    # 0.14 ms) is left out, as Quanser's own model does
    params = (
        Param("R_m", "ohm", 8.4, 0.1, 100.0, "terminal resistance of the motor"),
        Param("k_t", "N*m/A", 0.042, 1e-4, 1.0, "torque constant of the motor"),
        Param("k_m", "V*s/rad", 0.042, 1e-4, 1.0, "back-EMF constant of the motor"),
    )

    def motor_torque(self, s, voltage):
        p = s.p
        return p["k_t"] * (voltage - p["k_m"] * s.dphi_r) / p["R_m"]


class VoltageLimit(FurutaEffect):
    """The amplifier cannot put out more than its supply allows."""

    name = "voltage_limit"
    summary = "amplifier saturation: the motor sees the input clamped to +-V_max"
    params = (Param("V_max", "V", 10.0, 0.1, 24.0, "largest voltage the amplifier puts out"),)
    requires = (("motor_drive",),)

    def shape_voltage(self, s, voltage):
        return sp.Max(-s.p["V_max"], sp.Min(s.p["V_max"], voltage))


class ViscousArm(FurutaEffect):
    """Viscous friction of the motor and the arm's bearing (Quanser's D_r)."""

    name = "viscous_arm"
    summary = "viscous damping of the arm, -D_r dphi_r"
    params = (Param("D_r", "N*m*s/rad", 0.0015, 0.0, 0.1, "equivalent viscous damping of the arm"),)

    def arm_torque(self, s):
        return -s.p["D_r"] * s.dphi_r


class CoulombArm(FurutaEffect):
    """The effect Quanser's model leaves out and data can hide: the motor's brushes and bearing
    need a small torque to turn at all (no sticking rule: sgn(0) = 0, as for the cart's pivot)."""

    name = "coulomb_arm"
    summary = "dry friction of the motor and the arm's bearing, -tau_r sgn(dphi_r)"
    params = (Param("tau_r", "N*m", 1e-3, 0.0, 0.1, "dry friction torque of the arm"),)

    def arm_torque(self, s):
        return -s.p["tau_r"] * sp.sign(s.dphi_r)


class ViscousPivot(FurutaEffect):
    """Viscous friction of the pendulum's hinge (Quanser's D_p)."""

    name = "viscous_pivot"
    acts_on = "pendulum"
    summary = "viscous damping at the pendulum's hinge, -D_p dalpha_p"
    params = (Param("D_p", "N*m*s/rad", 0.0005, 0.0, 0.1, "equivalent viscous damping of the hinge"),)

    def pivot_torque(self, s):
        return -s.p["D_p"] * s.dalpha_p


class CoulombPivot(FurutaEffect):
    """Dry friction of the pendulum's hinge (no sticking rule: sgn(0) = 0)."""

    name = "coulomb_pivot"
    acts_on = "pendulum"
    summary = "dry friction at the pendulum's hinge, -tau_p sgn(dalpha_p)"
    params = (Param("tau_p", "N*m", 1e-4, 0.0, 0.01, "dry friction torque of the hinge"),)

    def pivot_torque(self, s):
        return -s.p["tau_p"] * sp.sign(s.dalpha_p)


class AlphaOffset(FurutaEffect):
    """No hardware form by nature: the encoders count from power-on, so an offset of the
    zero exists only in a recording (a run started with the pendulum not quite at rest)."""

    name = "alpha_offset"
    summary = "the pendulum's encoder reads alpha_p + alpha_p_off: its zero is not the hanging rest"
    acts_on = "alpha_p"
    params = (Param("alpha_p_off", "rad", 0.0, -math.pi, math.pi, "angle the encoder reads at the hanging rest"),)

    def sensor_offset(self, s):
        return "alpha_p", s.p["alpha_p_off"]


FURUTA_CATALOGUE: dict[str, type[FurutaEffect]] = {
    cls.name: cls
    for cls in (MotorDrive, VoltageLimit, ViscousArm, CoulombArm, ViscousPivot, CoulombPivot, AlphaOffset)
}
# Pairs that both define the same part of the model (none yet: every Furuta effect adds)
FURUTA_CONFLICTS: tuple[tuple[str, str, str], ...] = ()
