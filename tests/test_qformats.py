"""Q-format assignment (pendc.passes.qformats): the thesis' rules, overrides, widening, narrowing."""

import pytest

import pendc
from pendc.ir.fsm import output_width
from pendc.ir.graph import Graph
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat
from pendc.ir.verify import verify
from pendc.caching.build_cache import compile_cached
from pendc.passes.pipeline import BuildOptions
from pendc.passes.qformats import CONST_BITS, MAX_WIDTH, MULT_OPERAND_BITS, assign_qformats, thesis_format
from pendc.passes.ranges import Ranges
from pendc.passes.tabulate import fill_lut_tables, tabulate_luts

Q = QFormat.parse
OPTIONS = BuildOptions(training_scale=0.02)
STATES = ("x", "dx", "theta", "dtheta")


@pytest.fixture(scope="module")
def build():
    return compile_cached(pendc.load_model(), OPTIONS)     # one short build for the pass tests (the build cache)


@pytest.fixture(scope="module")
def tabulated(build):
    return tabulate_luts(build.untyped, build.ranges, margin=OPTIONS.lut_margin, addr_bits=OPTIONS.lut_addr_bits)


def assign(build, tabulated, **kw):
    kw.setdefault("margin_bits", OPTIONS.margin_bits)
    g = assign_qformats(tabulated, build.ranges, width=OPTIONS.width, **kw)
    g = fill_lut_tables(g)
    verify(g, typed=True)
    return g


@pytest.fixture(scope="module")
def typed(build, tabulated):
    return assign(build, tabulated)


def test_every_node_is_typed(typed):
    assert all(n.qformat is not None for n in typed.nodes)


def test_constants_have_at_least_32_bits(typed):
    consts = typed.of_kind(Kind.CONST)
    assert consts
    for n in consts:
        assert n.qformat.width >= CONST_BITS, n.name
        assert n.qformat == thesis_format(abs(n.param("value")), CONST_BITS), n.name
    for n in typed.of_kind(Kind.GAIN):
        cfmt = Q(n.param("cfmt"))
        assert cfmt.width >= CONST_BITS and cfmt == thesis_format(abs(n.param("value")), CONST_BITS), n.name
        assert abs(cfmt.from_float(n.param("value")) * cfmt.lsb - n.param("value")) <= cfmt.lsb / 2


def test_variables_follow_the_thesis_rule(build, tabulated, typed):
    """The thesis' rule, plus the guard bits of a state that cannot resolve its own increment (the
    default model's theta in FIX32_19 against a 3.3e-5 rad step: 4 bits) on its accumulation path."""
    from pendc.passes.qformats import accumulator_chain, increment_guard_bits
    r = build.ranges
    stored_by = {n.inputs[0]: n.name for n in typed.of_kind(Kind.REGISTER)}
    guards = increment_guard_bits(tabulated, r, OPTIONS.width, OPTIONS.margin_bits)
    assert guards.get("theta") == 4
    guarded = {name: extra for reg, extra in guards.items() for name in (reg, *accumulator_chain(tabulated, reg))}
    checked = 0
    for n in tabulated.nodes:
        if n.kind in (Kind.CONST, Kind.COMPARE, Kind.SLICE, Kind.FSM, Kind.REGISTER):
            continue
        m = r[n.name]
        if n.kind is Kind.LUT:
            m = max(m, n.param("fmax"))
        if n.kind is Kind.INPUT:
            m = max(m, n.param("max_abs"))
        if n.name in stored_by:
            m = max(m, r[stored_by[n.name]])
        want = thesis_format(m, OPTIONS.width, OPTIONS.margin_bits)
        extra = guarded.get(n.name, 0)
        assert typed[n.name].qformat == Q(f"FIX{want.width + extra}_{want.frac + extra}"), n.name
        checked += 1
    assert checked > 30
    assert typed["u"].qformat == thesis_format(10.0, 32, OPTIONS.margin_bits)     # the port's declared range


