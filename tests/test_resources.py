"""Resource estimate (pendc.passes.resources) of a small hand-typed graph and of the default build."""

import json

import pytest

import pendc
from pendc.ir.graph import Graph
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat
from pendc.ir.verify import verify
from pendc.caching.build_cache import compile_cached
from pendc.passes.pipeline import BuildOptions
from pendc.passes.resources import BRAM_BITS, dsp18_for, dsp_for, estimate_resources, longest_path
from pendc.passes.tabulate import fill_lut_tables

Q = QFormat.parse


def test_dsp18_for():
    assert dsp18_for(32, 32) == 4
    assert dsp18_for(18, 18) == 1
    assert dsp18_for(18, 2) == 1
    assert dsp18_for(32, 18) == 2
    assert dsp18_for(35, 18) == 2          # 34 magnitude bits = two 17-bit partial products
    assert dsp18_for(36, 18) == 3
    assert dsp18_for(1, 1) == 1


def hand_graph():
    """Every counted kind once or twice; the longest logic chain is m -> s -> d -> n -> mx -> q (6)."""
    three = dict(states=("A", "B", "C"), outputs=(0, 1, 2), reset="A", lo=-10.0, hi=10.0,
                 transitions=(("*", "gt", 1.0, "B"), ("*", "lt", -1.0, "C")))
    nodes = [
        make("a", Kind.INPUT, port="u", qformat=Q("FIX32_20")),
        make("b", Kind.INPUT, port="w", qformat=Q("FIX16_8")),
        make("c", Kind.CONST, value=0.5, qformat=Q("FIX32_30")),
        make("r", Kind.REGISTER, ["q"], reset=0.0, qformat=Q("FIX40_30")),
        make("f", Kind.FSM, ["d"], qformat=Q("UFIX2_0"), **three),
        make("g", Kind.GAIN, ["a"], value=3.0, cfmt="FIX18_15", qformat=Q("FIX32_18")),
        make("m", Kind.MUL, ["a", "b"], qformat=Q("FIX32_20")),
        make("s", Kind.ADD, ["m", "c"], qformat=Q("FIX32_20")),
        make("d", Kind.SUB, ["s", "g"], qformat=Q("FIX24_12")),
        make("n", Kind.NEG, ["d"], qformat=Q("FIX24_12")),
        make("cmp", Kind.COMPARE, ["n", "c"], op="lt", qformat=Q("UFIX1_0")),
        make("sl", Kind.SLICE, ["n"], hi=-1, lo=-1, qformat=Q("UFIX1_0")),
        make("mx", Kind.MUX, ["sl", "n", "d"], qformat=Q("FIX24_12")),
        make("k", Kind.CAST, ["mx"], qformat=Q("FIX40_30")),
        make("q", Kind.ADD, ["r", "k"], qformat=Q("FIX40_30")),
        make("small", Kind.LUT, ["b"], expr="sin(v)", lo=-4.0, hi=4.0, periodic=False, addr_bits=6,
             interpolate=True, qformat=Q("FIX18_16")),
        make("big", Kind.LUT, ["a"], expr="cos(v)", lo=-8.0, hi=8.0, periodic=False, addr_bits=12,
             interpolate=False, qformat=Q("FIX32_30")),
    ]
    g = fill_lut_tables(Graph.build("hand", nodes, [("q", "q"), ("cmp", "cmp"), ("small", "small"),
                                                    ("big", "big"), ("f", "f")]))
    verify(g, typed=True)
    return g


@pytest.fixture(scope="module")
def res():
    return estimate_resources(hand_graph())


def test_multipliers(res):
    # MUL a*b, GAIN a by an 18-bit constant, and the interpolation of the small table: its
    # slope (sin over 1/8-wide segments, 2**16 LSB per unit: |dy| < 8192, 14 signed bits) times
    # its 5-bit fraction (b has 8 fraction bits, 32-LSB segments) plus a zero sign bit
    assert res.multipliers == {"32x16": 1, "32x18": 1, "14x6": 1}
    assert res.dsp18 == dsp18_for(32, 16) + dsp18_for(32, 18) + 1 == 5
    assert res.dsp == 5 and res.dsp_shape == "18x18"
    assert {p["node"]: p["dsp"] for p in res.products} == {"g": 2, "m": 2, "small": 1}


def test_dsp_blocks_by_multiplier_shape():
    assert dsp_for(25, 18, (25, 18)) == 1 and dsp_for(18, 25, (25, 18)) == 1
    assert dsp_for(25, 18, (18, 18)) == 2
    assert dsp_for(27, 18, (27, 18)) == 1 and dsp_for(27, 18, (25, 18)) == 2
    assert dsp_for(32, 32, (25, 18)) == 4         # 31 bits: 2 x 24-bit, 2 x 17-bit partial products
    assert dsp_for(16, 16, (16, 16)) == 1 and dsp_for(17, 16, (16, 16)) == 2
    g = hand_graph()
    assert estimate_resources(g, (25, 18)).dsp == dsp_for(32, 16, (25, 18)) + dsp_for(32, 18, (25, 18)) + 1 == 5


