"""State equations and plant interface of a model: a plant definition plus parameter values.

:func:`build_equations` walks the stages of :mod:`pendc.model.effect_kinds` in their fixed
order and binds named intermediates as the file names them (the intermediates, each drive's
force, each coordinate's dry friction and generalized force, the determinant, the
accelerations), so the IR, the Verilog and the reports speak the file's names. The rigid
body is :mod:`pendc.model.mechanics`' derivation (mechanical form) or the file's own state
equations. :func:`build_interface` gives what the compiler knows around the equations.
"""

from __future__ import annotations

import sympy as sp

from ..errors import PendcError
from .dimensions import check_dimensions
from .effect_kinds import DRIVE, INPUT, MOVING, SHAPERS, STICKING, target_kind
from .equations import Equations
from .expressions import parse_expression
from .interface import PlantInterface, QuantitySpec, StateSpec, input_spec
from .mechanics import derive
from .zero_divisors import check_zero_divisors

DEFAULT_TURNS = 256      # whole periods either way a periodic register holds when the file does not say


class _Context:
    """Symbols of one model and the assignments bound so far."""

    def __init__(self, model):
        d = model.definition
        self.d, self.model, self.where = d, model, model.source or d.name
        self.symbols = {}
        for name, p in d.constants.items():
            # from the bounds alone, never the value: with_params keeps the derived equations
            self.symbols[name] = (sp.Symbol(name, positive=True) if p.lo > 0 or p.positive else
                                  sp.Symbol(name, nonnegative=True) if p.lo == 0 else sp.Symbol(name, real=True))
        self.params = list(self.symbols.values())
        for values in model.effects.values():
            for p in values:
                self.symbols[p] = sp.Symbol(p, real=True)
                self.params.append(self.symbols[p])
        for i in d.inputs:
            self.symbols[i.name] = sp.Symbol(i.name, real=True)
        for c in d.coordinates:
            self.symbols[c.name] = sp.Symbol(c.name, real=True)
            self.symbols[f"d{c.name}"] = sp.Symbol(f"d{c.name}", real=True)
        for s in d.states:
            self.symbols[s.name] = sp.Symbol(s.name, real=True)
        self.assignments = []

    def parse(self, text, where, extra=None):
        return parse_expression(text, {**self.symbols, **(extra or {})}, f"{self.where}: {where}")

    def role(self, effect, role, default=None):
        text = effect.role(role)
        if text is None:
            return default
        return self.parse(text, f"catalogue.{effect.name}.{role}")

    def bind(self, name, expr):
        sym = sp.Symbol(name, real=True)
        self.assignments.append((sym, expr))
        self.symbols[name] = sym
        return sym


def _shape(ctx, effect, value):
    """``value`` through a dead zone or a saturation."""
    if effect.kind == "saturation":
        limit = ctx.role(effect, "limit")
        lo, hi = (-limit, limit) if limit is not None else (ctx.role(effect, "low"), ctx.role(effect, "high"))
        return sp.Max(lo, sp.Min(hi, value))
    width, centre = ctx.role(effect, "width"), ctx.role(effect, "centre", sp.Integer(0))
    e = value - centre
    return sp.Piecewise((value - width * sp.sign(e), sp.Abs(e) > width), (centre, True))


def _active(ctx, *kinds):
    return [ctx.d.catalogue[n] for n in ctx.model.effects if ctx.d.catalogue[n].kind in kinds]


def _drives(ctx):
    """Each active drive's output force (after shaping, binding and lags): name -> expression,
    the input delay, and the lag states ``(symbol, derivative, initial)``."""
    d = ctx.d
    delay = next((ctx.role(e, "time") for e in _active(ctx, "delay")), None)
    out, lags = {}, []
    for e in _active(ctx, "drive"):
        law = ctx.parse(e.role("force"), f"catalogue.{e.name}.force")
        out[e.name] = sp.piecewise_fold(law) if law.has(sp.Piecewise) else law
    for e in _active(ctx, *SHAPERS):
        if target_kind(d, e) == DRIVE and e.on in out:
            out[e.on] = _shape(ctx, e, out[e.on])
    for e in _active(ctx, "drive"):
        if e.role("name"):
            out[e.name] = ctx.bind(e.role("name"), out[e.name])
    for e in _active(ctx, "lag"):
        if e.on not in out:
            continue
        state = sp.Symbol(e.role("state") or f"{e.on}_lag", real=True)
        lags.append((state, (out[e.on] - state) / ctx.role(e, "time_constant"), ctx.role(e, "initial", sp.Integer(0))))
        ctx.symbols[state.name] = state
        out[e.on] = state
    return out, delay, lags


