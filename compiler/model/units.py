"""Units of plant-file parameters and a dimension check of the plant's expressions.

A plant file gives every parameter a unit ("kg", "N*m*s/rad", "V*s/rad"); :func:`dimension_of`
then checks that the dynamics add only like quantities, take sin/exp/log of dimensionless ones,
and give the quantity each place expects. A unit error is the cheapest bug to catch and the
hardest to see in a simulation that merely looks wrong.

Unit names resolve through :mod:`sympy.physics.units` to SI base dimensions; the unit string is
read with :mod:`ast` and never evaluated (plant files travel between labs). Grammar: unit names
combined with ``*``, ``/``, ``^`` or ``**`` (integer or fractional powers such as ``^(1/2)`` or
``^0.5``) and parentheses; ``1`` as a factor (``1/s``); ``-``, ``1`` or an empty string mean
dimensionless; ``%`` is percent; ``°`` is deg. Names follow SI symbols as sympy resolves them,
so ``T`` is the tesla, ``F`` the farad, ``C`` the coulomb, ``S`` the siemens.

A :class:`Dim` carries no scale, so only coherent SI units are accepted: "mm" or "g" would
silently be read as m or kg. Angles are dimensionless (rad/s is 1/s); deg, rev, rpm and % are
accepted for their dimension only, and their scale (pi/180, 2*pi, 2*pi/60, 1/100) is the
caller's to apply to the value.
"""

from __future__ import annotations

import ast
import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction

import sympy as sp

from ..atomic import write_atomic
from ..codegen import cache_dir
from ..errors import PendcError
from .interface import DIMENSIONLESS_SPELLINGS

# Written form of each SI base dimension (sympy's names), in the order __str__ prints them.
BASE_UNITS = {"mass": "kg", "length": "m", "time": "s", "current": "A", "temperature": "K",
              "amount_of_substance": "mol", "luminous_intensity": "cd"}

# Unit name -> sympy quantities and powers. sympy has no rev or rpm (both angles per time).
_UNIT_SOURCES = {
    "m": "meter", "kg": "kilogram", "s": "second", "A": "ampere", "K": "kelvin",
    "mol": "mole", "cd": "candela", "N": "newton", "J": "joule", "W": "watt", "V": "volt",
    # Python folds the ohm sign U+2126 into Greek capital omega in names; both are listed.
    "ohm": "ohm", "Ohm": "ohm", "Ω": "ohm", "\u2126": "ohm", "F": "farad", "H": "henry",
    "C": "coulomb", "Pa": "pascal", "Hz": "hertz", "T": "tesla", "Wb": "weber",
    "S": "siemens", "rad": "radian", "deg": "degree", "rev": "radian",
    "rpm": (("radian", 1), ("minute", -1)), "percent": "percent",
}
_MAX_TEXT = 200        # a unit is a few symbols; a long one is a mistake, not a unit


@dataclass(frozen=True)
class Dim:
    """A physical dimension: SI base dimensions with rational exponents.

    ``exponents`` is a sorted tuple of (base dimension name, Fraction), without zeros; build
    one with :meth:`of` or :func:`parse_unit`. Supports ``*``, ``/``, ``**`` (int or
    Fraction), ``==`` and hashing.
    """

    exponents: tuple[tuple[str, Fraction], ...] = ()

    @classmethod
    def of(cls, mapping) -> "Dim":
        """The Dim with ``mapping`` (base name -> int or Fraction) as exponents."""
        for name in mapping:
            if name not in BASE_UNITS:
                raise ValueError(f"unknown base dimension {name!r}")
        return cls(tuple(sorted((name, Fraction(power)) for name, power in mapping.items()
                                if power != 0)))

    @property
    def dimensionless(self) -> bool:
        """True for a pure number (angles included)."""
        return not self.exponents

    def __mul__(self, other: "Dim") -> "Dim":
        if not isinstance(other, Dim):
            return NotImplemented
        merged = dict(self.exponents)
        for name, power in other.exponents:
            merged[name] = merged.get(name, 0) + power
        return Dim.of(merged)

    def __truediv__(self, other: "Dim") -> "Dim":
        if not isinstance(other, Dim):
            return NotImplemented
        return self * other ** -1

    def __pow__(self, power) -> "Dim":
        if isinstance(power, bool) or not isinstance(power, (int, Fraction)):
            raise TypeError(f"a Dim is raised to an int or Fraction, not {power!r}")
        return Dim.of({name: exp * power for name, exp in self.exponents})

    def __str__(self) -> str:
        def part(name, power):
            power = abs(power)
            text = BASE_UNITS[name]
            if power == 1:
                return text
            return f"{text}^{power}" if power.denominator == 1 else f"{text}^({power})"
        order = list(BASE_UNITS)
        ranked = sorted(self.exponents, key=lambda item: order.index(item[0]))
        top = "*".join(part(n, p) for n, p in ranked if p > 0) or "1"
        bottom = [part(n, p) for n, p in ranked if p < 0]
        if not bottom:
            return top
        return f"{top}/{bottom[0]}" if len(bottom) == 1 else f"{top}/({'*'.join(bottom)})"

    def __repr__(self) -> str:
        return f"Dim({str(self)!r})"


