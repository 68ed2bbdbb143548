"""pendc.model.expressions: plant-file expressions parsed without running them."""

from __future__ import annotations

import builtins
import os

import pytest
import sympy as sp

from pendc.errors import PendcError
from pendc.model.expressions import (CONSTANTS, FUNCTIONS, MAX_DEPTH, MAX_TEXT, free_names,
                                     parse_expression, parse_vector)

NAMES = "x y z theta dx alpha u V_off L k_end b_end x_end a b c"
SYMS = {name: sp.Symbol(name, real=True) for name in NAMES.split()}
x, y, z, theta, dx, alpha, u, V_off, L, k_end, b_end, x_end, a, b, c = SYMS.values()
WHERE = "models/x.toml: effects.drive.force"


def parse(text, symbols=SYMS):
    return parse_expression(text, symbols, WHERE)


@pytest.mark.parametrize("text, expected", [
    ("alpha*(u - V_off)", alpha * (u - V_off)),
    ("-(x - L*sin(theta))", -(x - L * sp.sin(theta))),
    ("3", sp.Integer(3)),
    ("2.5", sp.Float(2.5)),
    ("1e-3", sp.Float(1e-3)),
    ("0x10 + 1_000", sp.Integer(1016)),
    ("1/3", sp.Rational(1, 3)),
    ("pi", sp.pi),
    ("2*pi*x", 2 * sp.pi * x),
    ("+x", x),
    ("-x", -x),
    ("x + y - z", x + y - z),
    ("x*y/z", x * y / z),
    ("x**2", x**2),
    ("(x + y)*z", (x + y) * z),
    ("  x + 1  ", x + 1),
])
def test_builds_the_same_sympy_as_by_hand(text, expected):
    assert parse(text) == expected


@pytest.mark.parametrize("text, expected", [
    ("x^2", x**2),
    ("a*b^2", a * b**2),             # '^' binds like '**', not like Python's xor
    ("x/y^2", x / y**2),
    ("-x^2", -(x**2)),
    ("x^-1", 1 / x),
    ("2^3^2", sp.Integer(512)),      # right-associative, as '**'
    ("(x + y)^(1/2)", sp.sqrt(x + y)),
])
def test_caret_is_power(text, expected):
    assert parse(text) == expected


@pytest.mark.parametrize("name", sorted(FUNCTIONS))
def test_every_function(name):
    function, low, _ = FUNCTIONS[name]
    args = [x, y, z][:low]
    text = f"{name}({', '.join(str(arg) for arg in args)})"
    assert parse(text) == function(*args)


def test_function_aliases_and_variadic_min_max():
    assert parse("abs(x)") == sp.Abs(x)
    assert parse("sgn(x)") == sp.sign(x)
    assert parse("max(x, y, z)") == sp.Max(x, y, z)
    assert parse("Min(x, 0)") == sp.Min(x, 0)


def test_piecewise_and_where():
    text = "Piecewise((-k_end*(x - sign(x)*x_end) - b_end*dx, Abs(x) > x_end), (0, True))"
    expected = sp.Piecewise((-k_end * (x - sp.sign(x) * x_end) - b_end * dx,
                             sp.Abs(x) > x_end), (0, True))
    assert parse(text) == expected
    assert parse("where(x > 0, y, z)") == sp.Piecewise((y, x > 0), (z, True))
    assert parse("Piecewise((1, x < 0), (2, x <= 1), (3, True))") == sp.Piecewise(
        (1, x < 0), (2, x <= 1), (3, True))


def test_conditions():
    assert parse("where(a < x < b, 1, 0)") == sp.Piecewise(
        (1, sp.And(a < x, x < b)), (0, True))
    assert parse("where(a <= x >= b, 1, 0)") == sp.Piecewise(
        (1, sp.And(a <= x, x >= b)), (0, True))
    assert parse("where(x > 0 and y < 0 or not z >= 1, 1, 0)") == sp.Piecewise(
        (1, sp.Or(sp.And(x > 0, y < 0), sp.Not(z >= 1))), (0, True))
    assert parse("where(True, x, y)") == x


def test_symbols_may_map_to_expressions_and_redefine_pi():
    assert parse("2*w", {"w": x + 1}) == 2 * (x + 1)
    assert parse("pi + 1", {"pi": y}) == y + 1
    assert parse("2*p", {"p": 3}) == 6


def test_toml_numbers_are_taken_directly():
    assert parse(3) == sp.Integer(3)
    assert parse(0.25) == sp.Float(0.25)
    for bad in (True, float("inf"), float("nan"), 1e301, None, ["x"]):
        with pytest.raises(PendcError, match=f"^{WHERE}: "):
            parse(bad)


