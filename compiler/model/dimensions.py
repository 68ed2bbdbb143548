"""The dimension check of a model's equations, from the units its plant file declares.

Every constant, effect parameter, coordinate, rate and input has a unit; walking the
assignments in order gives each named intermediate its dimension, and then every place that
expects a quantity is checked: an intermediate or quantity with a declared unit, each
generalized force (energy per unit of its coordinate: N on a metre, N*m on a radian), each
acceleration, and each state derivative (the state's unit per second). A unit mistake in a
file is one line naming the expression, before anything is built.
"""

from __future__ import annotations

from .units import DIMENSIONLESS, Dim, check_same, dimension_or_zero, parse_unit, require

ENERGY = "J"
PER_SECOND = "1/s"


def check_dimensions(model, equations) -> None:
    """Raise a one-line :class:`~pendc.errors.PendcError` where ``equations`` (of ``model``)
    add unlike quantities or give a place the wrong unit."""
    d = model.definition
    src = model.source or d.name
    dims: dict[str, Dim] = {}
    for name, p in d.constants.items():
        dims[name] = parse_unit(p.unit, f"{src}: constants.{name}.unit")
    for effect in d.catalogue.values():
        for p in effect.params:
            dims[p.name] = parse_unit(p.unit, f"{src}: catalogue.{effect.name}.params.{p.name}.unit")
    for i in d.inputs:
        dims[i.name] = parse_unit(i.unit, f"{src}: inputs.{i.name}.unit")
    per_second = parse_unit(PER_SECOND, "")
    expected = {}
    for c in d.coordinates:
        unit = parse_unit(c.unit, f"{src}: coordinates.{c.name}.unit")
        rate = parse_unit(c.rate_unit, f"{src}: coordinates.{c.name}.rate.unit") if c.rate_unit else unit * per_second
        dims[c.name], dims[f"d{c.name}"] = unit, rate
        expected[c.force] = (parse_unit(ENERGY, "") / unit, f"the generalized force on {c.name}")
        expected[f"dd{c.name}"] = (rate * per_second, f"the acceleration of {c.name}")
    for s in d.states:
        dims[s.name] = parse_unit(s.unit, f"{src}: states.{s.name}.unit")
    for name, _, unit, _ in d.intermediates:
        if unit:
            expected[name] = (parse_unit(unit, f"{src}: intermediates.{name}.unit"), f"intermediate {name}")
    for name, unit, _ in d.quantities or ():
        if unit and name not in expected:
            expected[name] = (parse_unit(unit, f"{src}: quantities.{name}.unit"), f"quantity {name}")
    _check_energies(d, src, dims)
    first_lag = len(equations.states) - len(equations.initial)
    lags = list(zip(equations.states[first_lag:], equations.derivatives[first_lag:]))
    for state, _ in lags:          # a lag state has the unit of what it lags: declared, or its drive's
        if state.name in expected:
            dims[state.name] = expected[state.name][0]
    keys = {n: f"intermediates.{n}" for n, *_ in d.intermediates}
    keys.update({text: f"catalogue.{e.name}.force ({text})" for e in d.catalogue.values()
                 for role, text in e.roles if role == "name"})
    keys.update({c.force: f"{c.force} (the generalized force on {c.name}, the sum of the forces acting on it)"
                 for c in d.coordinates})
    for sym, expr in equations.assignments:
        where = f"{src}: {keys.get(sym.name, sym.name)}"
        # walked once: a chain of links' accelerations are expressions of tens of kB
        got = dimension_or_zero(expr, dims, where)
        dims[sym.name] = DIMENSIONLESS if got is None else got
        if sym.name in expected:
            want, what = expected[sym.name]
            require(want, got, where, what)
            dims[sym.name] = want          # a zero (no effect yet) has the place's unit, not none
        for state, derivative in lags:
            if state.name not in dims and sym in derivative.free_symbols:
                dims[state.name] = dims[sym.name]
    for state, derivative in lags:
        check_same(dims[state.name] * per_second, derivative, dims, f"{src}: {state.name}", f"d/dt {state.name}")
    if d.form == "state":
        for state, derivative in zip(equations.states, equations.derivatives):
            if state.name in dims:
                check_same(dims[state.name] * per_second, derivative, dims, f"{src}: states.{state.name}.derivative",
                           f"d/dt {state.name}")


def _check_energies(d, src: str, dims: dict) -> None:
    """[mechanics] kinetic and potential are energies: checked as written, so a unit slip there
    is named at its key, not at the acceleration derived from it (round G's ddq1)."""
    import sympy as sp

    from .expressions import parse_expression

    symbols = {name: sp.Symbol(name, real=True) for name in dims}
    energy = parse_unit(ENERGY, "")
    for key in ("kinetic", "potential"):
        text = getattr(d, key, None)
        if not text:
            continue
        where = f"{src}: mechanics.{key}"
        expr = parse_expression(text, symbols, where)
        if expr.free_symbols <= set(symbols.values()):   # intermediates are checked where they are assigned
            check_same(energy, expr, dims, where, f"the {key} energy")
