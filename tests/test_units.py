"""pendc.model.units: unit strings and the dimension check of plant expressions."""

from __future__ import annotations

from fractions import Fraction

import pytest
import sympy as sp

from pendc.errors import PendcError
from pendc.model.expressions import parse_expression
from pendc.model.units import DIMENSIONLESS, Dim, check_same, dimension_of, parse_unit

FORCE = "kg*m/s^2"


@pytest.mark.parametrize("text, expected", [
    ("m", "m"), ("kg", "kg"), ("s", "s"), ("A", "A"), ("K", "K"), ("mol", "mol"), ("cd", "cd"),
    ("N", FORCE), ("J", "kg*m^2/s^2"), ("W", "kg*m^2/s^3"), ("V", "kg*m^2/(s^3*A)"),
    ("ohm", "kg*m^2/(s^3*A^2)"), ("Ohm", "kg*m^2/(s^3*A^2)"), ("Ω", "kg*m^2/(s^3*A^2)"),
    ("\u2126", "kg*m^2/(s^3*A^2)"), ("F", "s^4*A^2/(kg*m^2)"), ("H", "kg*m^2/(s^2*A^2)"),
    ("C", "s*A"), ("Pa", "kg/(m*s^2)"), ("Hz", "1/s"), ("T", "kg/(s^2*A)"),
    ("rad", "1"), ("deg", "1"), ("rev", "1"), ("rpm", "1/s"), ("%", "1"),
    ("-", "1"), ("1", "1"), ("", "1"), (" m ", "m"),
    ("N*m*s/rad", "kg*m^2/s"), ("kg*m^2", "kg*m^2"), ("m/s^2", "m/s^2"), ("m/s**2", "m/s^2"),
    ("V*s/rad", "kg*m^2/(s^2*A)"), ("N*m/A", "kg*m^2/(s^2*A)"), ("kg^2*m^4", "kg^2*m^4"),
    ("1/s", "1/s"), ("s^-1", "1/s"), ("rad/s", "1/s"), ("(kg*m)/(s*s)", FORCE),
    ("m^(1/2)", "m^(1/2)"), ("m^0.5/s", "m^(1/2)/s"), ("N/V", "s*A/m"), ("W/(m*K)", "kg*m/(s^3*K)"),
])
def test_parse_unit(text, expected):
    assert str(parse_unit(text, "w")) == expected


@pytest.mark.parametrize("text", ["N*m*s/rad", "V", "m^(1/2)/s", "1", "F", "kg^2*m^4"])
def test_str_reads_back(text):
    dim = parse_unit(text, "w")
    assert parse_unit(str(dim), "w") == dim


@pytest.mark.parametrize("text, fragment", [
    ("furlong", "unknown unit 'furlong'"),
    ("mm", "unknown unit 'mm'"),             # no scale in a Dim: a prefix would be lost
    ("kN*m", "unknown unit 'kN'"),
    ("g", "unknown unit 'g'"),
    ("m+s", "only unit names"),
    ("2*m", "only unit names"),
    ("m^x", "exponent"),
    ("m^1e9", "exponent"),
    ("m^(1/0)", "exponent"),
    ("m^", "cannot read unit"),
    ("__import__('os').system('touch /tmp/pwned')", "cannot read unit"),
    ("m.x", "cannot read unit"),
    ("m" * 300, "limit"),
    (5, "a unit is a string"),
])
def test_bad_units(text, fragment):
    with pytest.raises(PendcError) as info:
        parse_unit(text, "plant.M.unit")
    message = str(info.value)
    assert message.startswith("plant.M.unit: ") and "\n" not in message
    assert fragment in message


def test_unknown_unit_lists_known_ones():
    with pytest.raises(PendcError, match=r"known: m, kg, s, A"):
        parse_unit("furlong", "w")