def test_parse_vector():
    assert parse_vector(["x", 2, 0.5, "y^2"], SYMS, "v") == (x, sp.Integer(2), sp.Float(0.5), y**2)
    assert parse_vector([], SYMS, "v") == ()
    with pytest.raises(PendcError, match=r"^v\[1\]: unknown name 'q'"):
        parse_vector(["x", "q"], SYMS, "v")
    with pytest.raises(PendcError, match="^v: expected a list"):
        parse_vector("x", SYMS, "v")


def test_free_names():
    assert free_names("alpha*(u - V_off) + sin(theta)", "w") == {"alpha", "u", "V_off", "theta"}
    assert free_names("Piecewise((k, x > x_end), (0, True)) * pi", "w") == {"k", "x", "x_end", "pi"}
    assert "pi" in CONSTANTS
    assert free_names(2.5, "w") == set()
    with pytest.raises(PendcError, match="^w: attribute access"):
        free_names("x.y + 1", "w")


@pytest.mark.parametrize("text, column", [
    ("x y", 3), ("a ^ (b", 5), ("  a ^ (b", 7), ("x^y^)", 5), ("(x^2 + ) ", 8),
])
def test_syntax_errors_name_the_users_column(text, column):
    with pytest.raises(PendcError, match=f"^{WHERE}: syntax error at column {column}:"):
        parse(text)


def test_multi_line_text_names_the_line():
    text = "Piecewise(\n    (x^2, x > 0),\n    (0, foo))"
    with pytest.raises(PendcError, match=r"\(at line 3, column 9: 'foo'\)$"):
        parse(text)
    assert parse(text.replace("foo", "True")) == sp.Piecewise((x**2, x > 0), (0, True))


def test_unknown_name_lists_at_most_ten_allowed():
    with pytest.raises(PendcError) as info:
        parse("foo + 1")
    message = str(info.value)
    assert "unknown name 'foo'" in message and "(6 more)" in message    # 15 symbols and pi


MARKER = "/tmp/pwned"

# (text, a fragment the message must hold)
HOSTILE = [
    (f"__import__('os').system('touch {MARKER}')", "attribute access is not allowed"),
    (f"__import__('os')", "unknown function '__import__'"),
    ("().__class__.__bases__[0]", "subscripts"),
    ("open('x')", "unknown function 'open'"),
    (f"exec(\"open('{MARKER}', 'w')\")", "unknown function 'exec'"),
    ("eval('1')", "unknown function 'eval'"),
    ("lambda: 1", "lambda is not allowed"),
    ("[x for x in ()]", "comprehensions are not allowed"),
    ("(x for x in ())", "comprehensions are not allowed"),
    ("f'{x}'", "f-strings are not allowed"),
    ("'abc'", "strings are not allowed"),
    ("b'abc'", "bytes are not allowed"),
    ("x.y", "attribute access is not allowed"),
    ("sin.__globals__", "attribute access is not allowed"),
    ("x[0]", "subscripts"),
    ("sin(x=1)", "keyword arguments are not allowed"),
    ("*x", "syntax error"),
    ("sin(*x)", "starred arguments"),
    ("(x:=1)", "assignment (:=) is not allowed"),
    ("10**10**10", "too large"),
    ("9**99999", "too large"),
    ("(9**999)**999", "out of range"),
    ("2^1000", "out of range"),
    ("1e400", "out of range"),
    ("1" * 400, "out of range"),
    ("9" * 5000, "syntax error"),          # Python's own limit on digits in a literal
    ("x + " * 25000 + "x", f"the limit is {MAX_TEXT}"),
    ("(" * 100000 + "x" + ")" * 100000, f"the limit is {MAX_TEXT}"),
    ("(" * 300 + "x" + ")" * 300, "too many nested parentheses"),
    ("-" * 15000 + "x", "nested too deeply"),
    ("1+" * 5000 + "1", "nested"),
    ("x+" * (MAX_DEPTH + 5) + "x", f"more than {MAX_DEPTH} levels"),
    ("x == y", "'==' is not allowed"),
    ("x != y", "'!=' is not allowed"),
    ("x is y", "'is' is not allowed"),
    ("x in y", "'in' is not allowed"),
    ("x if y else z", "use where(c, a, b)"),
    ("unknown_name", "unknown name 'unknown_name'"),
    ("unknown_func(x)", "unknown function 'unknown_func'"),
    ("sin(x, y)", "sin takes 1 argument, got 2"),
    ("atan2(x)", "atan2 takes 2 arguments, got 1"),
    ("max(x)", "at least 2 arguments"),
    ("Piecewise((1, x > 0))", "condition True"),
    ("Piecewise((1, x > 0, 2), (0, True))", "pair (value, condition)"),
    ("Piecewise()", "pairs"),
    ("Piecewise((1, x), (0, True))", "expected a condition"),
    ("where(x > 0, 1)", "where takes 3 arguments"),
    ("x > 0", "a condition is only allowed inside Piecewise or where"),
    ("x + (y < 1)", "a condition is only allowed inside Piecewise or where"),
    ("x > 0 and y > 0", "a condition is only allowed inside Piecewise or where"),
    ("not x", "a condition is only allowed inside Piecewise or where"),
    ("True + 1", "True is only allowed as a condition"),
    ("where(False, x, y)", "False is not allowed"),
    ("None", "None is not allowed"),
    ("...", "Ellipsis is not allowed"),
    ("1j", "complex numbers are not allowed"),
    ("(x, y)", "only allowed in Piecewise"),
    ("[x]", "lists are not allowed"),
    ("{x: 1}", "dicts are not allowed"),
    ("x % 2", "'%' is not allowed"),
    ("x // 2", "'//' is not allowed"),
    ("x @ y", "'@' is not allowed"),
    ("~x", "'~' is not allowed"),
    ("x | y", "'|' is not allowed"),
    ("(x + 1)(2)", "only the named functions"),
    ("sin", "'sin' is a function"),
    ("1/0", "division by zero"),
    ("0**-1", "division by zero"),
    ("log(0)", "not finite"),
    ("sqrt(-1)", "not real"),
    ("", "empty expression"),
    ("   ", "empty expression"),
    ("x y", "syntax error at column 3"),
    ("x\0", "null bytes"),
    ("ceiling(exp(exp(100)))", "out of range"),       # sympy would compute its integer part
    ("floor(10^(300*pi))", "out of range"),
    ("Max(" + ", ".join(["x"] * 17) + ")", "at most 16 arguments"),
    ("Min(x, Max(" + ", ".join(["y"] * 15) + "))", "at most 16 arguments"),
    ("x\ny", "syntax error at line 2"),
]


