"""A constant of value 0 that an equation divides by: a one-line error, not a simulation of infinities.

A constant whose bounds start at 0 may be 0 (an ideal switch's resistance, a point mass's own
inertia), as one whose bounds straddle 0 may. Where the equations divide by such a constant, or
by a determinant it empties, the model has no dynamics worth building: :func:`check_zero_divisors`
names the constant(s) and the equation. Only divisors that contain a zero constant are looked
at, so a model without one costs nothing and a state equation that divides by a state (a
level, a speed) is left to the simulation as before.
"""

from __future__ import annotations

import sympy as sp

from ..errors import PendcError

_LONGEST_DIVISOR = 60   # characters of a divisor quoted in the message; a determinant is longer


def _divisors(expr):
    """Bases of the negative powers in ``expr``, outside a Piecewise: a branch that divides by
    zero may be one the conditions never select, which the simulation and the hardware allow."""
    stack = [expr]
    while stack:
        e = stack.pop()
        if isinstance(e, sp.Piecewise):
            continue
        if e.is_Pow and e.exp.is_negative:
            yield e.base
        stack.extend(e.args)


def check_zero_divisors(model, equations, start: dict) -> None:
    """Raise :class:`PendcError` when an equation of ``model`` divides by zero because a
    constant is 0: identically, or at the start state ``start`` (state name -> value)."""
    values = model.parameter_values()
    constants = model.definition.constants
    zero = {p: sp.Integer(0) for p in equations.params if p.name in constants and values[p.name] == 0}
    if not zero:
        return
    at_start = {p: sp.Float(values[p.name]) for p in equations.params}
    at_start.update({s: sp.Float(start.get(s.name, 0.0)) for s in equations.states})
    neutral = model.definition.inputs[0].neutral
    at_start[equations.input] = sp.Float(0.0 if neutral is None else neutral)
    named = [(sym.name, expr) for sym, expr in equations.assignments]
    named += [(f"d/dt {s.name}", d) for s, d in zip(equations.states, equations.derivatives)]
    for label, expr in named:
        for divisor in _divisors(expr):
            full = equations.inline(divisor)
            culprits = [p for p in zero if p in full.free_symbols]
            if not culprits:
                continue
            if full.xreplace(zero) == 0:
                when = ""
            else:
                number = full.xreplace(at_start)
                if not (number.is_number and number == 0):
                    continue
                when = " at the start state"
            _refuse(model, label, divisor, culprits, values, when)


def _refuse(model, label, divisor, culprits, values, when):
    where = model.source or model.definition.name
    keys = ", ".join(f"plant.{p.name} = {values[p.name]}" for p in culprits)
    text = str(divisor)
    by = text if len(text) <= _LONGEST_DIVISOR else f"{text[:_LONGEST_DIVISOR]}..."
    which = "it a value" if len(culprits) == 1 else "one or more of them a value"
    raise PendcError(f"{where}: {keys}: {label} divides by {by}, which is then 0{when}; "
                     f"give {which} other than 0")
