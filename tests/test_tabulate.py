"""LUT tabulation (pendc.passes.tabulate): domains from ranges, grids, contents, lookups."""

import math

import numpy as np
import pytest
import sympy as sp

import pendc
from pendc.ir import lut as lut_sem
from pendc.ir.graph import Graph
from pendc.ir.interpret import FixedInterpreter, FloatInterpreter
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat, Rounding
from pendc.ir.verify import verify
from pendc.caching.build_cache import compile_cached
from pendc.passes.pipeline import BuildOptions
from pendc.passes.ranges import Ranges
from pendc.passes.tabulate import fill_lut_tables, tabulate_luts

Q = QFormat.parse
OPTIONS = BuildOptions(training_scale=0.02)      # the same short build as the other pass tests


def untyped_graph(luts):
    """One input ``a`` feeding LUTs given as (name, expr, periodic)."""
    nodes = [make("a", Kind.INPUT, port="u")]
    for name, expr, periodic in luts:
        lo, hi = (0.0, 1.0) if periodic else (None, None)
        nodes.append(make(name, Kind.LUT, ["a"], expr=expr, lo=lo, hi=hi, periodic=periodic, addr_bits=10,
                          interpolate=True))
    return Graph.build("t", nodes, [(n, n) for n, _, _ in luts])


def ranges_of(lo, hi):
    return Ranges(max_abs={"a": max(abs(lo), abs(hi))}, lo={"a": lo}, hi={"a": hi}, sources=("test",))


def typed_lut(expr, lo, hi, fin, fout, addr_bits, interpolate=True, periodic=False, rounding=Rounding.NEAREST):
    """A typed graph input -> LUT with its table filled."""
    nodes = [make("a", Kind.INPUT, port="u", qformat=Q(fin)),
             make("y", Kind.LUT, ["a"], qformat=Q(fout), rounding=rounding, expr=expr, lo=lo, hi=hi,
                  periodic=periodic, addr_bits=addr_bits, interpolate=interpolate)]
    g = fill_lut_tables(Graph.build("t", nodes, [("y", "y")]))
    verify(g, typed=True)
    return g


def second_derivative_bound(expr, lo, hi):
    v = sp.Symbol("v", real=True)
    d2 = sp.lambdify(v, sp.diff(sp.sympify(expr, locals={"v": v}), v, 2), "numpy")
    xs = np.linspace(lo, hi, 20001)
    return float(np.max(np.abs(np.broadcast_to(d2(xs), xs.shape))))


# -- domains (before Q-formats) --------------------------------------------------------------------

def test_signed_input_domain_is_symmetric_with_margin():
    g = tabulate_luts(untyped_graph([("f", "v**3", False)]), ranges_of(-0.3, 0.2))
    f = g["f"]
    assert f.param("lo") == pytest.approx(-0.3 * 1.125) and f.param("hi") == pytest.approx(0.3 * 1.125)
    # the output format must also cover the grid's possible reach, up to twice the span
    reach = -0.3 * 1.125 + 2 * (2 * 0.3 * 1.125)
    assert f.param("fmax") == pytest.approx(reach ** 3, rel=1e-12)


def test_non_negative_input_keeps_lo_zero():
    g = tabulate_luts(untyped_graph([("f", "exp(-v)", False)]), ranges_of(0.1, 0.4), margin=0.5)
    f = g["f"]
    assert f.param("lo") == 0.0
    assert f.param("hi") == pytest.approx(0.4 * 1.5)
    assert f.param("fmax") == pytest.approx(1.0)          # exp(-0) on [0, 0.6]
    g = tabulate_luts(untyped_graph([("f", "v", False)]), ranges_of(0.0, 2.0))
    assert g["f"].param("lo") == 0.0 and g["f"].param("hi") == pytest.approx(2.25)


def test_periodic_domain_is_kept_and_addr_bits_override():
    g = tabulate_luts(untyped_graph([("p", "3*cos(2*pi*v)", True), ("f", "v", False)]), ranges_of(-5.0, 5.0),
                      addr_bits=7)
    p = g["p"]
    assert (p.param("lo"), p.param("hi")) == (0.0, 1.0)
    assert p.param("fmax") == pytest.approx(3.0)
    assert p.param("addr_bits") == 7 and g["f"].param("addr_bits") == 7
    assert tabulate_luts(untyped_graph([("p", "v", True)]), ranges_of(-1, 1))["p"].param("addr_bits") == 10


def test_function_not_finite_on_its_domain_raises():
    with np.errstate(divide="ignore", invalid="ignore"):
        with pytest.raises(ValueError, match="recip"):
            tabulate_luts(untyped_graph([("recip", "1/v", False)]), ranges_of(-1.0, 1.0))
        with pytest.raises(ValueError, match="logv"):
            tabulate_luts(untyped_graph([("logv", "log(v)", False)]), ranges_of(0.0, 1.0))