@pytest.fixture
def no_code_runs(monkeypatch):
    """eval or exec of source text, and sympy's string parser, fail the test if reached.

    exec of a code object stays allowed: that is how Python runs a module sympy imports lazily.
    """
    import sympy.parsing.sympy_parser as sympy_parser
    # sympy's simplify (which floor() may call) imports sympy.physics.units lazily, and that
    # module sympifies its own constant strings ('yotta') on import: load it first, so the
    # guard sees only what parsing the user's text does.
    import sympy.physics.units  # noqa: F401

    def guard(real):
        def refuse_text(source, *args, **kwargs):
            if isinstance(source, (str, bytes)):
                raise AssertionError(f"code was evaluated: {source!r:.80}")
            return real(source, *args, **kwargs)
        return refuse_text

    def refuse(*args, **kwargs):
        raise AssertionError("sympy's parser was called")
    monkeypatch.setattr(builtins, "eval", guard(builtins.eval))
    monkeypatch.setattr(builtins, "exec", guard(builtins.exec))
    monkeypatch.setattr(sympy_parser, "parse_expr", refuse)


def test_the_hostile_table_is_long_enough():
    assert len(HOSTILE) >= 25


@pytest.mark.parametrize("text, fragment", HOSTILE,
                         ids=[f"{i}:{text[:20]}" for i, (text, _) in enumerate(HOSTILE)])
def test_hostile_inputs_are_refused_on_one_line(text, fragment, no_code_runs):
    existed = os.path.exists(MARKER)
    with pytest.raises(PendcError) as info:
        parse(text)
    message = str(info.value)
    assert message.startswith(f"{WHERE}: ")
    assert "\n" not in message and len(message) < 400
    assert fragment in message
    assert existed or not os.path.exists(MARKER)


@pytest.mark.parametrize("text", [
    f"__import__('os').system('touch {MARKER}')", "().__class__.__bases__[0]", "open('x')",
    "lambda: 1", "[x for x in ()]", "f'{x}'", "'abc'", "x.y", "sin(x=1)", "(x:=1)", "x == y",
    "x if y else z", "unknown_func(x)", "x y", "", "(" * 100000 + ")" * 100000,
    "x+" * (MAX_DEPTH + 5) + "x",
])
def test_free_names_refuses_what_is_not_in_the_grammar(text, no_code_runs):
    with pytest.raises(PendcError, match=f"^{WHERE}: "):
        free_names(text, WHERE)


def test_sympy_giving_up_is_one_line():
    # Not under no_code_runs: sympy's polynomial code exec()s source it generates itself
    # (monomial_mul) while trying to decide the integer part; no user text reaches it.
    with pytest.raises(PendcError) as info:
        parse("floor(exp(690))")
    message = str(info.value)
    assert message.startswith(f"{WHERE}: sympy cannot build the expression") and "\n" not in message


def test_safe_expressions_still_work_with_eval_refused(no_code_runs):
    text = "where(a < x < b, alpha*(u - V_off)^2, Min(sin(theta), 1e-3))"
    assert parse(text) == sp.Piecewise(
        (alpha * (u - V_off)**2, sp.And(a < x, x < b)),
        (sp.Min(sp.sin(theta), sp.Float(1e-3)), True))