def test_dim_arithmetic():
    m, s = parse_unit("m", "w"), parse_unit("s", "w")
    assert m / s / s == parse_unit("m/s^2", "w")
    assert (m * m) ** Fraction(1, 2) == m
    assert m ** 2 / m ** 2 == DIMENSIONLESS and DIMENSIONLESS.dimensionless
    assert not m.dimensionless
    assert hash(m * s) == hash(s * m) and m * s == s * m
    assert Dim.of({"length": 1, "time": -2}) == m / s ** 2
    assert str(Dim.of({"mass": -1})) == "1/kg"
    with pytest.raises(TypeError):
        m ** 0.5


UNITS = {"M": "kg", "m": "kg", "dx": "m/s", "F": "N", "theta": "rad", "dtheta": "rad/s",
         "x": "m", "k": "N/m", "x_end": "m", "k_end": "N/m", "b_end": "N*s/m", "L": "m",
         "alpha": "N/V", "u": "V", "V_off": "V", "g": "m/s^2", "n": "1", "J": "kg*m^2",
         "b_theta": "N*m*s/rad"}
DIMS = {name: parse_unit(unit, name) for name, unit in UNITS.items()}
SYMS = {name: sp.Symbol(name, real=True) for name in UNITS}


def dim(text):
    return dimension_of(parse_expression(text, SYMS, "w"), DIMS, "w")


@pytest.mark.parametrize("text, expected", [
    ("F/M", "m/s^2"),
    ("alpha*(u - V_off)", FORCE),
    ("-(x - L*sin(theta))", "m"),
    ("M*g*sin(theta) - F", FORCE),
    ("sqrt(k/m)", "1/s"),
    ("sin(theta)", "1"),
    ("cos(x/L)", "1"),
    ("-b_theta*dtheta/J", "1/s^2"),
    ("Piecewise((-k_end*(x - sign(x)*x_end) - b_end*dx, Abs(x) > x_end), (0, True))", FORCE),
    ("where(dx > 0, F, 0)", FORCE),
    ("where(x > 0, 0, F)", FORCE),
    ("Max(0, F)", FORCE),
    ("Min(F, M*g)", FORCE),
    ("atan2(x, L)", "1"),
    ("Abs(dx)", "m/s"),
    ("floor(x)", "m"),
    ("x^2", "m^2"),
    ("x^(1/3)", "m^(1/3)"),
    ("x^-1.5", "1/m^(3/2)"),
    ("theta^n", "1"),
    ("F + 0", FORCE),
    ("2*pi", "1"),
    ("0", "1"),
])
def test_dimensions_of_physical_expressions(text, expected):
    assert str(dim(text)) == expected


@pytest.mark.parametrize("text, fragments", [
    ("M*dx + F", ["inconsistent units", "'F' is kg*m/s^2", "'M*dx' is kg*m/s"]),
    ("exp(x)", ["the argument of exp must be dimensionless", "'x' is m"]),
    ("log(k)", ["the argument of log"]),
    ("sin(x)", ["the argument of sin"]),
    ("atan2(x, M)", ["inconsistent units in atan2"]),
    ("Min(x, dx)", ["inconsistent units in Min"]),
    ("where(x > dx, x, 0)", ["inconsistent units in a comparison"]),
    ("where(x > 0, x, dx)", ["between Piecewise branches"]),
    ("x^n", ["exponent must be a rational number"]),
    ("x^0.3", ["exponent must be a rational number"]),
    ("2^x", ["an exponent must be dimensionless"]),
])
def test_dimension_errors(text, fragments):
    with pytest.raises(PendcError) as info:
        dim(text)
    message = str(info.value)
    assert message.startswith("w: ") and "\n" not in message
    for fragment in fragments:
        assert fragment in message


def test_missing_symbol_is_named():
    with pytest.raises(PendcError, match="^w: no units known for 'q'"):
        dimension_of(sp.Symbol("q") + 1, DIMS, "w")


def test_lagrangian_functions_and_derivatives():
    t = sp.Symbol("t")
    xt = sp.Function("x")(t)
    dims = {**DIMS, "t": parse_unit("s", "t")}
    assert str(dimension_of(sp.Derivative(xt, t, 2), dims, "w")) == "m/s^2"
    assert str(dimension_of(SYMS["M"] * xt.diff(t), dims, "w")) == "kg*m/s"