DIMENSIONLESS = Dim()


def _sympy_dim(quantity_name: str) -> Dim:
    """The Dim of a sympy quantity, by its SI dimensional dependencies."""
    import sympy.physics.units as spu
    from sympy.physics.units.systems.si import SI, dimsys_SI
    quantity = getattr(spu, quantity_name)
    deps = dimsys_SI.get_dimensional_dependencies(SI.get_quantity_dimension(quantity))
    # Keys are Dimension objects whose printed form varies (Dimension(length, L) vs
    # Dimension(length)); their .name is the stable base name.
    return Dim.of({str(dim.name): Fraction(int(p.p), int(p.q)) if isinstance(p, sp.Rational)
                   else Fraction(p) for dim, p in deps.items()})


def _resolve(source) -> Dim:
    if isinstance(source, str):
        return _sympy_dim(source)
    result = DIMENSIONLESS
    for name, power in source:
        result = result * _sympy_dim(name) ** power
    return result


def unit_table(folder=None) -> dict:
    """Unit name -> Dim, each resolved through sympy.physics.units, and kept in pendc's cache
    folder (``folder``: another) under the sympy version and the sources it resolves: importing
    sympy.physics.units took every process that reads a plant file 0.2-0.3 s of its start."""
    made_from = repr((sp.__version__, sorted(_UNIT_SOURCES.items()), list(BASE_UNITS))).encode()
    path = (folder or cache_dir("units")) / f"units-{hashlib.sha256(made_from).hexdigest()[:16]}.json"
    try:
        kept = json.loads(path.read_text(encoding="utf-8"))
        table = {name: Dim.of({b: Fraction(p) for b, p in exponents}) for name, exponents in kept.items()}
        if set(table) == set(_UNIT_SOURCES):
            return table
    except (OSError, ValueError, TypeError, AttributeError, ZeroDivisionError):
        pass                                  # not made yet, or not readable: resolved again
    table = {name: _resolve(source) for name, source in _UNIT_SOURCES.items()}
    try:
        write_atomic(path, json.dumps({name: [[b, str(p)] for b, p in d.exponents] for name, d in table.items()},
                                      ensure_ascii=False))
    except PendcError:
        pass                                  # a folder not writable: resolved again next time
    return table


UNITS = unit_table()


