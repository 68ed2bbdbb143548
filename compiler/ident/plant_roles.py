"""What identification needs to know about a plant, read off its plant file, never by name.

Identification treats every plant alike; the roles its parts play come from what the plant
file declares (``docs/plant_files.md``):

* the **drive**: the catalogue effect of kind ``drive`` the model has; its ``force`` law
  gives the input at which the drive pushes nothing with the plant at rest
  (:func:`drive_offset`, e.g. a servo drive's offset voltage) and how much force a unit of
  input makes there (:func:`drive_gain`);
* the **driven coordinate**: the one the drive acts ``on`` (:func:`driven_coordinate`);
* the experiment that **holds** a coordinate and nothing else (:func:`holding_experiment`);
* an effect that acts only **beyond a threshold** of a position (a force written as
  ``Piecewise((..., Abs(q) > p), (0, True))``, such as end stops): :func:`engagement`.
"""

from __future__ import annotations

from functools import lru_cache

import sympy as sp

from ..model.expressions import free_names, parse_expression


def _drive(model):
    """``(name, declaration)`` of the first drive effect the model has, or None."""
    catalogue = getattr(model, "catalogue", None) or {}
    for name in getattr(model, "effects", {}) or {}:
        decl = catalogue.get(name)
        if decl is not None and decl.kind == "drive":
            return name, decl
    return None


@lru_cache(maxsize=64)
def _parsed(text: str) -> sp.Expr:
    where = "drive law"
    return parse_expression(text, {n: sp.Symbol(n) for n in free_names(text, where)}, where)


def _at_rest(model, expr: sp.Expr) -> sp.Expr:
    """``expr`` with every position and rate of the plant at zero."""
    d = model.definition
    names = set(d.coordinate_names) | {d.rate_of(c) for c in d.coordinate_names if d.rate_of(c)}
    return expr.subs({s: 0 for s in expr.free_symbols if s.name in names})


def _input_of(model, decl) -> str:
    return decl.role("input", model.definition.inputs[0].name)


def drive_offset(model) -> tuple | None:
    """``(value, name)``: the input at which the model's drive law gives no force with the
    plant at rest, and the parameter that holds it ('' when no single parameter does: a law
    without an offset gives 0). None when the model has no drive or its law has no single
    such input."""
    found = _drive(model)
    if found is None:
        return None
    _, decl = found
    expr = _at_rest(model, _parsed(decl.role("force")))
    u = sp.Symbol(_input_of(model, decl))
    try:
        roots = sp.solve(expr, u)
    except (NotImplementedError, TypeError, ValueError):
        return None
    if len(roots) != 1:
        return None
    root = roots[0]
    values = model.parameter_values()
    if isinstance(root, sp.Symbol) and root.name in values:
        return float(values[root.name]), root.name
    number = root.subs({s: values[s.name] for s in root.free_symbols if s.name in values})
    return (float(number), "") if number.is_number else None


def drive_gain(model) -> float | None:
    """The force (in the driven coordinate's force unit) one unit of input adds at rest: the
    derivative of the drive law by its input (a servo drive's gain). None without a drive."""
    found = _drive(model)
    if found is None:
        return None
    _, decl = found
    expr = _at_rest(model, _parsed(decl.role("force")))
    slope = sp.diff(expr, sp.Symbol(_input_of(model, decl)))
    values = model.parameter_values()
    number = slope.subs({s: values[s.name] for s in slope.free_symbols if s.name in values})
    return float(number) if number.is_number else None


def driven_coordinate(model) -> str | None:
    """The coordinate the model's drive acts on (None without a drive)."""
    found = _drive(model)
    return found[1].on if found else None


def holding_experiment(model, coordinate: str) -> str | None:
    """The experiment of the plant file that holds ``coordinate`` and nothing else (removes
    no body), or None."""
    for name, e in model.definition.experiments.items():
        if tuple(e.held) == (coordinate,) and not e.removed:
            return name
    return None


def engagement(model, effect: str) -> tuple | None:
    """``(position, parameter, value)`` when catalogue effect ``effect`` is a force that acts
    only where ``|position| > parameter`` (``Piecewise((..., Abs(q) > p), (0, True))``, e.g.
    stops at the ends of a track); its value is the model's, else the catalogue default.
    None for any other effect."""
    decl = model.catalogue.get(effect)
    if decl is None or decl.role("force") is None or decl.kind == "drive":
        return None
    expr = _parsed(decl.role("force"))
    pieces = [p for p in expr.atoms(sp.Piecewise)]
    if len(pieces) != 1:
        return None
    args = pieces[0].args
    if len(args) != 2 or args[1].expr != 0 or args[1].cond is not sp.true:
        return None
    cond = args[0].cond
    if isinstance(cond, sp.StrictLessThan):
        cond = sp.StrictGreaterThan(cond.rhs, cond.lhs)
    if not isinstance(cond, sp.StrictGreaterThan) or not isinstance(cond.lhs, sp.Abs):
        return None
    position, threshold = cond.lhs.args[0], cond.rhs
    params = {p.name: p.default for p in decl.params}
    if not (isinstance(position, sp.Symbol) and position.name in model.definition.coordinate_names
            and isinstance(threshold, sp.Symbol) and threshold.name in params):
        return None
    value = (getattr(model, "effects", {}) or {}).get(effect, {}).get(threshold.name, params[threshold.name])
    return position.name, threshold.name, float(value)