def test_registers_share_their_inputs_format(typed):
    regs = typed.of_kind(Kind.REGISTER)
    assert len(regs) >= 8         # four states and four encoder phases
    for n in regs:
        assert n.qformat == typed[n.inputs[0]].qformat, n.name


def test_flag_formats(typed):
    for n in typed.of_kind(Kind.COMPARE):
        assert n.qformat == Q("UFIX1_0"), n.name
    for n in typed.of_kind(Kind.SLICE):
        hi, lo = n.param("hi"), n.param("lo")
        expected = 1 if hi == lo == -1 else hi - lo + 1
        assert n.qformat == QFormat(False, expected, 0), n.name
    fsms = typed.of_kind(Kind.FSM)
    assert len(fsms) == 4
    for n in fsms:
        assert n.qformat == QFormat(False, output_width(n.param("outputs")), 0) == Q("UFIX3_0")


def test_overrides_win(build, tabulated):
    g = assign(build, tabulated, overrides={"ddx": "FIX32_20", "F_cart": Q("FIX40_30"), "dx_over": "UFIX1_0"})
    assert g["ddx"].qformat == Q("FIX32_20")
    assert g["F_cart"].qformat == Q("FIX40_30")


def test_register_override_moves_its_input_too(build, tabulated):
    g = assign(build, tabulated, overrides={"x": "FIX48_44"})
    assert g["x"].qformat == g["x_sum"].qformat == Q("FIX48_44")


def test_unknown_override_raises(build, tabulated):
    with pytest.raises(ValueError, match="no_such_node"):
        assign_qformats(tabulated, build.ranges, overrides={"no_such_node": "FIX32_16"})
    with pytest.raises(ValueError):
        assign_qformats(tabulated, build.ranges, overrides={"ddx": "Q15"})


def test_margin_bits(build, tabulated, typed):
    g = assign(build, tabulated, margin_bits=OPTIONS.margin_bits + 2)
    assert g["ddx"].qformat.frac == typed["ddx"].qformat.frac - 2
    assert g["c_0p55"].qformat == typed["c_0p55"].qformat          # constants have no margin


def test_widen_adds_fraction_bits_to_accumulators(build, tabulated, typed):
    """``widen`` counts from the rule's format; a state's own guard bits (theta's 4) are a floor
    under it, not added to it."""
    from pendc.passes.qformats import increment_guard_bits
    g = assign(build, tabulated, widen={s: 8 for s in STATES})
    guards = increment_guard_bits(tabulated, build.ranges, OPTIONS.width, OPTIONS.margin_bits)
    for s in STATES:
        base = typed[s].qformat
        floor = guards.get(s, 0)
        assert g[s].qformat == QFormat(True, base.width + 8 - floor, base.frac + 8 - floor), s
        assert g[s].qformat == g[g[s].inputs[0]].qformat                 # the stored sum widens too
    assert g["ddx"].qformat == typed["ddx"].qformat                       # not an accumulator


def test_widen_reaches_the_sum_of_every_accumulator(build, tabulated):
    g = assign(build, tabulated, widen={s: 8 for s in STATES})
    for s in STATES:
        (total,) = [n for n in g.of_kind(Kind.ADD) if set(n.inputs) == {s, f"{s}_inc"}]
        assert total.qformat.frac >= g[s].qformat.frac, (s, total.name, str(total.qformat), str(g[s].qformat))


def test_wide_multiplier_operands_get_a_cast(build, tabulated):
    g = assign(build, tabulated, widen={s: 8 for s in STATES})
    for n in g.of_kind(Kind.GAIN, Kind.MUL):
        for i in n.inputs:
            assert g[i].qformat.width <= MULT_OPERAND_BITS, (n.name, i)
    # dx (40 bits now) feeds gains through one shared 32-bit cast keeping its integer bits
    cast = g["dx_m"]
    assert cast.kind is Kind.CAST and cast.inputs == ("dx",)
    assert cast.qformat == QFormat(True, 32, g["dx"].qformat.frac - 8)
    assert "dx_m" in g["x_inc"].inputs and "dx_m" in g["F_cart_dx_gain"].inputs
    assert g["ddx_dtheta_prod"].inputs == ("dtheta_m", "dtheta_m")
    # the comparator and the register chain still read the wide value
    assert "dx" in g["moving"].inputs


