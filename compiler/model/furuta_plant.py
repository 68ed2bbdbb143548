"""The rotary (Furuta) pendulum's equations and plant interface (a Quanser QUBE-Servo 2).

:func:`build_furuta_equations` assembles the state equations from the derived rigid body
(:mod:`pendc.model.furuta`) and the effects of :mod:`pendc.model.furuta_effects`;
:func:`build_furuta_interface` gives what the compiler knows of the plant around them: the
states (both angles are rotations: their period is read off the geometry), the amplifier's
input, the two 512-line encoders and error budgets of half an encoder count.
"""

from __future__ import annotations

import math

import sympy as sp

from ..errors import PendcError
from .equations import Equations
from .furuta import COORDINATES, derive_furuta
from .furuta_effects import FURUTA_CATALOGUE, FurutaSymbols
from .interface import PlantInterface, QuantitySpec, SensorSpec, StateSpec, input_spec

# The positions each experiment measures
MEASURED = {"arm_held": ("alpha_p",), "pendulum_removed": ("phi_r",)}

# The amplifier's input: name, unit, meaning, and the range it takes. Qube-Servo user manual:
# the PWM amplifier's recommended output range is +-10 V (+-15 V at most); the model takes the
# recommended range, as Quanser's own swing-up (tau_max = k_t 10 V / R_m) does. A model file's
# [input] range overrides it.
INPUT = ("u", "V", "motor voltage from the amplifier (V)")
INPUT_RANGE = (-10.0, 10.0)
# Named intermediates of build_furuta_equations, as the IR prints them
QUANTITIES = {
    "tau_motor": ("N*m", "motor torque on the arm (N*m)"),
    "tau_arm": ("N*m", "generalized torque on the arm (N*m)"),
    "tau_pivot": ("N*m", "torque at the pendulum's hinge (N*m)"),
    "det_furuta": ("kg^2*m^4", "determinant of the mass matrix, a function of the pendulum angle"),
    "ddphi_r": ("rad/s^2", "arm angular acceleration (rad/s^2)"),
    "ddalpha_p": ("rad/s^2", "pendulum angular acceleration (rad/s^2)"),
}
# Qube-Servo user manual: both encoders have 512 lines per revolution, 2048 counts in
# quadrature (0.00307 rad per count): state, body, band (rad), lines, bands per revolution
LINES = 512
ENCODERS = (("phi_r", "arm", 2 * math.pi / (2 * LINES), LINES, 2 * LINES),
            ("alpha_p", "pendulum", 2 * math.pi / (2 * LINES), LINES, 2 * LINES))
# Error budget: half an encoder count (2*pi / 2048 / 2 rad) for each measured angle
BUDGETS = {state: band / 4 for state, _, band, _, _ in ENCODERS}
# Whole turns either way each angle's register holds. The arm turns at up to about 30 rad/s
# at full scale (k_t 10 V / (R_m D_r + k_t k_m) with the shipped figures), 1024 turns is 3.6
# minutes of it; the pendulum, whirled by the arm, gets the cart-pendulum's 256 turns.
TURNS = {"phi_r": 1024, "alpha_p": 256}
# Rates for range analysis to train on from reset: the arm beyond any speed the amplifier can
# drive it to (the back-EMF limit full scale / k_m is 238 rad/s with no friction at all, the
# shipped model's damping holds it near 30 rad/s), the pendulum spinning at twice that.
SPIN_RATES = {"phi_r": 40.0, "alpha_p": 80.0}


