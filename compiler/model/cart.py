"""The cart-pendulum's equations and plant interface (the SCT inverted pendulum, spec §2-§4).

:func:`build_cart_equations` assembles the state equations from the derived rigid body
(:mod:`pendc.model.lagrangian`) and the effects of :mod:`pendc.model.effects`;
:func:`build_cart_interface` gives what the compiler knows of the plant around them.
"""

from __future__ import annotations

import math

import sympy as sp

from ..errors import PendcError
from .effects import CATALOGUE, Symbols
from .equations import Equations
from .interface import PlantInterface, QuantitySpec, SensorSpec, StateSpec, input_spec
from .lagrangian import COORDINATES, derive_rigid_body

PLANT_CONSTANTS = {
    "g": ("m/s^2", "gravitational acceleration"),
    "M": ("kg", "virtual cart mass, motor and spindle inertia included (II.5)"),
    "m": ("kg", "pendulum mass (rod and bob)"),
    "L": ("m", "pivot to pendulum centre of mass"),
    "I": ("kg*m^2", "pendulum inertia about its centre of mass"),
}
# The positions each experiment measures
MEASURED = {"cart_held": ("theta",), "pendulum_removed": ("x",)}


def build_cart_equations(model) -> Equations:
    """Assemble the cart-pendulum state equations of ``model`` (a :class:`~pendc.model.plant.PlantModel`) from the derived rigid body and its effects."""
    rb = derive_rigid_body()
    x, dx, theta, dtheta = rb.state
    u = sp.Symbol("u", real=True)
    F_N = sp.Symbol("F_N", real=True)
    params = dict(rb.constants)
    for name, values in model.effects.items():
        for p in values:
            params[p] = sp.Symbol(p, real=True)
    s = Symbols(x=x, dx=dx, theta=theta, dtheta=dtheta, u=u, F_N=F_N, p=params)
    effects = [CATALOGUE[name]() for name in model.effects]
    c = rb.constants

    assignments = [(F_N, (c["M"] + c["m"]) * c["g"])]

    def bind(name, expr):
        sym = sp.Symbol(name, real=True)
        assignments.append((sym, expr))
        return sym

    delay = next((d for d in (e.input_delay(s) for e in effects) if d is not None), None)

    force = next((f for f in (e.drive_force(s) for e in effects) if f is not None), sp.Integer(0))
    for e in effects:
        force = e.reshape_drive(s, force)
    for e in effects:
        force = e.shape_force(s, force)
    F_in = bind("F_in", force)

    states, derivs, initial = [x, dx, theta, dtheta], [], []
    F_act = F_in
    for e in effects:
        lag = e.lag_state(s, F_act)
        if lag is not None:
            state, deriv, init = lag
            states.append(state)
            derivs.append(deriv)
            initial.append(init)
            F_act = state

    moving = next((f for f in (e.moving_friction(s) for e in effects) if f is not None), sp.Integer(0))
    for e in effects:
        moving = e.scale_moving_friction(s, moving)
    rule = next((r for r in (e.sticking_rule(s) for e in effects) if r is not None), None)
    if rule is not None:
        mu_s, v_stick = rule
        friction = sp.Piecewise(
            (moving, sp.Abs(dx) > v_stick),
            (-F_act, sp.Abs(F_act) < mu_s * F_N),
            (-mu_s * F_N * sp.sign(F_act), True),
        )
    else:
        friction = moving
    F_fric = bind("F_fric", friction) if friction != 0 else friction

    F_cart = bind("F_cart", F_act + F_fric + sum((e.cart_force(s) for e in effects), sp.Integer(0)))
    tau = bind("tau_pend", sum((e.pendulum_torque(s) for e in effects), sp.Integer(0)))
    k = bind("k", rb.k)
    forces = {rb.forces[0]: F_cart, rb.forces[1]: tau}
    moving = (dx, dtheta)
    if model.experiment == "cart_held":
        # the clamp takes whatever force the cart equation would need: only the pivot equation
        # holds, with ddx = 0
        acc = sp.Symbol("ddtheta", real=True)
        pivot = rb.euler_lagrange[1].subs({sp.Symbol("ddx", real=True): 0, rb.forces[1]: tau})
        ddx = bind("ddx", sp.Float(0.0))
        ddtheta = bind("ddtheta", sp.solve(pivot, acc)[0])
        moving = (sp.Float(0.0), dtheta)
    elif model.experiment == "pendulum_removed":
        # no pendulum mass: the cart alone (the normal force too, as the thesis' Table 2 fit has it)
        no_m = {c["m"]: 0}
        assignments[0] = (F_N, assignments[0][1].subs(no_m))
        ddx = bind("ddx", sp.cancel((rb.num_x.subs(forces) / rb.k).subs(no_m)))
        ddtheta = bind("ddtheta", sp.Float(0.0))
        moving = (dx, sp.Float(0.0))
    else:
        ddx = bind("ddx", rb.num_x.subs(forces) / k)
        ddtheta = bind("ddtheta", rb.num_theta.subs(forces) / k)

    bound = next((b for b in (e.velocity_bound(s) for e in effects) if b is not None), None)
    offsets = tuple(o for o in (e.sensor_offset(s) for e in effects) if o is not None)
    used = [sym for sym in params.values()]   # every experiment keeps every parameter
    return Equations(
        states=tuple(states),
        input=u,
        params=tuple(used),
        assignments=tuple(assignments),
        derivatives=(moving[0], ddx, moving[1], ddtheta, *derivs),
        initial=tuple(initial),
        velocity_bound=bound,
        delay=delay,
        sensor_offsets=offsets,
        experiment=model.experiment,
        measured=MEASURED.get(model.experiment, ("x", "theta")),
    )