def _generalized_force(ctx, coordinate, friction_name, force_name, drive_out):
    """Bind the generalized force on ``coordinate``: its drives, its dry friction (with the
    sticking rule against the drives' force), and every other force on it."""
    d = ctx.d
    rate = ctx.symbols[d.rate_of(coordinate)]
    applied = sum((drive_out[e.name] for e in _active(ctx, "drive") if e.on == coordinate and e.name in drive_out),
                  sp.Integer(0))
    on = [e for e in (d.catalogue[n] for n in ctx.model.effects) if e.on == coordinate]
    moving = sp.Integer(0)
    for e in on:
        scale = ctx.role(e, "scale", sp.Integer(1))
        if e.kind == "coulomb":
            moving = -ctx.role(e, "level") * scale * sp.sign(rate)
        elif e.kind == "stribeck":
            c, s = ctx.role(e, "coulomb"), ctx.role(e, "static")
            weight = sp.exp(-((sp.Abs(rate) / ctx.role(e, "velocity")) ** ctx.role(e, "shape")))
            moving = -(c + (s - c) * weight) * scale * sp.sign(rate)
    for e in on:
        if e.kind == "asymmetric":
            moving = moving * (1 + ctx.role(e, "ratio") * sp.sign(rate))
    rule = next((e for e in on if e.kind in STICKING), None)
    friction = moving
    if rule is not None:
        level = ctx.role(rule, "static" if rule.kind == "stribeck" else "level") * ctx.role(rule, "scale", sp.Integer(1))
        below = ctx.role(rule, "stick_below", sp.Integer(0))
        friction = sp.Piecewise((moving, sp.Abs(rate) > below), (-applied, sp.Abs(applied) < level),
                                (-level * sp.sign(applied), True))
    if friction_name and friction != 0:
        friction = ctx.bind(friction_name, friction)
    others = sp.Integer(0)
    for e in on:
        if e.kind == "viscous":
            others += -ctx.role(e, "coefficient") * rate
        elif e.kind == "quadratic_drag":
            others += -ctx.role(e, "coefficient") * rate * sp.Abs(rate)
        elif e.kind == "spring":
            others += -ctx.role(e, "stiffness") * (ctx.symbols[coordinate] - ctx.role(e, "rest", sp.Integer(0)))
        elif e.kind == "force":
            others += ctx.role(e, "force")
    return ctx.bind(force_name, applied + friction + others)


def build_equations(model) -> Equations:
    """The state equations of ``model`` (a :class:`~pendc.model.plant.PlantModel`) under its
    experiment."""
    ctx = _Context(model)
    d = ctx.d
    experiment = d.experiments[model.experiment]
    removed = set(experiment.removed)
    zero = {}
    for b in d.bodies:
        if b.name in removed:
            for text in (b.mass, b.inertia):
                if text and text in ctx.symbols:
                    zero[ctx.symbols[text]] = 0
    raw_input = ctx.symbols[d.inputs[0].name]
    for e in _active(ctx, *SHAPERS):
        if target_kind(d, e) == INPUT:
            # every expression reads the input as its dead zones and saturations leave it: a drive's
            # law, and as well an intermediate or a state equation that uses the input itself
            ctx.symbols[e.on] = _shape(ctx, e, ctx.symbols[e.on])
    for name, text, _, _ in d.intermediates:
        ctx.bind(name, ctx.parse(text, f"intermediates.{name}").subs(zero))
    drive_out, delay, lags = _drives(ctx)
    if d.form == "mechanical":
        derivatives = _mechanical(ctx, experiment, drive_out)
        states = [s for c in d.coordinates for s in (ctx.symbols[c.name], ctx.symbols[f"d{c.name}"])]
    else:
        derivatives, states = _state_form(ctx, experiment, drive_out)
    limit = next(iter(_active(ctx, "velocity_limit")), None)
    offsets = tuple((e.on, ctx.role(e, "offset")) for e in _active(ctx, "offset"))
    held = set(experiment.held)
    measured = experiment.measured or tuple(
        s.state for s in d.sensors if s.state not in held) or tuple(n for n in d.coordinate_names if n not in held)
    equations = Equations(
        states=tuple(states) + tuple(s for s, _, _ in lags),
        input=raw_input,
        params=tuple(ctx.params),
        assignments=tuple(ctx.assignments),
        derivatives=tuple(derivatives) + tuple(dv for _, dv, _ in lags),
        initial=tuple(i for _, _, i in lags),
        velocity_bound=None if limit is None else ctx.role(limit, "limit"),
        delay=delay,
        sensor_offsets=offsets,
        experiment=model.experiment,
        measured=tuple(measured),
    )
    check_dimensions(model, equations)
    return equations