def test_tables(res):
    small_bits = 65 * 18                  # 2**6 + 1 entries (interpolated) of 18 bits
    big_bits = 4096 * 32                  # 2**12 entries of 32 bits
    assert res.luts == 2
    assert res.lut_bits == small_bits + big_bits
    assert res.brams == 1 + -(-big_bits // BRAM_BITS) == 1 + 4


def test_registers_and_logic(res):
    assert res.register_bits == 40 + 2        # the 40-bit register and the 3-state FSM's state
    assert res.adders == 4                    # s, d, n, q
    assert res.adder_bits == 32 + 24 + 24 + 40
    assert res.muxes == 1
    assert res.comparators == 1


def test_longest_path(res):
    g = hand_graph()
    depth, path = longest_path(g)
    assert (depth, path) == (res.logic_depth, res.critical_path)
    assert depth == 6
    assert path[0] == "a" and path[-1] == "q"
    for src, dst in zip(path, path[1:]):
        assert src in g[dst].inputs
    free = (Kind.CONST, Kind.INPUT, Kind.REGISTER, Kind.FSM, Kind.SLICE, Kind.CAST)
    assert sum(g[n].kind not in free for n in path) == depth
    assert [n for n in path if g[n].kind not in free] == ["m", "s", "d", "n", "mx", "q"]


def test_registers_break_paths():
    """A chain through a register counts from the register, not from before it."""
    fmt = Q("FIX16_8")
    nodes = [make("u", Kind.INPUT, port="u", qformat=fmt),
             make("a1", Kind.NEG, ["u"], qformat=fmt), make("a2", Kind.NEG, ["a1"], qformat=fmt),
             make("a3", Kind.NEG, ["a2"], qformat=fmt),
             make("r", Kind.REGISTER, ["a3"], reset=0.0, qformat=fmt),
             make("b1", Kind.NEG, ["r"], qformat=fmt)]
    g = Graph.build("chain", nodes, [("b1", "b1")])
    assert longest_path(g) == (3, ("u", "a1", "a2", "a3"))


def test_unsigned_operand_needs_a_sign_bit_in_the_multiplier():
    """UFIX18 x FIX18 does not fit one 18x18 signed block: the unsigned operand enters with a
    zero sign bit (19 bits), as the Verilog multiplies it (backend/timing.py)."""
    from pendc.passes.resources import product_widths
    nodes = [make("a", Kind.INPUT, port="a", qformat=Q("UFIX18_10")),
             make("b", Kind.INPUT, port="b", qformat=Q("FIX18_10")),
             make("p", Kind.MUL, ["a", "b"], qformat=Q("FIX37_20"))]
    g = Graph.build("unsigned_product", nodes, [("p", "p")])
    assert product_widths(g, g["p"]) == (19, 18)
    assert dsp18_for(*product_widths(g, g["p"])) == 2
    signed = Graph.build("signed_product", [make("a", Kind.INPUT, port="a", qformat=Q("FIX18_10"))] + nodes[1:],
                         [("p", "p")])
    assert product_widths(signed, signed["p"]) == (18, 18)


def test_to_json_is_serialisable(res):
    data = json.loads(json.dumps(res.to_json()))
    assert data["dsp18"] == 5 and data["critical_path"] == list(res.critical_path)
    assert data["products"][0]["widths"] == res.products[0]["widths"]


def test_default_build_estimate():
    build = compile_cached(pendc.load_model(), BuildOptions(training_scale=0.02))   # the pass tests' short build
    r = build.resources
    g = build.graph
    n_mult = len(g.of_kind(Kind.MUL, Kind.GAIN)) + sum(1 for n in g.of_kind(Kind.LUT) if n.param("interpolate"))
    assert sum(r.multipliers.values()) == n_mult == len(r.products)
    # fitted to ECP5's 18x18 blocks: no product needs more than its level allows (32 bits at most)
    assert r.dsp_shape == "18x18" and r.dsp == sum(p["dsp"] for p in r.products)
    assert all(int(k.split("x")[0]) <= 32 and int(k.split("x")[1]) <= 32 for k in r.multipliers)
    assert r.luts == len(g.of_kind(Kind.LUT)) >= 5
    assert r.register_bits >= sum(g[s].qformat.width for s in ("x", "dx", "theta", "dtheta"))
    end = r.critical_path[-1]                   # the path ends where a state element or an output takes it
    assert end in dict(g.outputs).values() or any(g[c].kind in (Kind.REGISTER, Kind.FSM) for c in g.consumers[end])
    assert g[r.critical_path[0]].kind in (Kind.INPUT, Kind.REGISTER, Kind.FSM, Kind.CONST)
    assert r.logic_depth == longest_path(g)[0]


def test_schedule_lut4_counts_shared_operand_muxes():
    """A unit serving k products is a (k-1)-deep 2:1 mux per operand bit; no units, no muxes."""
    from pendc.passes.resources import schedule_lut4
    shared = {"ii": 8, "units": [{"name": "mul0", "widths": [32, 18], "uses": [["a", 1], ["b", 3], ["c", 5]]},
                                 {"name": "mul1", "widths": [18, 18], "uses": [["d", 2]]}]}
    r = schedule_lut4(shared)
    assert r["unit_mux"] == 2 * 50 + 0
    assert r["lut4"] == r["unit_mux"] + r["phase"] and 0 < r["phase"] < 50
    assert schedule_lut4({"ii": 1, "units": []}) == {"unit_mux": 0, "phase": 0, "lut4": 0}