def build_furuta_equations(model) -> Equations:
    """Assemble the Furuta state equations of ``model`` (a :class:`~pendc.model.plant.PlantModel`)."""
    rb = derive_furuta()
    phi, dphi, alpha, dalpha = rb.state
    u = sp.Symbol("u", real=True)
    params = dict(rb.constants)
    for values in model.effects.values():
        for p in values:
            params[p] = sp.Symbol(p, real=True)
    s = FurutaSymbols(phi_r=phi, dphi_r=dphi, alpha_p=alpha, dalpha_p=dalpha, u=u, p=params)
    effects = [FURUTA_CATALOGUE[name]() for name in model.effects]
    assignments = []

    def bind(name, expr):
        sym = sp.Symbol(name, real=True)
        assignments.append((sym, expr))
        return sym

    voltage = u
    for e in effects:
        voltage = e.shape_voltage(s, voltage)
    motor = next((m for m in (e.motor_torque(s, voltage) for e in effects) if m is not None), sp.Integer(0))
    if motor != 0:
        motor = bind("tau_motor", motor)
    tau_arm = bind("tau_arm", motor + sum((e.arm_torque(s) for e in effects), sp.Integer(0)))
    tau_pivot = bind("tau_pivot", sum((e.pivot_torque(s) for e in effects), sp.Integer(0)))
    torques = {rb.forces[0]: tau_arm, rb.forces[1]: tau_pivot}
    ddphi_sym, ddalpha_sym = rb.accelerations
    rates = (dphi, dalpha)
    if model.experiment == "arm_held":
        # the clamp takes whatever torque the arm's equation would need: only the hinge's holds
        hinge = rb.euler_lagrange[1].subs({ddphi_sym: 0, dphi: 0, rb.forces[1]: tau_pivot})
        ddphi = bind("ddphi_r", sp.Float(0.0))
        ddalpha = bind("ddalpha_p", sp.solve(hinge, ddalpha_sym)[0])
        rates = (sp.Float(0.0), dalpha)
    elif model.experiment == "pendulum_removed":
        # no pendulum: the motor turns the arm's own inertia
        arm = rb.euler_lagrange[0].subs({rb.constants["m_p"]: 0, ddalpha_sym: 0, rb.forces[0]: tau_arm})
        ddphi = bind("ddphi_r", sp.solve(arm, ddphi_sym)[0])
        ddalpha = bind("ddalpha_p", sp.Float(0.0))
        rates = (dphi, sp.Float(0.0))
    else:
        det = bind("det_furuta", rb.det)
        ddphi = bind("ddphi_r", rb.numerators[0].subs(torques) / det)
        ddalpha = bind("ddalpha_p", rb.numerators[1].subs(torques) / det)
    offsets = tuple(o for o in (e.sensor_offset(s) for e in effects) if o is not None)
    return Equations(
        states=(phi, dphi, alpha, dalpha),
        input=u,
        params=tuple(params.values()),        # every experiment keeps every parameter
        assignments=tuple(assignments),
        derivatives=(rates[0], ddphi, rates[1], ddalpha),
        sensor_offsets=offsets,
        experiment=model.experiment,
        measured=MEASURED.get(model.experiment, ("phi_r", "alpha_p")),
    )


def build_furuta_interface(model) -> PlantInterface:
    """The Furuta pendulum's :class:`PlantInterface`: arm and pendulum angles and rates (both
    periodic, as the geometry says), the amplifier's voltage, the two QUBE-Servo 2 encoders."""
    eq = model.equations
    periods = dict(derive_furuta().periods)
    states = []
    for q, body, (pq, punit, pmeaning), (rq, runit, rmeaning) in COORDINATES:
        period = periods[q]
        if period is None:
            raise PendcError(f"internal error: the Furuta's {q} should be a rotation")
        states.append(StateSpec(q, punit, pmeaning, body, pq, period=float(period), turns=TURNS[q],
                                budget=BUDGETS[q]))
        states.append(StateSpec(f"d{q}", runit, rmeaning, body, rq, derivative_of=q,
                                training_rate=SPIN_RATES[q]))
    if [s.name for s in states] != [sym.name for sym in eq.states]:
        raise PendcError("internal error: the Furuta equations' states are not the rigid body's coordinates and rates")
    return PlantInterface(
        name="furuta", core="furuta_core", states=tuple(states),
        inputs=(input_spec(INPUT, model.input_range or INPUT_RANGE),),
        sensors=tuple(SensorSpec(f"enc_{state}", state, body, band, lines, bands)
                      for state, body, band, lines, bands in ENCODERS),
        quantities=tuple(QuantitySpec(name, unit, meaning) for name, (unit, meaning) in QUANTITIES.items()))