# -- the plant interface -----------------------------------------------------------------------

INPUT = ("u", "V", "driver input voltage (V)")      # name, unit, meaning
# What the drive takes (thesis II.1, Fig. II.4: "the input voltage having a range from 0 to
# 10V"; spec section 3): a model file's [input] range overrides it. The input port's full
# scale is the larger end, 10 V.
INPUT_RANGE = (0.0, 10.0)
# Named intermediates of build_equations (and the lag state of motor_lag), as the IR prints them
QUANTITIES = {
    "F_m": ("N", "drive force after the motor lag (N)"), "F_in": ("N", "drive force on the cart (N)"),
    "F_fric": ("N", "cart friction without the viscous part (N)"),
    "F_cart": ("N", "generalized force on the cart (N)"), "tau_pend": ("N*m", "torque at the pivot (N*m)"),
    "ddx": ("m/s^2", "cart acceleration (m/s^2)"), "ddtheta": ("rad/s^2", "pendulum angular acceleration (rad/s^2)"),
}
FEED = 5e-3                           # m per spindle revolution
# The rig's encoders (spec section 4): state, body, band (state units), lines, bands per revolution
ENCODERS = (("x", "cart", FEED / 1000, 500, 1000),                 # 1000 bands/rev of the spindle (II.49)
            ("theta", "pendulum", 2 * math.pi / 10000, 5000, 10000))  # Heidenhain ROD 420 (II.50)
# One count of each after x4 decoding (half a band): 2.5 um of cart travel, 0.314 mrad
X_COUNT, THETA_COUNT = (band / 2 for _, _, band, _, _ in ENCODERS)
# Error budget: half an encoder count over the check horizon, the count as the thesis prints it
# (2.5 um, 0.314 mrad)
BUDGETS = {"x": 2.5e-6 / 2, "theta": 3.14e-4 / 2}
# Whole turns either way that theta holds. The angle stays continuous (the encoders count
# turns, measurements are unwrapped), so its register needs integer bits for every turn it
# may make: 256 turns is over a minute at the encoders' 8*pi rad/s limit and costs 8 bits over
# one turn. Tables only read the fraction of theta/2pi, which wraps for free. A pendulum
# spun further stops the run with theta's overflow flag, never a silent wrap.
TURN_CAPACITY = 256
# A spinning pendulum's rate for range analysis to train on: above the encoders' design limit
# (spec section 4, 8*pi rad/s) and above the 29 rad/s that a minute of full-scale switching
# reaches on the rig model, where the cart's hits on the end stops spin the pendulum.
SPIN_RATE = 10 * math.pi


def build_cart_interface(model) -> PlantInterface:
    """The cart-pendulum's :class:`PlantInterface`: the rigid body's coordinates and rates
    (periodicity read off the Lagrangian), the velocity clamp of the model's effects, any lag
    states, the driver input (its range the model file's, else the thesis' 0-10 V) and the two
    encoders."""
    eq = model.equations
    rb = derive_rigid_body()
    periods = dict(rb.periods)
    values = {s: sp.Float(v) for s, v in zip(eq.params, model.parameter_vector())}
    bound = None if eq.velocity_bound is None else float(eq.velocity_bound.subs(values))
    states = []
    for q, body, (pq, punit, pmeaning), (rq, runit, rmeaning) in COORDINATES:
        period = periods[q]
        states.append(StateSpec(q, punit, pmeaning, body, pq, period=None if period is None else float(period),
                                turns=TURN_CAPACITY if period is not None else None, budget=BUDGETS.get(q)))
        states.append(StateSpec(f"d{q}", runit, rmeaning, body, rq, derivative_of=q,
                                velocity_bound=bound if period is None else None,   # the cart's clamp
                                training_rate=SPIN_RATE if period is not None else None))
    if [s.name for s in states] != [sym.name for sym in eq.states[:len(states)]]:
        raise PendcError("internal error: the equations' states are not the rigid body's coordinates and rates")
    for sym in eq.states[len(states):]:       # lag states (motor_lag's F_m): internal, not reported
        unit, meaning = QUANTITIES.get(sym.name, ("", sym.name))
        states.append(StateSpec(sym.name, unit, meaning, output=False))
    state_names = {s.name for s in states}
    return PlantInterface(
        name="cart_pendulum", core="pendulum_core", states=tuple(states),
        inputs=(input_spec(INPUT, model.input_range or INPUT_RANGE),),
        sensors=tuple(SensorSpec(f"enc_{state}", state, body, band, lines, bands)
                      for state, body, band, lines, bands in ENCODERS),
        quantities=tuple(QuantitySpec(name, unit, meaning) for name, (unit, meaning) in QUANTITIES.items()
                         if name not in state_names))