def test_widening_is_capped(build, tabulated):
    g = assign(build, tabulated, widen={"x": 100})
    assert g["x"].qformat.width == MAX_WIDTH


def test_a_tiny_increment_of_a_large_state_is_cut_to_what_the_aligned_sum_holds():
    """A thermal mass at 296 K whose training run moved it 1e-9 K a step: the increment's own
    range types it FIX32_60, and aligned to the state's 10 integer bits the sum would need 71
    bits (an internal compiler error before). A CAST drops the increment's bits below 2^-53
    (64 - 1 carry - 10 bits of the state), all beneath the state's LSB; the compiled kernel and
    the interpreter agree bit for bit."""
    import numpy as np
    from pendc.ir.compiled import CompiledGraph
    from pendc.ir.interpret import FixedInterpreter
    nodes = [make("u", Kind.INPUT, port="u"), make("inc", Kind.GAIN, ["u"], value=1e-9),
             make("T", Kind.REGISTER, ["T_sum"], reset=296.15), make("T_sum", Kind.ADD, ["T", "inc"]),
             make("hot", Kind.COMPARE, ["T", "inc"], op="lt")]
    g = Graph.build("oven", nodes, [("T", "T"), ("hot", "hot")])
    ranges = Ranges(max_abs={"u": 1.0, "inc": 1e-9, "T": 296.2, "T_sum": 296.2, "hot": 1.0},
                    lo={}, hi={}, sources=("hand",))
    t = assign_qformats(g, ranges, width=32, widen={"T": 22})
    verify(t, typed=True)
    assert t["inc"].qformat == Q("FIX32_60") and t["T"].qformat == Q("FIX54_44")
    assert t["T_sum"].inputs == ("T", "inc_f53") and t["hot"].inputs == ("T", "inc_f53")
    assert t["inc_f53"].qformat == Q("FIX25_53") and t["inc_f53"].kind is Kind.CAST
    plain = assign_qformats(g, ranges, width=32)          # the guard bits alone: 2^-38 <= 1e-9 / 256
    assert plain["T_sum"].inputs == ("T", "inc_f53") and plain["T"].qformat == Q("FIX48_38")
    u = np.full(50, t["u"].qformat.from_float(0.75), dtype=np.int64)
    compiled = CompiledGraph(t, "fixed").run({"u": u})
    ref = FixedInterpreter(t).run({"u": u})
    assert np.array_equal(compiled.outputs["T"], ref.outputs["T"]) and not compiled.overflows
    moved = (int(ref.outputs["T"][-1]) - int(ref.outputs["T"][0])) * t["T"].qformat.lsb
    assert moved == pytest.approx(49 * 0.75e-9, rel=1e-3)