def _mechanism(ctx, removed=()):
    d = ctx.d
    bodies = []
    for b in d.bodies:
        if b.name in removed:
            continue

        def expr(text, key, b=b):
            return ctx.parse(text, f"bodies.{b.name}.{key}") if text else None

        def vec(texts, key, b=b):
            return tuple(ctx.parse(t, f"bodies.{b.name}.{key}[{i}]") for i, t in enumerate(texts))

        bodies.append((b.kind, expr(b.mass, "mass"), expr(b.inertia, "inertia"), expr(b.rotation, "rotation"),
                       vec(b.position, "position"), vec(b.start, "start"), vec(b.end, "end")))
    gravity = tuple(ctx.parse(t, f"mechanics.gravity[{i}]") for i, t in enumerate(d.gravity))
    kinetic = ctx.parse(d.kinetic, "mechanics.kinetic") if d.kinetic else None
    potential = ctx.parse(d.potential, "mechanics.potential") if d.potential else None
    coords = tuple(ctx.symbols[c.name] for c in d.coordinates)
    return derive(coords, bodies, gravity, kinetic, potential)


def _mechanical(ctx, experiment, drive_out):
    d = ctx.d
    forces = [_generalized_force(ctx, c.name, c.friction, c.force, drive_out) for c in d.coordinates]
    held = set(experiment.held)
    rates = [sp.Float(0.0) if c.name in held else ctx.symbols[f"d{c.name}"] for c in d.coordinates]
    if not held and not experiment.removed:
        mech = _mechanism(ctx)
        if mech.det == 0:
            where = "mechanics.kinetic" if d.kinetic else "bodies"    # the table that wrote the inertias
            fix = ("write a kinetic energy in which every coordinate's rate appears squared"
                   if d.kinetic else "give every coordinate a mass or inertia that moves with it")
            raise PendcError(f"{ctx.where}: {where}: the mass matrix is singular (a coordinate has no inertia of its "
                             f"own: {fix})")
        det = ctx.bind(d.determinant, mech.det)
        accels = [ctx.bind(f"dd{c.name}", num.xreplace(dict(zip(mech.forces, forces))) / det)
                  for c, num in zip(d.coordinates, mech.numerators)]
    else:
        mech = _mechanism(ctx, set(experiment.removed))
        fixed = {}
        for c, dd, dq in zip(d.coordinates, mech.accelerations, mech.rates):
            if c.name in held:
                fixed.update({dd: 0, dq: 0})
        moving = [i for i, c in enumerate(d.coordinates) if c.name not in held]
        eqs = [mech.euler_lagrange[i].xreplace({**fixed, **dict(zip(mech.forces, forces))}) for i in moving]
        unknowns = [mech.accelerations[i] for i in moving]
        if len(unknowns) == 1:
            solved = sp.solve(eqs[0], unknowns[0])
            solution = {unknowns[0]: solved[0]} if solved else {}
        else:
            solution = sp.solve(eqs, unknowns, dict=True)
            solution = solution[0] if solution else {}
        if len(solution) != len(unknowns):
            raise PendcError(f"{ctx.where}: experiments.{experiment.name}: the remaining equations cannot be "
                             f"solved for the accelerations (a coordinate left without inertia)")
        accels = [ctx.bind(f"dd{c.name}", sp.Float(0.0) if c.name in held else solution[mech.accelerations[i]])
                  for i, c in enumerate(d.coordinates)]
    return [v for pair in zip(rates, accels) for v in pair]


def _state_form(ctx, experiment, drive_out):
    d = ctx.d
    held = set(experiment.held)
    held_rates = {d.rate_of(h) for h in held} - {None}
    for s in d.states:
        if s.rate_of and s.force:
            _generalized_force(ctx, s.rate_of, s.friction, s.force, drive_out)
    derivatives = []
    for s in d.states:
        if s.name in held or s.name in held_rates:
            derivatives.append(sp.Float(0.0))
        else:
            derivatives.append(ctx.parse(s.derivative, f"states.{s.name}.derivative"))
    return derivatives, [ctx.symbols[s.name] for s in d.states]


def _initial_value(model, state, values: dict) -> float:
    """A state-equation file's ``initial`` of ``state`` as a number: a number or an expression
    of the constants (at the model's values)."""
    where = f"{model.source or model.definition.name}: states.{state.name}.initial"
    expr = parse_expression(state.initial, {p.name: p for p in values}, where).subs(values)
    if expr.free_symbols or not expr.is_finite or not expr.is_real:
        raise PendcError(f"{where}: must be a finite number or an expression of the constants, got {state.initial!r}")
    return float(expr)


def _working_range(model, decl, period) -> tuple | None:
    """A position's declared ``range``; a periodic one has none (its table is addressed by phase)."""
    if decl.working_range is not None and period is not None:
        where = f"{model.source or model.definition.name}: {decl.name}.range"
        raise PendcError(f"{where}: a periodic position (period {period:g}) takes no range; it holds whole turns")
    return decl.working_range