def parse_unit(text: str, where: str) -> Dim:
    """The dimension of unit string ``text`` ("N*m*s/rad", "kg*m^2", "1/s", "-"), or a
    one-line :class:`PendcError` starting with ``where``."""
    if not isinstance(text, str):
        raise PendcError(f"{where}: a unit is a string such as \"kg*m^2\", "
                         f"got {type(text).__name__}")
    stripped = text.strip()
    if stripped in DIMENSIONLESS_SPELLINGS:
        return DIMENSIONLESS
    if len(stripped) > _MAX_TEXT:
        raise PendcError(f"{where}: unit is {len(stripped)} characters long; "
                         f"the limit is {_MAX_TEXT}")
    # '^' would otherwise bind looser than '/' in Python ("m/s^2" as (m/s)^2).
    python = stripped.replace("^", "**").replace("%", " percent ").replace("°", " deg ").strip()
    try:
        tree = ast.parse(python, mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        raise PendcError(f"{where}: cannot read unit {_quote(stripped)} "
                         f"(write e.g. \"N*m*s/rad\", \"kg*m^2\", \"1/s\")") from None
    return _unit(tree.body, stripped, where)


def _quote(text) -> str:
    text = " ".join(str(text).split())
    return repr(text if len(text) <= 40 else text[:37] + "...")


def _unit(node: ast.AST, text: str, where: str) -> Dim:
    if isinstance(node, ast.Name):
        if node.id not in UNITS:
            known = ", ".join(k for k in UNITS if k.isascii() and k != "percent")
            raise PendcError(f"{where}: unknown unit {_quote(node.id)} in {_quote(text)} "
                             f"(known: {known}, %; no prefixed units such as mm or kN)")
        return UNITS[node.id]
    if isinstance(node, ast.Constant) and node.value == 1 and type(node.value) is int:
        return DIMENSIONLESS
    if isinstance(node, ast.BinOp):
        if isinstance(node.op, ast.Mult):
            return _unit(node.left, text, where) * _unit(node.right, text, where)
        if isinstance(node.op, ast.Div):
            return _unit(node.left, text, where) / _unit(node.right, text, where)
        if isinstance(node.op, ast.Pow):
            return _unit(node.left, text, where) ** _power(node.right, text, where)
    raise PendcError(f"{where}: cannot read unit {_quote(text)}: only unit names, *, /, ^ "
                     f"and numeric powers are allowed")


def _power(node: ast.AST, text: str, where: str) -> Fraction:
    """An exponent: an int, a float like 0.5, a quotient like (1/2), with a sign."""
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        value = _power(node.operand, text, where)
        return -value if isinstance(node.op, ast.USub) else value
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div):
        denominator = _power(node.right, text, where)
        if denominator != 0:
            return _power(node.left, text, where) / denominator
    if (isinstance(node, ast.Constant) and type(node.value) in (int, float)
            and abs(node.value) <= 100):
        # Fraction(repr) reads 0.5 as 1/2 and 0.1 as 1/10, not as the binary approximation.
        return Fraction(repr(node.value))
    raise PendcError(f"{where}: unit {_quote(text)} has an exponent that is not a small "
                     f"number (write e.g. m^2, s^-1, m^(1/2))")


def _text(expr) -> str:
    return _quote(sp.sstr(expr))[1:-1]


_DIMENSIONLESS_ARG = (sp.sin, sp.cos, sp.tan, sp.asin, sp.acos, sp.atan, sp.sinh, sp.cosh,
                      sp.tanh, sp.exp, sp.log)
_SAME_AS_ARG = (sp.Abs, sp.floor, sp.ceiling)


_NAMED = ("N", "J", "W", "V", "ohm", "F", "H", "C", "Pa", "T", "Wb", "S")


def shown(dim: Dim) -> str:
    """``dim`` as a message prints it: in SI base units, and the derived unit's name where one
    matches (``kg*m^2/(s^3*A) (V)``), or one over or times a second or its square (a state's
    derivative: ``kg*m^2/(s^4*A) (V/s)``), since a user wrote volts, not base units."""
    base = str(dim)
    if not any(sign in base for sign in "*/^"):
        return base                  # m, s, A, 1: already what a user writes
    for form in ("{}", "{}/s", "{}/s^2", "{}*s"):
        for name in _NAMED:
            if parse_unit(form.format(name), "") == dim:
                return f"{base} ({form.format(name)})"
    return base


