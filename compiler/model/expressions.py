"""Expressions in plant files, parsed without running them.

Plant files travel between labs, so the text in them is untrusted. ``sympy.sympify`` and
``parse_expr`` call ``eval`` on their input: a plant file could then run any Python it likes
(``__import__('os').system(...)``). Here the text is read with :mod:`ast` (which only parses),
every node is checked against a whitelist, and the sympy objects are built by hand.

Grammar (Python syntax, a small subset of it)::

    expr      := number | name | pi | (expr) | +expr | -expr
               | expr (+ | - | * | / | ** | ^) expr
               | func(expr, ...) | Piecewise((expr, cond), ..., (expr, True))
               | where(cond, expr, expr)
    cond      := expr (< | <= | > | >=) expr [(< | <= | > | >=) expr ...]
               | cond and cond | cond or cond | not cond | (cond) | True
    func      := sin cos tan asin acos atan atan2 sinh cosh tanh exp log sqrt
                 Abs abs sign sgn Min min Max max floor ceiling

``^`` is power (as in Modelica, Simscape and MATLAB) with the precedence of ``**``, so
``a*b^2`` is ``a*b**2``; like ``**`` it groups to the right. ``1/3`` is the exact rational 1/3.
``where(c, a, b)`` is ``Piecewise((a, c), (b, True))``. ``==`` and ``!=`` are refused: they
compare floating-point values exactly, which a plant model never means.

Limits (an untrusted file must not make the compiler hang or run out of memory): the text is at
most :data:`MAX_TEXT` characters and the syntax tree at most :data:`MAX_DEPTH` levels deep;
numbers (literals and every number sympy folds on the way) are finite with magnitude at most
:data:`MAX_MAGNITUDE`; a numeric exponent is at most :data:`MAX_EXPONENT` in magnitude, so sympy
is never asked to compute ``9**99999`` exactly.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Mapping

import sympy as sp

from ..errors import PendcError

from .expression_syntax import (  # noqa: F401  (the limits and tables are this module's public face)
    CONSTANTS, FUNCTIONS, MAX_DEPTH, MAX_EXPONENT, MAX_MAGNITUDE, MAX_MINMAX_ARGS, MAX_TEXT, _SPECIAL,
    _COMPARE, _NOT_FINITE, _Source, _parse, _short)


def _number(value, where: str) -> sp.Expr:
    """A TOML or literal number as sympy, within the limits."""
    if isinstance(value, float) and not math.isfinite(value):
        raise PendcError(f"{where}: number {value} is not finite")
    if abs(value) > MAX_MAGNITUDE:
        raise PendcError(f"{where}: number {_short(repr(value))} is out of range "
                         f"(magnitude above {MAX_MAGNITUDE:g})")
    return sp.Integer(value) if isinstance(value, int) else sp.Float(value)


class _Builder:
    """Builds sympy from a validated tree; knows which positions take conditions."""

    def __init__(self, src: _Source, symbols):
        self.src = src
        self.names = dict(CONSTANTS)
        for name, value in symbols.items():
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                value = _number(value, src.where)
            if not isinstance(value, sp.Basic):
                raise TypeError(f"symbols[{name!r}] must be a sympy expression, got {value!r}")
            self.names[name] = value

    def value(self, node: ast.AST) -> sp.Expr:
        result = self._value(node)
        self._check(result, node)
        return result

    def _check(self, result, node: ast.AST) -> None:
        """Refuse a non-finite, complex or out-of-range number as soon as sympy folds one."""
        if result.has(*_NOT_FINITE):
            raise self.src.error("the value is not finite (a division by zero?)", node)
        if isinstance(result, sp.Rational):
            if abs(result.p) > MAX_MAGNITUDE or result.q > MAX_MAGNITUDE:
                raise self.src.error("number out of range", node)
        elif isinstance(result, sp.Float):
            if abs(result) > MAX_MAGNITUDE:
                raise self.src.error("number out of range", node)
        elif result.is_number:
            # A constant sympy keeps symbolic (exp(exp(100)), 10**(300*pi)) must stay in range
            # too: floor or ceiling of it would make sympy compute its integer part exactly.
            value = result.evalf(15)
            if value.has(sp.I) or result.is_extended_real is False:
                raise self.src.error(f"the value {_short(sp.sstr(result))} is not real", node)
            if value.has(*_NOT_FINITE) or (value.is_Float and abs(value) > MAX_MAGNITUDE):
                raise self.src.error("number out of range", node)

    def _value(self, node: ast.AST) -> sp.Expr:
        src = self.src
        if isinstance(node, ast.Constant):
            if node.value is True:
                raise src.error("True is only allowed as a condition", node)
            if node.value == math.inf:      # how Python reads a float literal such as 1e400
                raise src.error(f"number is out of range (magnitude above {MAX_MAGNITUDE:g})",
                                node)
            return _number(node.value, src.where)
        if isinstance(node, ast.Name):
            return self._name(node)
        if isinstance(node, ast.UnaryOp):
            if isinstance(node.op, ast.Not):
                raise src.error("a condition is only allowed inside Piecewise or where", node)
            operand = self.value(node.operand)
            return -operand if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp):
            left, right = self.value(node.left), self.value(node.right)
            if isinstance(node.op, ast.Add):
                return left + right
            if isinstance(node.op, ast.Sub):
                return left - right
            if isinstance(node.op, ast.Mult):
                return left * right
            if isinstance(node.op, ast.Div):
                if right.is_zero:
                    raise src.error("division by zero", node)
                return left / right
            return self._power(left, right, node)
        if isinstance(node, (ast.Compare, ast.BoolOp)):
            raise src.error("a condition is only allowed inside Piecewise or where", node)
        if isinstance(node, ast.Tuple):
            raise src.error("a tuple (value, condition) is only allowed in Piecewise", node)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            return self._call(node)
        raise src.error(f"{type(node).__name__} is not allowed", node)   # _validate stops these

    def _name(self, node: ast.Name) -> sp.Expr:
        if node.id in self.names:
            return self.names[node.id]
        if node.id in FUNCTIONS or node.id in _SPECIAL:
            raise self.src.error(f"{node.id!r} is a function; call it like {node.id}(x)", node)
        known = sorted(self.names, key=str.lower)
        listed = ", ".join(known[:10]) + (f", ... ({len(known) - 10} more)"
                                          if len(known) > 10 else "")
        raise self.src.error(f"unknown name {_short(node.id)!r} (allowed: {listed})", node)

    def _power(self, base, exponent, node: ast.AST) -> sp.Expr:
        if exponent.is_Number:
            if abs(exponent) > MAX_EXPONENT:
                raise self.src.error(f"exponent {_short(sp.sstr(exponent))} is too large "
                                     f"(limit {MAX_EXPONENT})", node)
            if base.is_Number:
                if base.is_zero and exponent.is_negative:
                    raise self.src.error("division by zero (0 to a negative power)", node)
                if not base.is_zero:
                    # Estimate the size before sympy computes the power exactly.
                    digits = abs(float(exponent)) * abs(_log10(abs(base)))
                    if digits > math.log10(MAX_MAGNITUDE):
                        raise self.src.error("number out of range", node)
        return sp.Pow(base, exponent)

    def _call(self, node: ast.Call) -> sp.Expr:
        name, args = node.func.id, node.args
        if name == "Piecewise":
            return self._piecewise(node)
        if name == "where":
            if len(args) != 3:
                raise self.src.error(f"where takes 3 arguments (condition, value if true, "
                                     f"value otherwise), got {len(args)}", node)
            return sp.Piecewise((self.value(args[1]), self.condition(args[0])),
                                (self.value(args[2]), sp.true))
        function, low, high = FUNCTIONS[name]
        if len(args) < low or (high is not None and len(args) > high):
            wanted = (f"{low}" if low == high else f"at least {low}")
            raise self.src.error(f"{name} takes {wanted} argument{'s' * (wanted != '1')}, "
                                 f"got {len(args)}", node)
        return function(*[self.value(arg) for arg in args])

    def _piecewise(self, node: ast.Call) -> sp.Expr:
        src, pairs = self.src, []
        if not node.args:
            raise src.error("Piecewise needs (value, condition) pairs", node)
        for arg in node.args:
            if not isinstance(arg, ast.Tuple) or len(arg.elts) != 2:
                raise src.error("each Piecewise argument is a pair (value, condition)", arg)
            pairs.append((self.value(arg.elts[0]), self.condition(arg.elts[1])))
        last = node.args[-1].elts[1]
        if not (isinstance(last, ast.Constant) and last.value is True):
            raise src.error("the last Piecewise pair must have the condition True "
                            "(the value otherwise)", node)
        return sp.Piecewise(*pairs)

    def condition(self, node: ast.AST):
        """A sympy boolean from a comparison, and/or/not, or the literal True."""
        src = self.src
        if isinstance(node, ast.Constant) and node.value is True:
            return sp.true
        if isinstance(node, ast.Compare):
            left, parts = self.value(node.left), []
            for op, right_node in zip(node.ops, node.comparators):
                right = self.value(right_node)
                parts.append(_COMPARE[type(op)](left, right))
                left = right
            return sp.And(*parts)
        if isinstance(node, ast.BoolOp):
            combine = sp.And if isinstance(node.op, ast.And) else sp.Or
            return combine(*[self.condition(value) for value in node.values])
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
            return sp.Not(self.condition(node.operand))
        raise src.error("expected a condition (a comparison such as x > 0)", node)


def _log10(number) -> float:
    """log10 of a positive sympy number, exact enough for big rationals (no float overflow)."""
    if isinstance(number, sp.Rational):
        return math.log10(number.p) - math.log10(number.q)
    return math.log10(float(number))


def parse_expression(text: str | int | float, symbols: Mapping[str, sp.Basic],
                     where: str) -> sp.Expr:
    """The sympy expression ``text`` denotes, built without evaluating any code.

    ``text`` is an expression string in the grammar of the module docstring, or a TOML number
    (int or float, not bool) taken as that number. ``symbols`` maps each allowed bare name to
    the sympy object it stands for (``pi`` is sp.pi unless ``symbols`` names it). Any problem
    raises a one-line :class:`PendcError` starting with ``where``.
    """
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        return _number(text, where)
    src, tree = _parse(text, where)
    builder = _Builder(src, symbols)      # outside the try: a bad ``symbols`` is a bug, not input
    try:
        return builder.value(tree.body)
    except PendcError:
        raise
    except (TypeError, ValueError, ArithmeticError, RecursionError) as exc:
        # sympy refusing something (e.g. comparing a non-real value); keep it to one line.
        detail = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        raise PendcError(f"{where}: sympy cannot build the expression "
                         f"({_short(detail, 100)})") from None


def parse_vector(value: list, symbols: Mapping[str, sp.Basic],
                 where: str) -> tuple[sp.Expr, ...]:
    """Each element of ``value`` (a TOML list of expression strings or numbers) parsed by
    :func:`parse_expression`; element ``i`` is named ``f"{where}[{i}]"`` in errors."""
    if not isinstance(value, (list, tuple)):
        raise PendcError(f"{where}: expected a list of expressions, got {type(value).__name__}")
    return tuple(parse_expression(item, symbols, f"{where}[{i}]") for i, item in enumerate(value))


def free_names(text: str | int | float, where: str) -> set[str]:
    """The bare names ``text`` uses (not the functions it calls), checked as safely as by
    :func:`parse_expression` but without resolving them; ``pi`` is included when used (it is
    in :data:`CONSTANTS`). A TOML number uses no names."""
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        return set()
    _, tree = _parse(text, where)
    called = {id(node.func) for node in ast.walk(tree) if isinstance(node, ast.Call)}
    return {node.id for node in ast.walk(tree)
            if isinstance(node, ast.Name) and id(node) not in called}