def test_a_pole_stays_outside_a_one_signed_inputs_domain():
    """1/t^2 of a gap seen between 1 mm and 15.8 mm (a magnet's force): the domain widened by the
    span's margin would reach past t = 0, and the table's format was sized for 1e10 (every force
    of the plant read 0); it stays on the side of zero the input was seen on."""
    g = tabulate_luts(untyped_graph([("f", "3.2654e-5/v**2", False)]), ranges_of(0.001, 0.0158))
    f = g["f"]
    assert f.param("lo") == pytest.approx(0.001 / 1.125) and f.param("hi") == pytest.approx(0.0158 + 0.125 * 0.0148)
    assert f.param("fmax") == pytest.approx(3.2654e-5 * 1.125**2 / 0.001**2)
    g = tabulate_luts(untyped_graph([("f", "1/v", False)]), ranges_of(-0.0158, -0.001))
    assert g["f"].param("hi") == pytest.approx(-0.001 / 1.125)


def test_untabulated_nodes_are_untouched():
    g = untyped_graph([("f", "v", False)])
    out = tabulate_luts(g, ranges_of(-1.0, 1.0))
    assert out["a"] == g["a"]


# -- grids and contents (after Q-formats) -----------------------------------------------------------

def test_periodic_grid_is_one_period():
    g = typed_lut("cos(2*pi*v)", 0.0, 1.0, "FIX16_12", "FIX18_16", addr_bits=8, periodic=True)
    y = g["y"]
    assert y.param("shift") == 4
    assert (1 << (y.param("addr_bits") + y.param("shift"))) * Q("FIX16_12").lsb == 1.0
    table = y.param("table")
    assert len(table) == 257 and table[-1] == table[0]


def test_periodic_period_must_be_a_power_of_two_of_lsbs():
    nodes = [make("a", Kind.INPUT, port="u", qformat=Q("FIX16_12")),
             make("y", Kind.LUT, ["a"], qformat=Q("FIX18_16"), expr="cos(v)", lo=0.0, hi=2 * math.pi,
                  periodic=True, addr_bits=8, interpolate=True)]
    with pytest.raises(ValueError, match="period"):
        fill_lut_tables(Graph.build("t", nodes, [("y", "y")]))


@pytest.mark.parametrize("expr, lo, hi, fin, fout, bits, interp", [
    ("sin(v)", -2.0, 3.0, "FIX16_10", "FIX20_18", 6, True),
    ("exp(-v)", 0.0, 0.6, "FIX32_31", "FIX32_30", 10, True),
    ("v**2", 0.0, 3.0, "FIX16_8", "UFIX16_10", 4, False),
])
def test_entries_are_the_function_at_grid_points(expr, lo, hi, fin, fout, bits, interp):
    g = typed_lut(expr, lo, hi, fin, fout, bits, interpolate=interp)
    y = g["y"]
    fi, fo = Q(fin), Q(fout)
    shift = y.param("shift")
    assert shift == lut_sem.grid_shift(lo, hi, bits, fi)
    span = (1 << (bits + shift)) * fi.lsb
    assert span >= hi - lo and (shift == 0 or span / 2 < hi - lo)      # smallest power-of-two grid
    xs = lut_sem.grid_points(lo, bits, shift, fi, interp)
    assert len(xs) == len(y.param("table")) == (1 << bits) + interp
    assert xs[0] == pytest.approx(lo, abs=fi.lsb / 2)
    ys = np.array(y.param("table")) * fo.lsb
    assert np.all(np.abs(ys - lut_sem.evaluate(expr, xs)) <= fo.lsb / 2 * (1 + 1e-9))


@pytest.mark.parametrize("rounding", [Rounding.NEAREST, Rounding.TRUNCATE])
def test_fixed_lookup_is_within_interpolation_error(rounding):
    expr, lo, hi, fin, fout, bits = "sin(v) + 0.1*v**2", -2.0, 3.0, "FIX16_10", "FIX24_20", 6
    g = typed_lut(expr, lo, hi, fin, fout, bits, rounding=rounding)
    y, fi, fo = g["y"], Q(fin), Q(fout)
    h = (1 << y.param("shift")) * fi.lsb
    bound = h * h / 8 * second_derivative_bound(expr, lo, lo + (1 << bits) * h) + 1.5 * fo.lsb
    ints = np.arange(lut_sem.lo_int(lo, fi), math.floor(hi / fi.lsb) + 1)
    p = dict(y.params)
    got = np.array([lut_sem.lookup(int(v), fi, fo, lo, bits, p["shift"], p["table"], True, False, rounding)[0]
                    for v in ints]) * fo.lsb
    err = np.abs(got - lut_sem.evaluate(expr, ints * fi.lsb))
    assert err.max() <= bound
    assert err.max() > 10 * fo.lsb          # the test resolves interpolation error, not just rounding