def test_a_state_gets_guard_bits_below_its_own_increment():
    """A thermal mass at 300 K heated at most 5e-7 K a step: its rule's format FIX32_22 (LSB
    2.4e-7 K) rounds each increment to 0 or 1 LSB; 7 guard bits put 256 LSBs under the largest
    increment, on the register, its accumulating sum and the clamp between them. A wider budget
    widening wins; a state whose format already resolves its increment is left alone."""
    from pendc.passes.qformats import INCREMENT_GUARD_BITS, increment_guard_bits
    nodes = [make("u", Kind.INPUT, port="u"), make("inc", Kind.GAIN, ["u"], value=5e-7),
             make("T", Kind.REGISTER, ["T_clamped"], reset=296.0), make("T_sum", Kind.ADD, ["T", "inc"]),
             make("hot", Kind.COMPARE, ["T_sum", "top"], op="gt"), make("top", Kind.CONST, value=400.0),
             make("T_clamped", Kind.MUX, ["hot", "T_sum", "top"]),
             make("n", Kind.REGISTER, ["n_sum"], reset=0.0), make("n_sum", Kind.ADD, ["n", "inc"])]
    g = Graph.build("oven", nodes, [("T", "T"), ("n", "n")])
    ranges = Ranges(max_abs={"u": 1.0, "inc": 5e-7, "T": 300.0, "T_sum": 300.0, "hot": 1.0, "top": 400.0,
                             "T_clamped": 300.0, "n": 1e-4, "n_sum": 1e-4}, lo={}, hi={}, sources=("hand",))
    assert INCREMENT_GUARD_BITS == 8 and increment_guard_bits(g, ranges) == {"T": 7}
    t = assign_qformats(g, ranges, width=32)
    verify(t, typed=True)
    assert t["T"].qformat == t["T_sum"].qformat == t["T_clamped"].qformat == Q("FIX39_29")
    assert t["T"].qformat.lsb <= 5e-7 / 256 < 2 * t["T"].qformat.lsb
    assert t["n"].qformat == Q("FIX32_44")                  # 1e-4 in 32 bits: LSB 5.7e-14, resolved already
    assert assign_qformats(g, ranges, width=32, widen={"T": 12})["T"].qformat == Q("FIX44_34")


def test_hold_seconds_puts_a_ceiling_on_a_states_lsb():
    """A tank near its equilibrium moves 1e-11 m a step, far below its largest increment: with
    [hardware] hold_seconds = 60 and a 76 um budget, its LSB is at most 2 * 76e-6 * 1e-6 / 60 =
    2.5e-12 m, so a creep of its budget over a minute is not rounded away; without, the guard
    bits alone (1/256 of the largest increment)."""
    import math
    from pendc.errors import PendcError
    from pendc.passes.pipeline import validate_options
    from pendc.passes.qformats import increment_guard_bits
    nodes = [make("u", Kind.INPUT, port="u"), make("h_inc", Kind.GAIN, ["u"], value=6.8e-9),
             make("h", Kind.REGISTER, ["h_sum"], reset=0.07), make("h_sum", Kind.ADD, ["h", "h_inc"])]
    g = Graph.build("tank", nodes, [("h", "h")])
    ranges = Ranges(max_abs={"u": 1.0, "h_inc": 6.8e-9, "h": 0.62, "h_sum": 0.62}, lo={}, hi={}, sources=("hand",))
    ceiling = 2 * 7.57e-5 * 1e-6 / 60
    plain, held = increment_guard_bits(g, ranges), increment_guard_bits(g, ranges, lsb_ceiling={"h": ceiling})
    rule = thesis_format(0.62)
    assert rule.frac + plain["h"] == math.ceil(8 - math.log2(6.8e-9))                  # 1/256 of a step
    t = assign_qformats(g, ranges, width=32, lsb_ceiling={"h": ceiling})
    assert t["h"].qformat.lsb <= ceiling < 2 * t["h"].qformat.lsb and held["h"] > plain["h"]
    with pytest.raises(PendcError, match="hold_seconds must be 0"):
        validate_options({"hold_seconds": -1.0})
    assert validate_options({"hold_seconds": 60}).hold_seconds == 60.0


