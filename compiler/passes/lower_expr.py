"""The expression lowerer behind :func:`pendc.passes.lower.lower_model`: sympy expressions to
untyped IR nodes, sharing structurally equal subexpressions, gathering single-variable factors
into tables, non-smooth operations as sign-bit slices, compares and muxes (see that module's
docstring for the rules). Tables of a periodic state, its phase and turn counter are
:mod:`pendc.passes.lower_turns`."""

from __future__ import annotations

import sympy as sp

from ..errors import PendcError
from ..ir.compare_ops import CompareOp
from ..ir.nodes import Kind, SliceParams, make
from ..model.interface import PlantInterface
from .lower_turns import PeriodicTables, is_periodic

_NONSMOOTH = (sp.Abs, sp.sign, sp.Piecewise, sp.Min, sp.Max)
_SYMPY_OPS = {sp.StrictLessThan: CompareOp.LT, sp.LessThan: CompareOp.LE, sp.StrictGreaterThan: CompareOp.GT,
              sp.GreaterThan: CompareOp.GE, sp.Equality: CompareOp.EQ, sp.Unequality: CompareOp.NE}


class ExpressionLowerer(PeriodicTables):
    """Turns sympy expressions into nodes, sharing structurally equal subexpressions."""

    def __init__(self, variables: dict, interface: PlantInterface, turns_phase: bool = False,
                 deep_last: bool = False, narrow_abs: bool = False, lookahead: bool = False):
        self.variables = dict(variables)      # sympy Symbol -> node name
        self.turns_phase = turns_phase        # periodic tables read state/period less whole turns
        self.deep_last = deep_last            # sums add their deepest term last (see term_depth)
        self.narrow_abs = narrow_abs          # |a| of a cast of a, not of a itself (see lower_model)
        self.lookahead = lookahead            # periodic tables are registers read a step ahead
        self.ahead: list = []                 # (register, StateSpec, expression text, meaning) to read ahead
        self.turn_steps: dict = {}            # periodic state -> its turn counter's step (-1, 0, 1)
        self.depth: dict = {}                 # assigned Symbol -> how deep its value lies in the step
        self.nodes: list = []
        self.memo: dict = {}                  # expression -> node name
        self.placeholders: dict = {}          # Dummy -> non-smooth expression it stands for
        self.opaque_of: dict = {}
        self.used_names: set = set(variables.values())
        # periodic states: sympy Symbol -> StateSpec (tables of them are addressed by phase)
        self.periodic = {sym: spec for spec in interface.periodic for sym in variables if sym.name == spec.name}

    def fresh(self, hint: str) -> str:
        base = "".join(c if c.isalnum() or c == "_" else "_" for c in hint).strip("_") or "n"
        name, i = base, 1
        while name in self.used_names:
            i += 1
            name = f"{base}_{i}"
        self.used_names.add(name)
        return name

    def emit(self, kind, inputs, hint, meaning="", **params) -> str:
        name = self.fresh(hint)
        self.nodes.append(make(name, kind, inputs, meaning=meaning, **params))
        return name

    def const(self, value: float) -> str:
        key = ("const", float(value))
        if key not in self.memo:
            text = repr(float(value)).replace("-", "m").replace(".", "p").replace("+", "")
            self.memo[key] = self.emit(Kind.CONST, [], f"c_{text}", value=float(value))
        return self.memo[key]

    # -- classification -------------------------------------------------------------
    def opaque(self, e):
        """``e`` with every outermost non-smooth subexpression replaced by a placeholder symbol."""
        if isinstance(e, _NONSMOOTH):
            if e not in self.opaque_of:
                arg = e.args[0] if len(e.args) == 1 else None
                label = {sp.Abs: "abs", sp.sign: "sgn"}.get(type(e), "pw")
                if arg is not None and arg.is_Symbol:
                    label += f"_{arg.name}"
                d = sp.Dummy(label, real=True)
                self.opaque_of[e] = d
                self.placeholders[d] = e
            return self.opaque_of[e]
        if not e.args:
            return e
        return e.func(*[self.opaque(a) for a in e.args])

    @staticmethod
    def smooth_single(factor):
        """The variable of a factor that is a non-polynomial smooth function of one variable, else None."""
        free = factor.free_symbols
        if len(free) == 1:
            (v,) = free
            if not factor.is_polynomial(v):
                return v
        return None

    # -- lowering ----------------------------------------------------------------------
    def value(self, e, hint: str = "t", meaning: str = "") -> str:
        e = sp.sympify(e)
        if e in self.memo:
            return self.memo[e]
        name = self._value(e, hint, meaning)
        self.memo[e] = name
        return name

    def _value(self, e, hint, meaning):
        if e.is_Number:
            return self.const(float(e))
        if e in self.variables:
            return self.variables[e]
        if e in self.placeholders:
            return self.value(self.placeholders[e], hint)
        if isinstance(e, sp.Piecewise):
            return self.piecewise(e.args, hint, meaning)
        if isinstance(e, (sp.Min, sp.Max)):
            a, rest = e.args[0], e.func(*e.args[1:]) if len(e.args) > 2 else e.args[1]
            na, nb = self.value(a), self.value(rest)
            op = CompareOp.LT if isinstance(e, sp.Min) else CompareOp.GT
            sel = self.emit(Kind.COMPARE, [na, nb], f"{hint}_sel", op=op)
            return self.emit(Kind.MUX, [sel, nb, na], hint, meaning)
        if isinstance(e, sp.Abs):
            a = self.value(e.args[0], f"{hint}_arg")
            if self.narrow_abs:     # round once, then negate and select in the narrow format
                a = self.value_key(("abs_arg", a), lambda: self.emit(Kind.CAST, [a], f"{a}_for_abs"))
            return self.emit(Kind.MUX, [self.sign_bit(a), a, self.negated(a)], f"abs_{a}", meaning or f"|{a}|")
        if isinstance(e, sp.sign):
            return self.times_sign(self.const(1.0), e.args[0], hint)
        return self.sum_of_terms(self.differences_named(self.opaque(e)), hint, meaning)

    def times_sign(self, y: str, arg, hint: str) -> str:
        """y * sgn(arg) with sgn(0) = 0: sign-bit slice, negate and two muxes."""
        a = self.value(arg)
        zero = self.value_key(("iszero", a), lambda: self.emit(Kind.COMPARE, [a, self.const(0.0)],
                                                                   f"{a}_is_zero", op=CompareOp.EQ))
        signed = self.emit(Kind.MUX, [self.sign_bit(a), y, self.negated(y)], f"{hint}_signed")
        return self.emit(Kind.MUX, [zero, signed, self.const(0.0)], hint, f"{y} * sgn({a})")

    def sign_bit(self, a: str) -> str:
        return self.value_key(("signbit", a), lambda: self.emit(Kind.SLICE, [a], f"{a}_sign",
                                                                     params=SliceParams.sign()))

    def negated(self, a: str) -> str:
        return self.value_key(("neg", a), lambda: self.emit(Kind.NEG, [a], f"{a}_neg"))

    def value_key(self, key, build):
        if key not in self.memo:
            self.memo[key] = build()
        return self.memo[key]

    def condition(self, c) -> str:
        if c is sp.true:
            return self.const(1.0)
        if isinstance(c, sp.core.relational.Relational):
            lhs, rhs = c.lhs, c.rhs
            op = _SYMPY_OPS[type(c)]
            # |a| > 0 is a != 0: one comparator instead of abs + compare
            if isinstance(lhs, sp.Abs) and rhs == 0 and op is CompareOp.GT:
                return self.emit(Kind.COMPARE, [self.value(lhs.args[0]), self.const(0.0)], "moving",
                                 op=CompareOp.NE)
            return self.emit(Kind.COMPARE, [self.value(lhs), self.value(rhs)], "cond", op=op)
        raise PendcError(f"cannot lower condition {c}")

    def piecewise(self, args, hint, meaning) -> str:
        (expr, cond), rest = args[0], args[1:]
        if cond is sp.true or not rest:
            return self.value(expr, hint)
        otherwise = self.piecewise(rest, f"{hint}_else", "")
        sel = self.condition(cond)
        return self.emit(Kind.MUX, [sel, otherwise, self.value(expr, f"{hint}_then")], hint, meaning)

    def table(self, expr, var, hint: str) -> str:
        """A LUT node for ``expr`` (a smooth function of ``var``)."""
        v = sp.Symbol("v", real=True)
        spec = self.periodic.get(var)
        if spec is not None and is_periodic(expr, var, spec.period):
            return self.periodic_table(expr, var, spec, hint)
        source = self.value(self.placeholders.get(var, var))
        text = sp.sstr(expr.subs(var, v))
        return self.value_key(("lut", source, text), lambda: self.emit(
            Kind.LUT, [source], f"{hint}_lut", f"{sp.sstr(expr.subs(var, sp.Symbol(source)))}", expr=text,
            lo=None, hi=None, periodic=False, addr_bits=10, interpolate=True))

    def sum_of_terms(self, e, hint, meaning) -> str:
        groups: dict = {}
        for term in sp.Add.make_args(sp.expand(e)):
            coeff, factors = term.as_coeff_mul(rational=False)
            table_factors, rest = [], []
            for f in factors:
                if f.is_number:     # sqrt(2) of sqrt(2*g*h): sympy keeps it apart from the Float
                    coeff *= f
                    continue
                (table_factors if self.smooth_single(f) is not None else rest).append(f)
            for f in list(rest):
                if len(f.free_symbols) > 1 and not f.is_polynomial(*f.free_symbols):
                    rest.remove(f)
                    table_factors.append(self.of_computed_argument(f, hint))
            variables = sorted({self.smooth_single(f) for f in table_factors}, key=sp.default_sort_key)
            if len(variables) > 1:
                # a product of functions of several variables (cos(q1)*sin(q2) in a chain of
                # links): the first variable's factors join the summed table, every other
                # variable's factors are one table of their own, a factor of the product
                tabled = [f for f in table_factors if self.smooth_single(f) == variables[0]]
                rest += [self.function_factor(sp.Mul(*[f for f in table_factors if self.smooth_single(f) == v]))
                         for v in variables[1:]]
                table_factors = tabled
            key = (variables[0] if variables else None, sp.Mul(*rest))
            groups[key] = groups.get(key, sp.Integer(0)) + coeff * sp.Mul(*table_factors)
        # a constant coefficient is a function of any variable: fold it into the one table
        # that multiplies the same factors, so c*sgn(dx) + T(|dx|)*sgn(dx) is one table
        for var, rest in list(groups):
            tables = [k for k in groups if k[1] == rest and k[0] is not None]
            if var is None and len(tables) == 1:
                groups[tables[0]] += groups.pop((None, rest))
        acc = None
        keys = list(groups)
        if self.deep_last:      # the term that is ready last joins the sum last: one adder after it
            keys.sort(key=lambda k: self.term_depth(*k))
        for i, (var, rest) in enumerate(keys):
            coeff = groups[(var, rest)]
            part_hint = f"{hint}_{_slug(rest)}" if rest != 1 else f"{hint}_0"
            negative = False
            if var is not None:
                table = self.table(coeff, var, part_hint)
                part = table if rest == 1 else self.product(self._factors(rest), part_hint, table=table)
            elif rest == 1:
                part = self.const(float(coeff))
            else:
                negative = float(coeff) < 0
                part = self.product(self._factors(rest), part_hint, gain=abs(float(coeff)))
            name_hint, m = (hint, meaning) if i == len(keys) - 1 else (f"{hint}_acc", "")
            if acc is None:
                acc = self.emit(Kind.NEG, [part], name_hint, m) if negative else part
            else:
                acc = self.emit(Kind.SUB if negative else Kind.ADD, [acc, part], name_hint, m)
        return acc if acc is not None else self.const(0.0)

    def differences_named(self, e):
        """``e`` with each linear combination of several variables that is the whole argument of a
        smooth function (up to that combination: a flow through a pipe, (h1 - h3) /
        ((h1 - h3)^2 + eps^2)^(1/4)) replaced by a placeholder, computed once: expanding would
        square h1 and h3 apart and the function would be a table of a difference of products,
        steep and cancelling, instead of a table of the difference. Periodic angles are left
        alone (their tables are addressed by phase)."""
        for f in sp.preorder_traversal(e):
            if not ((isinstance(f, sp.Pow) and f.exp.is_number and not f.exp.is_integer)
                    or (isinstance(f, sp.Function) and len(f.args) == 1)) or len(f.free_symbols) < 2:
                continue
            arg = f.base if isinstance(f, sp.Pow) else f.args[0]
            for c in sp.preorder_traversal(arg):
                # not of periodic angles: cos(q1 - q2) stays a product of tables addressed by phase
                if (isinstance(c, sp.Add) and len(c.free_symbols) >= 2 and c.is_polynomial(*c.free_symbols)
                        and not any(v in self.periodic for v in c.free_symbols)
                        and sp.Poly(c, *c.free_symbols).total_degree() == 1):
                    d = self.opaque_of.get(c) or sp.Dummy("diff", real=True)
                    if arg.subs(c, d).free_symbols == {d}:      # registered only when it is used
                        self.opaque_of[c] = d
                        self.placeholders[d] = c
                        return self.differences_named(e.subs(c, d))
        return e

    def of_computed_argument(self, f, hint: str):
        """``f``, a smooth function of one argument that depends on several variables (a flow
        through a pipe, ((h1 - h3)^2 + eps^2)^(-1/4)), as the same function of a placeholder for
        that argument: the argument is computed (sums and products), the function is a table of
        it. A function of several arguments, or a power with a variable exponent, is an error."""
        if isinstance(f, sp.Pow) and f.exp.is_number:
            inner, rebuild = f.base, (lambda d: d ** f.exp)
        elif isinstance(f, sp.Function) and len(f.args) == 1:
            inner, rebuild = f.args[0], f.func
        else:
            raise PendcError(f"cannot lower {f} (in {hint}): a smooth function of several variables "
                             f"({', '.join(sorted(map(str, f.free_symbols)))}) that is not a function of "
                             "one computed argument; tables take one")
        if inner not in self.opaque_of:
            d = sp.Dummy(f"arg_{hint}", real=True)
            self.opaque_of[inner] = d
            self.placeholders[d] = inner
        return rebuild(self.opaque_of[inner])

    def function_factor(self, f):
        """A placeholder symbol standing for ``f``, a smooth function of one variable that is a
        factor of a product (lowered as its own table when the product is)."""
        if f not in self.opaque_of:
            d = sp.Dummy(f"fn_{self.smooth_single(f)}", real=True)
            self.opaque_of[f] = d
            self.placeholders[d] = f
        return self.opaque_of[f]

    def expr_depth(self, e) -> int:
        """A rank of how late ``e``'s value is ready in a step: states and the input 0, an
        assigned symbol one more than its expression, a non-smooth operation (a table of
        ``|dx|``, compares and muxes) two more than its argument."""
        def symbol(s) -> int:
            if s in self.placeholders:
                return 2 + self.expr_depth(self.placeholders[s])
            return self.depth.get(s, 0)
        deepest = max((symbol(s) for s in e.free_symbols), default=0)
        return deepest + (2 if e.has(*_NONSMOOTH) else 0)

    def term_depth(self, var, rest) -> int:
        """:meth:`expr_depth` of a term of :meth:`sum_of_terms` (table variable ``var`` times ``rest``),
        one more for the table read and one more for a product."""
        tabled = var is not None
        base = max(self.expr_depth(rest), self.expr_depth(var) if tabled else 0)
        return base + tabled + (rest != 1)

    def _factors(self, rest):
        out = []
        for f in sp.Mul.make_args(rest):
            base, exp = f.as_base_exp()
            if exp.is_Integer and exp > 0:
                out += [base] * int(exp)
            else:
                raise PendcError(f"cannot lower factor {self.placeholders.get(f, f)} (no dividers in hardware)")
        return out

    def product(self, factors, hint, gain: float = 1.0, table: str | None = None) -> str:
        """Multiply factors; variables first (so a rate's square is shared), then the table, then the
        constant; sign factors become muxes, not multipliers."""
        signs = [f for f in factors if isinstance(self.placeholders.get(f), sp.sign)]
        plain = sorted((f for f in factors if f not in signs), key=sp.default_sort_key)
        acc = None
        for i, f in enumerate(plain):
            node = self.value(f, hint)
            if acc is None:
                acc = node
            else:
                key = ("prod", sp.Mul(*plain[: i + 1]))
                acc = self.value_key(key, lambda a=acc, n=node: self.emit(
                    Kind.MUL, [a, n], f"{hint}_prod"))
        if table is not None:
            acc = table if acc is None else self.emit(Kind.MUL, [acc, table], f"{hint}_term")
        if acc is None:
            acc = self.const(1.0)
        if gain != 1.0:
            acc = self.emit(Kind.GAIN, [acc], f"{hint}_gain", value=gain)
        for s in signs:
            acc = self.times_sign(acc, self.placeholders[s].args[0], f"{hint}_sgn")
        return acc


def _slug(expr) -> str:
    return "_".join(sorted(str(s.name) for s in expr.free_symbols))[:40] or "term"
