"""The plant model: rigid body plus a list of effects, and the equations it implies.

:class:`PlantModel` is the value that model files, the simulator, the identification
workbench and the compiler pass around. :func:`build_equations` turns it into an
:class:`Equations` object: a short list of named intermediate quantities (traceable
to the physics: ``F_in``, ``F_fric``, ``k``, ``ddx`` ...) followed by the state
derivatives. Adding or removing an effect changes these equations and nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import math

import sympy as sp

from ..errors import PendcError
from .effects import CATALOGUE, CONFLICTS, Symbols
from .experiments import DEFAULT_EXPERIMENT, EXPERIMENTS
from .interface import InputSpec, PlantInterface, QuantitySpec, SensorSpec, StateSpec
from .lagrangian import COORDINATES, derive_rigid_body

PLANT_CONSTANTS = {
    "g": ("m/s^2", "gravitational acceleration"),
    "M": ("kg", "virtual cart mass, motor and spindle inertia included (II.5)"),
    "m": ("kg", "pendulum mass (rod and bob)"),
    "L": ("m", "pivot to pendulum centre of mass"),
    "I": ("kg*m^2", "pendulum inertia about its centre of mass"),
}


@dataclass(frozen=True)
class Equations:
    """Symbolic state equations of one model.

    ``assignments`` are ``(symbol, expr)`` pairs in evaluation order; each expr uses
    states, the input, parameters and earlier assignments. ``derivatives[i]`` is
    d/dt of ``states[i]``. ``input`` is the voltage as the plant sees it (after any
    transport delay ``delay``, which the simulator applies). ``velocity_bound``
    clamps |dx| after every integration step. ``initial`` gives the initial value of
    each extra state (beyond x, dx, theta, dtheta) from the input and parameters.
    ``sensor_offsets`` is the measured-output map: ``(state name, offset)`` pairs, the
    sensor of that position reading state + offset (parameters only, so the inverse, the
    true state from a measured one, is a subtraction). ``experiment`` names what was held
    or removed (:mod:`pendc.model.experiments`); the parameters are the same in every one.
    """

    states: tuple
    input: sp.Symbol
    params: tuple
    assignments: tuple
    derivatives: tuple
    initial: tuple = ()
    velocity_bound: sp.Expr | None = None
    delay: sp.Expr | None = None
    sensor_offsets: tuple = ()
    experiment: str = DEFAULT_EXPERIMENT

    def outputs(self) -> tuple:
        """Names of the positions a run of this experiment measures (x, theta or both)."""
        return {"cart_held": ("theta",), "pendulum_removed": ("x",)}.get(self.experiment, ("x", "theta"))

    def inline(self, expr: sp.Expr) -> sp.Expr:
        """``expr`` with every assignment symbol replaced by its definition."""
        for sym, value in reversed(self.assignments):
            expr = expr.subs(sym, value)
        return expr

    def assignment(self, name: str) -> sp.Expr:
        for sym, value in self.assignments:
            if sym.name == name:
                return value
        raise KeyError(name)


@dataclass(frozen=True)
class PlantModel:
    """Rigid-body constants, active effects with their parameter values, and fit settings.

    ``effects`` maps effect name to ``{parameter: value}``; it is kept in catalogue
    order so that equal models produce identical equations and kernels. ``hardware``
    holds the model file's ``[hardware]`` table (build options and per-node range or
    Q-format overrides) untouched. ``experiment`` selects the equations of one of
    :data:`~pendc.model.experiments.EXPERIMENTS` (a held cart, a removed pendulum);
    it is never written to a model file. Construction validates everything and raises
    :class:`PendcError` with a one-line reason.
    """

    plant: dict
    effects: dict
    free: tuple = ()
    source: str = field(default="", compare=False)
    hardware: dict = field(default_factory=dict)   # compiler options; the compiler validates them
    experiment: str = DEFAULT_EXPERIMENT

    def __post_init__(self):
        if self.experiment not in EXPERIMENTS:
            raise PendcError(f"unknown experiment '{self.experiment}' (known: {', '.join(EXPERIMENTS)})")
        plant = _validate_plant(self.plant, self.source)
        effects = _validate_effects(self.effects, self.source)
        object.__setattr__(self, "plant", plant)
        object.__setattr__(self, "effects", effects)
        names = self.parameter_names()
        for p in self.free:
            if p not in names:
                raise PendcError(f"{self._where()}[fit] free names unknown parameter '{p}' (known: {', '.join(names)})")

    def _where(self):
        return f"{self.source}: " if self.source else ""

    def parameter_names(self) -> tuple:
        """Plant constants, then effect parameters in catalogue order."""
        return tuple(self.plant) + tuple(p for params in self.effects.values() for p in params)

    def parameter_values(self) -> dict:
        values = dict(self.plant)
        for params in self.effects.values():
            values.update(params)
        return values

    def for_experiment(self, name: str) -> "PlantModel":
        """The same model under experiment ``name`` (same parameters, other equations)."""
        return replace(self, experiment=name)

    def with_params(self, values: dict) -> "PlantModel":
        """A copy with some parameters (bare names) set to new values."""
        unknown = set(values) - set(self.parameter_names())
        if unknown:
            raise PendcError(f"unknown parameter(s) {', '.join(sorted(unknown))} for this model")
        plant = {k: float(values.get(k, v)) for k, v in self.plant.items()}
        effects = {e: {k: float(values.get(k, v)) for k, v in ps.items()} for e, ps in self.effects.items()}
        return replace(self, plant=plant, effects=effects)

    def with_effect(self, name: str, params: dict | None = None) -> "PlantModel":
        """A copy with effect ``name`` added (catalogue defaults for parameters not given)."""
        if name not in CATALOGUE:
            raise PendcError(f"unknown effect '{name}' (known: {', '.join(CATALOGUE)})")
        if name in self.effects:
            raise PendcError(f"the model has effect '{name}' already")
        values = {p.name: p.default for p in CATALOGUE[name].params}
        values.update(params or {})
        return replace(self, effects={**self.effects, name: values})

    def without_effect(self, name: str) -> "PlantModel":
        if name not in self.effects:
            raise PendcError(f"the model has no effect '{name}'")
        effects = {k: v for k, v in self.effects.items() if k != name}
        free = tuple(p for p in self.free if p not in self.effects[name])
        return replace(self, effects=effects, free=free)

    @cached_property
    def equations(self) -> Equations:
        return build_equations(self)

    @cached_property
    def interface(self) -> PlantInterface:
        """What the compiler, golden model and testbench know of this plant (states, input,
        encoders, tolerances); see :mod:`pendc.model.interface`."""
        return build_interface(self)

    def parameter_vector(self):
        """Values in the order of ``self.equations.params``."""
        values = self.parameter_values()
        return [values[s.name] for s in self.equations.params]


def _check_value(where: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PendcError(f"{where} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise PendcError(f"{where} must be finite, got {value!r}")
    return float(value)


def _validate_plant(plant: dict, source: str) -> dict:
    pre = f"{source}: " if source else ""
    if not isinstance(plant, dict):
        raise PendcError(f"{pre}[plant] must be a table")
    unknown = set(plant) - set(PLANT_CONSTANTS)
    if unknown:
        raise PendcError(f"{pre}[plant] has unknown constant(s) {', '.join(sorted(unknown))} (known: g M m L I)")
    missing = [k for k in PLANT_CONSTANTS if k not in plant]
    if missing:
        raise PendcError(f"{pre}[plant] lacks {', '.join(missing)}")
    out = {}
    for k in PLANT_CONSTANTS:
        v = _check_value(f"{pre}plant.{k}", plant[k])
        if v <= 0:
            raise PendcError(f"{pre}plant.{k} must be positive, got {v}")
        out[k] = v
    return out


def _validate_effects(effects: dict, source: str) -> dict:
    pre = f"{source}: " if source else ""
    if not isinstance(effects, dict):
        raise PendcError(f"{pre}[effects] must be a table of effect tables")
    for name in effects:
        if name not in CATALOGUE:
            raise PendcError(f"{pre}unknown effect '{name}' (known: {', '.join(CATALOGUE)})")
    out = {}
    for name, cls in CATALOGUE.items():  # catalogue order: equal models give identical equations
        if name not in effects:
            continue
        given = effects[name]
        if not isinstance(given, dict):
            raise PendcError(f"{pre}[effects.{name}] must be a table")
        known = {p.name: p for p in cls.params}
        for k in given:
            if k not in known:
                raise PendcError(f"{pre}effect '{name}' has no parameter '{k}' (its parameters: {', '.join(known)})")
        values = {}
        for p in cls.params:
            if p.name not in given:
                if not p.optional:
                    raise PendcError(f"{pre}[effects.{name}] lacks parameter '{p.name}' ({p.description}, {p.unit})")
                values[p.name] = p.default
                continue
            v = _check_value(f"{pre}{name}.{p.name}", given[p.name])
            if not p.lo <= v <= p.hi:
                raise PendcError(f"{pre}{name}.{p.name} = {v} is outside its physical range [{p.lo}, {p.hi}] {p.unit}")
            values[p.name] = v
        out[name] = values
    for a, b, what in CONFLICTS:
        if a in out and b in out:
            raise PendcError(f"{pre}effects '{a}' and '{b}' both define the {what}; keep one")
    for name in out:
        for alternatives in CATALOGUE[name].requires:
            if not any(a in out for a in alternatives):
                raise PendcError(f"{pre}effect '{name}' needs one of: {', '.join(alternatives)}")
    return out


def build_equations(model: PlantModel) -> Equations:
    """Assemble the state equations of ``model`` from the derived rigid body and its effects."""
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
    )


# -- the plant interface -----------------------------------------------------------------------

INPUT = ("u", "V", "driver input voltage (V)", 10.0)      # name, unit, meaning, full scale (±10 V)
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


def build_interface(model: PlantModel) -> PlantInterface:
    """The cart-pendulum's :class:`PlantInterface`: the rigid body's coordinates and rates
    (periodicity read off the Lagrangian), the velocity clamp of the model's effects, any lag
    states, the driver input and the two encoders."""
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
        inputs=(InputSpec(*INPUT),),
        sensors=tuple(SensorSpec(f"enc_{state}", state, body, band, lines, bands)
                      for state, body, band, lines, bands in ENCODERS),
        quantities=tuple(QuantitySpec(name, unit, meaning) for name, (unit, meaning) in QUANTITIES.items()
                         if name not in state_names))