def test_python_numbers_and_zero():
    assert dimension_of(0, DIMS, "w") == DIMENSIONLESS
    assert dimension_of(2.5, DIMS, "w") == DIMENSIONLESS


def test_check_same():
    force = parse_unit("N", "w")
    check_same(force, parse_expression("alpha*(u - V_off)", SYMS, "w"), DIMS, "w", "force")
    check_same(force, sp.Integer(0), DIMS, "w", "force")       # zero fits any quantity
    with pytest.raises(PendcError) as info:
        check_same(force, SYMS["M"] * SYMS["dx"], DIMS, "effects.drive", "the force")
    assert str(info.value) == ("effects.drive: the force has units of kg*m/s (N*s), "
                               "expected kg*m/s^2 (N)")
    with pytest.raises(PendcError) as info:      # a derived unit is named as the user wrote it
        check_same(parse_unit("V", "w"), SYMS["M"], DIMS, "states.vC", "d/dt vC")
    assert str(info.value) == "states.vC: d/dt vC has units of kg, expected kg*m^2/(s^3*A) (V)"
    with pytest.raises(PendcError) as info:      # a state's derivative: its unit per second
        check_same(parse_unit("V/s", "w"), SYMS["M"],
                   DIMS, "states.vC", "d/dt vC")
    assert str(info.value) == "states.vC: d/dt vC has units of kg, expected kg*m^2/(s^4*A) (V/s)"


def test_the_unit_table_is_sympys_and_is_kept_between_processes(tmp_path):
    """Each unit resolved through sympy.physics.units, written once to the cache folder and read
    back by later processes; a torn or foreign file is resolved again and rewritten."""
    import json
    import os
    import subprocess
    import sys

    from pendc.model.units import _UNIT_SOURCES, _resolve, unit_table
    resolved = {name: _resolve(source) for name, source in _UNIT_SOURCES.items()}
    assert resolved["N"] == Dim.of({"mass": 1, "length": 1, "time": -2}) and resolved["rpm"] == Dim.of({"time": -1})
    folder = tmp_path / "units"              # cache_dir("units") under PENDC_CACHE_DIR=tmp_path
    folder.mkdir()
    assert unit_table(folder) == resolved
    (kept,) = folder.glob("units-*.json")
    assert unit_table(folder) == resolved
    code = "import sys; from pendc.model.units import UNITS; print(len(UNITS), 'sympy.physics.units' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                          env={**os.environ, "PENDC_CACHE_DIR": str(tmp_path)})
    assert done.stdout.split() == [str(len(resolved)), "False"]          # read back, sympy's units not imported
    for torn in ('{"m": [["length"', json.dumps({"m": [["length", "1"]]}), "[1, 2]"):
        kept.write_text(torn)
        assert unit_table(folder) == resolved
        assert json.loads(kept.read_text()).keys() == resolved.keys()


@pytest.mark.parametrize("unit", ["-", "1", "", " - "])
def test_a_dimensionless_unit_is_not_printed_after_a_value(unit):
    """The spellings parse_unit reads as dimensionless print as nothing after a value ("d = 1",
    not "d = 1 -") and as a word where the unit stands alone ("[dimensionless]", not "[-]")."""
    from pendc.model.interface import InputRange, unit_name, with_unit

    assert parse_unit(unit, "w") == DIMENSIONLESS
    assert with_unit("0.5033", unit) == "0.5033" and unit_name(unit) == "dimensionless"
    assert InputRange(0.0, 1.0, unit).describe() == "0-1" and InputRange(-1.0, 1.0, unit).describe() == "±1"


def test_a_unit_is_printed_after_a_value():
    from pendc.model.interface import InputRange, unit_name, with_unit

    assert with_unit("2", "V") == "2 V" and with_unit("[0, 1]", " ohm ") == "[0, 1] ohm" and unit_name("N*m") == "N*m"
    assert InputRange(0.0, 10.0, "V").describe() == "0-10 V"
    assert InputRange(-2.0, 10.0, "V").describe() == "-2 to 10 V"      # "-2-10 V" reads as a subtraction