class _Checker:
    """Works out dimensions; ``None`` stands for a literal zero, which fits any dimension."""

    def __init__(self, dims, where: str):
        self.dims, self.where = dims, where

    def fail(self, reason: str) -> PendcError:
        return PendcError(f"{self.where}: {reason}")

    def same(self, exprs, what: str):
        """The one dimension all ``exprs`` share (None if all are zero), else an error."""
        found = None       # (expr, dim) of the first non-zero one
        for expr in exprs:
            dim = self.dim(expr)
            if dim is None:
                continue
            if found is None:
                found = (expr, dim)
            elif dim != found[1]:
                raise self.fail(f"inconsistent units{what}: '{_text(found[0])}' is {shown(found[1])} "
                                f"but '{_text(expr)}' is {shown(dim)}")
        return None if found is None else found[1]

    def dimensionless(self, expr, context: str) -> None:
        dim = self.dim(expr)
        if dim is not None and not dim.dimensionless:
            raise self.fail(f"{context} must be dimensionless, but '{_text(expr)}' is {dim}")

    def dim(self, expr):
        if isinstance(expr, sp.Number):
            return None if expr.is_zero else DIMENSIONLESS
        if isinstance(expr, (sp.NumberSymbol, sp.core.numbers.ImaginaryUnit)):
            return DIMENSIONLESS
        if isinstance(expr, sp.Symbol) or isinstance(expr, sp.core.function.AppliedUndef):
            # x(t) in a Lagrangian model carries the units of its name, like the symbol x.
            name = expr.name if isinstance(expr, sp.Symbol) else expr.func.__name__
            if name not in self.dims:
                raise self.fail(f"no units known for '{name}'")
            return self.dims[name]
        if isinstance(expr, sp.Add):
            return self.same(expr.args, "")
        if isinstance(expr, sp.Mul):
            result = DIMENSIONLESS
            for factor in expr.args:
                dim = self.dim(factor)
                if dim is None:
                    return None
                result = result * dim
            return result
        if isinstance(expr, sp.Pow):
            return self.power(expr)
        if isinstance(expr, sp.Derivative):
            result = self.dim(expr.expr)
            for variable, count in expr.variable_count:
                result = None if result is None else result / self.dim(variable) ** int(count)
            return result
        if isinstance(expr, _DIMENSIONLESS_ARG):
            self.dimensionless(expr.args[0], f"the argument of {expr.func.__name__}")
            return DIMENSIONLESS
        if isinstance(expr, sp.atan2):
            self.same(expr.args, " in atan2")
            return DIMENSIONLESS
        if isinstance(expr, _SAME_AS_ARG):
            return self.dim(expr.args[0])
        if isinstance(expr, sp.sign):
            self.dim(expr.args[0])
            return DIMENSIONLESS
        if isinstance(expr, (sp.Min, sp.Max)):
            return self.same(expr.args, f" in {expr.func.__name__}")
        if isinstance(expr, sp.Piecewise):
            for _, condition in expr.args:
                self.condition(condition)
            return self.same([value for value, _ in expr.args], " between Piecewise branches")
        if isinstance(expr, (sp.logic.boolalg.Boolean)):
            self.condition(expr)
            return DIMENSIONLESS
        raise self.fail(f"cannot work out the units of '{_text(expr)}'")

    def power(self, expr):
        base, exponent = expr.args
        self.dimensionless(exponent, "an exponent")
        dim = self.dim(base)
        if dim is None or dim.dimensionless:
            return dim
        if isinstance(exponent, sp.Rational):
            return dim ** Fraction(int(exponent.p), int(exponent.q))
        if isinstance(exponent, sp.Float):
            value = Fraction(float(exponent))     # exact: 0.5 is 1/2; 1/3 as a float is not
            if value.denominator <= 1024:
                return dim ** value
        raise self.fail(f"'{_text(expr)}': the exponent must be a rational number "
                        f"when the base has units ('{_text(base)}' is {dim})")

    def condition(self, cond) -> None:
        if isinstance(cond, sp.logic.boolalg.BooleanAtom):
            return
        if isinstance(cond, sp.core.relational.Relational):
            self.same(cond.args, " in a comparison")
            return
        if isinstance(cond, (sp.And, sp.Or, sp.Not)):
            for arg in cond.args:
                self.condition(arg)
            return
        raise self.fail(f"cannot work out the units of condition '{_text(cond)}'")


def _as_sympy(expr):
    """A plain Python number as sympy (never through sympify, which parses strings)."""
    if isinstance(expr, bool) or not isinstance(expr, (int, float)):
        return expr
    return sp.Integer(expr) if isinstance(expr, int) else sp.Float(expr)


def dimension_of(expr: sp.Basic, dims: Mapping[str, Dim], where: str) -> Dim:
    """The dimension of sympy expression ``expr``, given ``dims`` (symbol name -> Dim).

    Sums, Min/Max, Piecewise branches and comparisons need like dimensions (a literal 0 fits
    any); sin, exp, log and friends need dimensionless arguments; a base with units takes only
    a rational exponent. A zero expression is reported dimensionless. Errors are one-line
    :class:`PendcError` starting with ``where``.
    """
    dim = _Checker(dims, where).dim(_as_sympy(expr))
    return DIMENSIONLESS if dim is None else dim


def check_same(expected: Dim, expr: sp.Basic, dims: Mapping[str, Dim], where: str,
               what: str) -> None:
    """Raise "{where}: {what} has units of {got}, expected {expected}" unless ``expr`` has
    dimension ``expected`` (a zero expression fits any)."""
    require(expected, dimension_or_zero(expr, dims, where), where, what)


def dimension_or_zero(expr: sp.Basic, dims: Mapping[str, Dim], where: str) -> Dim | None:
    """:func:`dimension_of`, but None for a zero expression (which fits any dimension)."""
    return _Checker(dims, where).dim(_as_sympy(expr))


def require(expected: Dim, got: Dim | None, where: str, what: str) -> None:
    """:func:`check_same` of a dimension already worked out (None: a zero expression)."""
    if got is not None and got != expected:
        raise PendcError(f"{where}: {what} has units of {shown(got)}, expected {shown(expected)}")