def test_hand_graph_mul_cast_and_flags():
    nodes = [make("a", Kind.INPUT, port="u"), make("b", Kind.INPUT, port="w"),
             make("p", Kind.MUL, ["a", "b"]), make("c", Kind.COMPARE, ["a", "b"], op="lt"),
             make("k", Kind.CONST, value=-0.75), make("s", Kind.SLICE, ["a"], hi=5, lo=2),
             make("r", Kind.REGISTER, ["q"], reset=0.0), make("q", Kind.ADD, ["r", "p"])]
    g = Graph.build("h", nodes, [("q", "q"), ("c", "c"), ("k", "k"), ("s", "s")])
    ranges = Ranges(max_abs={"a": 3.0, "b": 0.4, "p": 1.2, "c": 1.0, "k": 0.75, "s": 15, "r": 100.0, "q": 50.0},
                    lo={}, hi={}, sources=("hand",))
    t = assign_qformats(g, ranges, width=32, overrides={"a": "FIX48_40"})
    verify(t, typed=True)
    assert t["a"].qformat == Q("FIX48_40")
    assert t["a_m"].qformat == Q("FIX32_24") and t["p"].inputs == ("a_m", "b")
    assert t["b"].qformat == Q("FIX32_32")            # 0.4 < 0.5: the sign bit is the 2**-1 weight
    assert t["c"].qformat == Q("UFIX1_0") and t["s"].qformat == Q("UFIX4_0")
    assert t["k"].qformat == Q("FIX32_31")
    assert t["r"].qformat == t["q"].qformat == thesis_format(100.0)   # the register's range counts
    assert t["c"].inputs == ("a", "b")                   # only multiplier operands are narrowed


# -- fitting products to the target's multipliers ----------------------------------------------------

def test_level_zero_fits_one_dsp_block(build, tabulated):
    from pendc.passes.resources import dsp_for, product_widths
    for shape in ((18, 18), (25, 18)):
        g = assign(build, tabulated, shape=shape)
        products = [n for n in g.nodes if product_widths(g, n) is not None]
        assert len(products) >= 10
        for n in products:
            assert dsp_for(*product_widths(g, n), shape) == 1, (shape, n.name, product_widths(g, n))
        for n in g.of_kind(Kind.GAIN):          # the coefficient takes the wide port
            assert QFormat.parse(n.param("cfmt")).width == max(shape)
            assert g[n.inputs[0]].qformat.width <= min(shape)
        for n in g.of_kind(Kind.LUT):
            if n.param("interpolate"):
                assert n.qformat.width <= max(shape) and n.param("shift") <= min(shape) - 1


def test_levels_widen_one_side_then_both(build, tabulated):
    g0 = assign(build, tabulated, shape=(18, 18))
    gain = next(n.name for n in g0.of_kind(Kind.GAIN))
    mul = next(n.name for n in g0.of_kind(Kind.MUL))
    g1 = assign(build, tabulated, shape=(18, 18), levels={gain: 1, mul: 1})
    assert QFormat.parse(g1[gain].param("cfmt")).width == CONST_BITS          # coefficient first
    assert g1[g1[gain].inputs[0]].qformat.width == 18
    assert g1[g1[mul].inputs[0]].qformat.width > 18 and g1[g1[mul].inputs[1]].qformat.width <= 18
    g2 = assign(build, tabulated, shape=(18, 18), levels={gain: 2})
    assert g2[gain] == assign(build, tabulated)[gain]                         # the 32-bit rule again


def test_an_overridden_operand_goes_into_its_multiplier_whole():
    """Round J: a CSTR's rate table overridden to FIX32_20 was cut back to the 18-bit DSP word
    (FIX18_6, coarser than before) in front of its product: the override did nothing. An operand
    whose format the file sets goes in whole up to a multiplier's 32 bits."""
    nodes = [make("a", Kind.INPUT, port="u"), make("b", Kind.INPUT, port="w"), make("p", Kind.MUL, ["a", "b"]),
             make("r", Kind.REGISTER, ["q"], reset=0.0), make("q", Kind.ADD, ["r", "p"])]
    g = Graph.build("h", nodes, [("q", "q")])
    ranges = Ranges(max_abs={"a": 1000.0, "b": 3.0, "p": 3000.0, "r": 5000.0, "q": 5000.0}, lo={}, hi={},
                    sources=("hand",))
    plain = assign_qformats(g, ranges, width=32, shape=(18, 18), levels={"p": 0})
    assert plain["p"].inputs == ("a_m18", "b_m18")
    kept = assign_qformats(g, ranges, width=32, shape=(18, 18), levels={"p": 0}, overrides={"a": "FIX32_20"})
    verify(kept, typed=True)
    assert kept["p"].inputs == ("a", "b_m18") and kept["a"].qformat == Q("FIX32_20")