def build_interface(model) -> PlantInterface:
    """The :class:`PlantInterface` of ``model``: every position and rate (periodicity declared
    or read off the geometry), lag states (internal), the inputs, the sensors and the named
    quantities."""
    d, eq = model.definition, model.equations
    values = {s: sp.Float(v) for s, v in zip(eq.params, model.parameter_vector())}
    bound_on = next((d.catalogue[n].on for n in model.effects if d.catalogue[n].kind == "velocity_limit"), None)
    bound = None if eq.velocity_bound is None else float(eq.velocity_bound.subs(values))
    sensor = {s.state: s for s in d.sensors}
    periods = _periods(model)
    states = []

    def position(c, body, quantity, output=True, initial=0.0):
        period = periods.get(c.name)
        budget = c.budget if c.budget is not None else (sensor[c.name].budget if c.name in sensor else None)
        return StateSpec(c.name, c.unit, c.meaning, body, quantity, period=period,
                         turns=(c.turns or DEFAULT_TURNS) if period is not None else None, budget=budget,
                         output=output, initial=initial, working_range=_working_range(model, c, period))

    if d.form == "mechanical":
        for c in d.coordinates:
            states.append(position(c, c.body, c.quantity))
            states.append(StateSpec(f"d{c.name}", c.rate_unit, c.rate_meaning, c.body, c.rate_quantity,
                                    derivative_of=c.name, velocity_bound=bound if bound_on == c.name else None,
                                    training_rate=c.training_rate))
    else:
        for s in d.states:
            initial = _initial_value(model, s, values)
            if s.rate_of:
                # a converter may read a rate state (a buck's inductor current): half its LSB, as a position's
                budget = s.budget if s.budget is not None else (sensor[s.name].budget if s.name in sensor else None)
                states.append(StateSpec(s.name, s.unit, s.meaning, s.body, s.quantity, derivative_of=s.rate_of,
                                        velocity_bound=bound if bound_on == s.rate_of else None, budget=budget,
                                        training_rate=s.training_rate, output=s.output, initial=initial,
                                        working_range=s.working_range))
            else:
                states.append(position(s, s.body, s.quantity, s.output, initial))
    quantities = d.quantities if d.quantities is not None else _derived_quantities(d, eq)
    meanings = {name: (unit, meaning) for name, unit, meaning in quantities}
    for sym in eq.states[len(states):]:          # lag states: internal, not reported
        unit, meaning = meanings.get(sym.name, ("", sym.name))
        states.append(StateSpec(sym.name, unit, meaning, output=False))
    check_zero_divisors(model, eq, {s.name: s.initial for s in states})
    names = {s.name for s in states}
    return PlantInterface(
        name=d.name, core=d.core, states=tuple(states),
        inputs=tuple(input_spec((i.name, i.unit, i.meaning), model.input_range or (i.lo, i.hi), i.neutral) for i in d.inputs),
        sensors=tuple(s.spec(d.body_of(s.state)) for s in d.sensors),
        quantities=tuple(QuantitySpec(n, u, m) for n, u, m in quantities if n not in names))


def _periods(model) -> dict:
    """Position -> period (a float) for the periodic positions."""
    d = model.definition
    out = {}
    if d.form == "mechanical":
        read = dict(_mechanism(_Context(model)).periods)
        for c in d.coordinates:
            if c.period == "none":
                continue
            period = c.period if c.period is not None else read.get(c.name)
            if period is not None:
                out[c.name] = float(period)
    else:
        out = {s.name: float(s.period) for s in d.states if s.period is not None}
    return out


def _derived_quantities(d, eq) -> tuple:
    """Named intermediates the file gave a unit or meaning, then the generalized forces and
    accelerations (when the file has no [quantities] table)."""
    out = [(n, u, m) for n, _, u, m in d.intermediates if u or m]
    bound = {s.name for s, _ in eq.assignments}
    for c in d.coordinates:
        if c.force in bound:
            out.append((c.force, c.force_unit, f"generalized force on {c.name}"))
        if f"dd{c.name}" in bound:
            out.append((f"dd{c.name}", f"{c.rate_unit}/s" if c.rate_unit else "", f"acceleration of {c.name}"))
    return tuple(out)


def mechanism_of(model):
    """The derived :class:`~pendc.model.mechanics.Mechanism` of a mechanical ``model``'s plant
    (everything moving; the equations before any effect's force is put in)."""
    if model.definition.form != "mechanical":
        raise PendcError(f"plant '{model.definition.name}' is given by state equations, not by a mechanism")
    return _mechanism(_Context(model))