def test_periodic_lookup_wraps_around():
    g = typed_lut("sin(2*pi*v)", 0.0, 1.0, "FIX16_12", "FIX18_16", addr_bits=7, periodic=True)
    y, fi, fo = g["y"], Q("FIX16_12"), Q("FIX18_16")
    p = dict(y.params)
    h = (1 << p["shift"]) * fi.lsb
    bound = h * h / 8 * (2 * math.pi) ** 2 + 1.5 * fo.lsb
    ints = np.arange(fi.min_int, fi.max_int + 1, 37)          # -8 .. +8 turns
    got = np.array([lut_sem.lookup(int(v), fi, fo, 0.0, 7, p["shift"], p["table"], True, True,
                                   Rounding.NEAREST) for v in ints], dtype=object)
    assert not any(flag for _, flag in got)
    values = np.array([v for v, _ in got], float) * fo.lsb
    assert np.max(np.abs(values - np.sin(2 * np.pi * ints * fi.lsb))) <= bound


def test_fixed_and_float_agree_on_out_of_domain_inputs():
    g = typed_lut("v**2", 0.0, 3.0, "FIX16_8", "FIX16_10", addr_bits=4)     # grid reaches 4.0
    for v in (2.5, 3.5):
        fixed = FixedInterpreter(g).run({"u": [v]})
        flt = FloatInterpreter(g).run({"u": [v]})
        assert bool(fixed.overflows) == bool(flt.overflows), v
        assert fixed.outputs["y"][0] * Q("FIX16_10").lsb == pytest.approx(flt.outputs["y"][0], abs=0.01), v


# -- the default model's tables -------------------------------------------------------------------

@pytest.fixture(scope="module")
def build():
    return compile_cached(pendc.load_model(), OPTIONS)     # one short build for the pass tests (the build cache)


def test_model_domains_come_from_ranges(build):
    g, r = build.graph, build.ranges
    luts = g.of_kind(Kind.LUT)
    assert luts

    def ranged(name):      # a table may read its input narrowed to the multiplier width: look through the cast
        while name not in r.lo and g[name].kind is Kind.CAST:
            name = g[name].inputs[0]
        return name

    for n in luts:
        src = ranged(n.inputs[0])
        if n.param("periodic"):
            assert src == "theta_turns" and (n.param("lo"), n.param("hi")) == (0.0, 1.0)
            continue
        reach = max(abs(r.lo[src]), abs(r.hi[src])) * (1 + OPTIONS.lut_margin)
        lo = 0.0 if r.lo[src] >= 0 else -reach
        assert n.param("lo") == pytest.approx(lo, rel=1e-12, abs=1e-15)
        # once filled, hi is the last grid point: at least the wanted reach, at most twice the span
        assert reach * (1 - 1e-9) <= n.param("hi") <= lo + 2 * (reach - lo) + g[src].qformat.lsb
    stribeck = g["F_fric_then_sgn_dx_lut"]
    assert ranged(stribeck.inputs[0]) == "abs_dx" and stribeck.param("lo") == 0.0


def test_model_tables(build):
    g = build.graph
    for n in g.of_kind(Kind.LUT):
        p = dict(n.params)
        fin, fout = g[n.inputs[0]].qformat, n.qformat
        if p["periodic"]:
            assert (1 << (p["addr_bits"] + p["shift"])) * fin.lsb == p["hi"] - p["lo"], n.name
            assert p["table"][0] == p["table"][-1]
        xs = lut_sem.grid_points(p["lo"], p["addr_bits"], p["shift"], fin, p["interpolate"])
        assert len(p["table"]) == len(xs) == (1 << p["addr_bits"]) + p["interpolate"]
        ys = np.array(p["table"], float) * fout.lsb
        ref = lut_sem.evaluate(p["expr"], xs)
        if p["periodic"]:
            ref[-1] = ref[0]
        inside = xs <= p["hi"] + (1 << p["shift"]) * fin.lsb     # entries that interpolate the domain
        assert np.all(np.abs(ys - ref)[inside] <= fout.lsb / 2 * (1 + 1e-9)), n.name
        assert np.max(np.abs(ref[xs <= p["hi"]])) <= fout.max_value, n.name


def test_model_lookups_follow_the_functions(build):
    g = build.graph
    rng = np.random.default_rng(3)
    for n in g.of_kind(Kind.LUT):
        p = dict(n.params)
        fin, fout = g[n.inputs[0]].qformat, n.qformat
        lo_i = lut_sem.lo_int(p["lo"], fin)
        hi_i = min(math.floor(p["hi"] / fin.lsb), fin.max_int)
        ints = rng.integers(max(lo_i, fin.min_int), hi_i, size=400, endpoint=True)
        h = (1 << p["shift"]) * fin.lsb
        period_lo, period_hi = (p["lo"], p["hi"]) if p["periodic"] else (lo_i * fin.lsb, hi_i * fin.lsb + h)
        bound = h * h / 8 * second_derivative_bound(p["expr"], period_lo, period_hi) + 1.5 * fout.lsb
        worst = 0.0
        for v in ints:
            got, flag = lut_sem.lookup(int(v), fin, fout, p["lo"], p["addr_bits"], p["shift"], p["table"],
                                       p["interpolate"], p["periodic"], n.rounding)
            assert not flag
            worst = max(worst, abs(got * fout.lsb - float(lut_sem.evaluate(p["expr"], int(v) * fin.lsb))))
        assert worst <= bound, (n.name, worst, bound)
