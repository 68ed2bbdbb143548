"""The IR verifier: every check has a graph that breaks it, and the message names the node."""

from __future__ import annotations

from dataclasses import replace

import pytest

from pendc.ir import lut as lut_sem
from pendc.ir.graph import Graph, GraphError
from pendc.ir.compare_ops import CompareOp
from pendc.ir.nodes import ConstParams, GainParams, Kind, SliceParams, make
from pendc.ir.qformat import QFormat, Rounding
from pendc.ir.verify import verify

Q = QFormat.parse
FSM_PARAMS = dict(states=("A", "B"), reset="A", transitions=(("*", "ge", 0.5, "B"), ("*", "lt", -0.5, "A")),
                  outputs=(0, 3), lo=-10.0, hi=10.0)


def lut_params(fin: QFormat, fout: QFormat, lo=-2.0, hi=2.0, addr_bits=4, interpolate=True, periodic=False):
    shift = lut_sem.grid_shift(lo, hi, addr_bits, fin)
    table = lut_sem.fill_table("sin(v)", lo, addr_bits, shift, fin, fout, interpolate, periodic)
    return dict(expr="sin(v)", lo=lo, hi=hi, periodic=periodic, addr_bits=addr_bits, interpolate=interpolate,
                shift=shift, table=table)


def base_nodes(typed: bool) -> list:
    """A small accumulator with one node of every kind; typed so that every rule just holds."""
    def f(text):
        return Q(text) if typed else None
    lut = lut_params(Q("FIX24_12"), Q("FIX16_14"))
    if not typed:
        lut = {k: v for k, v in lut.items() if k not in ("shift", "table")}
    gain = dict(value=0.5, cfmt="FIX32_31") if typed else dict(value=0.5)
    return [
        make("u", Kind.INPUT, port="u", qformat=f("FIX16_12")),
        make("x", Kind.REGISTER, ["s"], reset=0.0, qformat=f("FIX24_12")),
        make("f", Kind.FSM, ["x"], qformat=f("UFIX2_0"), **FSM_PARAMS),
        make("c1", Kind.CONST, value=1.0, qformat=f("FIX16_12")),
        make("k", Kind.GAIN, ["u"], qformat=f("FIX16_12"), **gain),
        make("s", Kind.ADD, ["x", "k"], qformat=f("FIX24_12")),
        make("d", Kind.SUB, ["x", "c1"], qformat=f("FIX24_12")),
        make("neg", Kind.NEG, ["x"], qformat=f("FIX24_12")),
        make("sgn", Kind.SLICE, ["x"], hi=-1, lo=-1, qformat=f("UFIX1_0")),
        make("ax", Kind.MUX, ["sgn", "x", "neg"], qformat=f("FIX24_12")),
        make("big", Kind.COMPARE, ["ax", "c1"], op="gt", qformat=f("UFIX1_0")),
        make("m", Kind.MUL, ["u", "u"], qformat=f("FIX32_24")),
        make("cast", Kind.CAST, ["m"], qformat=f("FIX16_8")),
        make("t", Kind.LUT, ["x"], qformat=f("FIX16_14"), **lut),
        make("bits", Kind.SLICE, ["f"], hi=1, lo=0, qformat=f("UFIX2_0")),
    ]


OUTPUTS = [("x", "x"), ("ax", "ax"), ("big", "big"), ("cast", "cast"), ("t", "t"), ("bits", "bits"), ("d", "d")]


def build(typed: bool, *changed, drop=(), outputs=OUTPUTS) -> Graph:
    """The base graph with some nodes replaced (by name) or added, and some dropped."""
    nodes = {n.name: n for n in base_nodes(typed)}
    for n in changed:
        nodes[n.name] = n
    return Graph.build("t", [n for k, n in nodes.items() if k not in drop], outputs)


def node(typed: bool, name: str):
    return {n.name: n for n in base_nodes(typed)}[name]


def raw(nodes, outputs=OUTPUTS) -> Graph:
    """A graph exactly as given: Graph.build would refuse most of these defects itself."""
    return Graph(name="raw", nodes=tuple(nodes), outputs=tuple(outputs))


def fails(graph: Graph, name: str, *words: str, typed: bool = False) -> str:
    with pytest.raises(GraphError) as e:
        verify(graph, typed=typed)
    msg = str(e.value)
    assert f"'{name}'" in msg and "\n" not in msg, msg
    for w in words:
        assert w in msg, msg
    return msg


def without(n, key):
    return replace(n, params=tuple((k, v) for k, v in n.params if k != key))


def refused(build_node, name: str, *words: str) -> str:
    """A node with a missing or malformed param cannot be built: GraphError names it."""
    with pytest.raises(GraphError) as e:
        build_node()
    msg = str(e.value)
    assert f"'{name}'" in msg and "\n" not in msg, msg
    for w in words:
        assert w in msg, msg
    return msg


def test_base_graphs_pass():
    verify(build(False))
    verify(build(True), typed=True)
    verify(build(True))     # a typed graph is also a valid untyped one


# -- structure -----------------------------------------------------------------------

def test_duplicate_name():
    nodes = base_nodes(False)
    fails(raw(nodes + [make("neg", Kind.NEG, ["u"])]), "neg", "duplicate")


def test_undefined_input():
    nodes = [n if n.name != "d" else make("d", Kind.SUB, ["x", "nope"]) for n in base_nodes(False)]
    fails(raw(nodes), "d", "undefined", "'nope'")


@pytest.mark.parametrize("name, inputs", [("neg", ["x", "x"]), ("s", ["x"]), ("k", []), ("x", [])])
def test_arity(name, inputs):
    nodes = [replace(m, inputs=tuple(inputs)) if m.name == name else m for m in base_nodes(False)]
    fails(raw(nodes), name, "input")


def test_mux_needs_two_data_inputs():
    fails(build(False, make("ax", Kind.MUX, ["sgn", "x"])), "ax", "select and at least 2")


@pytest.mark.parametrize("name, key", [("c1", "value"), ("u", "port"), ("k", "value"), ("x", "reset"),
                                       ("t", "expr"), ("t", "lo"), ("t", "hi"), ("t", "periodic"),
                                       ("t", "addr_bits"), ("t", "interpolate"), ("sgn", "hi"), ("bits", "lo"),
                                       ("big", "op"), ("f", "states"), ("f", "reset"), ("f", "transitions"),
                                       ("f", "outputs"), ("f", "lo"), ("f", "hi")])
def test_missing_param(name, key):
    refused(lambda: without(node(False, name), key), name, f"missing param '{key}'")


@pytest.mark.parametrize("name, changes, words", [
    ("c1", dict(value=float("nan")), ["finite"]),
    ("x", dict(reset="zero"), ["reset"]),
    ("u", dict(port=""), ["port"]),
    ("t", dict(addr_bits=0), ["addr_bits"]),
    ("t", dict(addr_bits=40), ["addr_bits"]),
    ("t", dict(lo=2.0, hi=-2.0), ["interval"]),
    ("t", dict(lo=None), ["interval"]),
    ("t", dict(periodic="yes"), ["periodic"]),
    ("bits", dict(hi=0, lo=1), ["'hi'"]),
    ("bits", dict(hi=3, lo=-1), ["'lo'"]),
    ("big", dict(op="lte"), ["lte"]),
    ("f", dict(reset="C"), ["reset state"]),
    ("f", dict(transitions=(("*", "ge", 0.5, "C"),)), ["unknown state 'C'"]),
    ("f", dict(transitions=(("Z", "ge", 0.5, "B"),)), ["unknown state 'Z'"]),
    ("f", dict(transitions=(("*", "eq", 0.5, "B"),)), ["op 'eq'"]),
    ("f", dict(transitions=(("*", "ge", "half", "B"),)), ["threshold"]),
    ("f", dict(transitions=(("*", "ge", 0.5),)), ["(from, op, threshold, to)"]),
    ("f", dict(outputs=(0,)), ["outputs"]),
    ("f", dict(states=("A", "A")), ["distinct"]),
    ("f", dict(lo=1.0, hi=-1.0), ["empty"]),
    ("k", dict(cfmt="FIX32"), ["cfmt", "not a Q-format"]),
    ("k", dict(gain=2.0), ["unknown param 'gain'"]),
    ("sgn", dict(sign_bit="yes"), ["sign_bit"]),
    ("u", dict(max_abs=float("inf")), ["max_abs", "finite"]),
])
def test_bad_param(name, changes, words):
    refused(lambda: node(False, name).with_params(**changes), name, *words)
    kind, inputs = node(False, name).kind, node(False, name).inputs
    refused(lambda: make(name, kind, inputs, **{**dict(node(False, name).params), **changes}), name, *words)


def test_verifier_refuses_params_of_another_kind():
    # Node.__post_init__ makes this impossible through the constructors; the verifier still
    # checks it for nodes patched behind their back
    bad = node(False, "k")
    object.__setattr__(bad, "params", ConstParams(value=0.5))
    fails(build(False, bad), "k", "ConstParams", "GainParams")


def test_typed_params_read_back_in_legacy_form():
    k = node(True, "k")
    assert k.params.cfmt == Q("FIX32_31") and k.param("cfmt") == "FIX32_31"
    sgn, bits = node(False, "sgn"), node(False, "bits")
    assert sgn.params.sign_bit and (sgn.param("hi"), sgn.param("lo")) == (-1, -1)
    assert sgn.params.bits(24) == (23, 23) and bits.params.bits(24) == (1, 0) and bits.params.width == 2
    assert node(False, "big").params.op is CompareOp.GT and node(False, "big").param("op") == "gt"
    f = node(False, "f")
    assert f.params.transitions[0].op is CompareOp.GE and f.param("transitions") == FSM_PARAMS["transitions"]
    # typed and keyword construction give one node
    assert make("k", Kind.GAIN, ["u"], params=GainParams(0.5, cfmt=Q("FIX32_31")),
                qformat=Q("FIX16_12")) == k
    assert make("sgn", Kind.SLICE, ["x"], params=SliceParams.sign()) == sgn
    with pytest.raises(GraphError, match="not both"):
        make("k", Kind.GAIN, ["u"], params=GainParams(0.5), value=0.5)


def test_untabulated_lut_domain_may_be_open():
    verify(build(False, node(False, "t").with_params(lo=None, hi=None)))


def test_duplicate_input_port():
    fails(build(False, make("u2", Kind.INPUT, port="u"), make("s", Kind.ADD, ["x", "u2"]),
                make("k", Kind.GAIN, ["u"], value=0.5)), "u2", "port 'u'", "'u'")


def test_combinational_cycle():
    nodes = base_nodes(False)
    # k reads s, s reads k: only a register may close a loop
    nodes = [make("k", Kind.GAIN, ["s"], value=0.5) if n.name == "k" else n for n in nodes]
    msg = fails(raw(nodes), "k", "combinational cycle")
    assert "k <- s <- k" in msg


def test_cycle_through_register_or_fsm_is_fine():
    # x = reg(s), s = x + k: the base graph's accumulator; f = fsm(x) feeds bits
    loop = build(False, make("k", Kind.GAIN, ["bits"], value=0.5))   # x -> f -(fsm)-> bits -> k -> s -> x
    verify(loop)


def test_evaluation_order():
    nodes = base_nodes(False)
    ax = next(n for n in nodes if n.name == "ax")
    nodes.remove(ax)
    nodes.insert(0, ax)
    fails(raw(nodes), "ax", "before its input")


def test_dangling_node():
    fails(build(False, make("spare", Kind.NEG, ["x"])), "spare", "dangling")


def test_dangling_register():
    # a register that feeds only itself never reaches an output either
    fails(build(False, make("r", Kind.REGISTER, ["r"], reset=0.0)), "r", "dangling")


def test_outputs():
    fails(raw(base_nodes(False), OUTPUTS + [("y", "nope")]), "nope", "output 'y'")
    fails(raw(base_nodes(False), OUTPUTS + [("x", "ax")]), "ax", "duplicate output port 'x'")
    with pytest.raises(GraphError, match="no outputs"):
        verify(raw(base_nodes(False), []))


# -- typed ---------------------------------------------------------------------------

def typed_with(*changed) -> Graph:
    return build(True, *changed)


def tnode(name: str, **changes):
    n = node(True, name)
    fmt = changes.pop("qformat", None)
    n = n.with_params(**changes) if changes else n
    return n.typed(Q(fmt)) if fmt else n


def test_untyped_node_in_typed_graph():
    fails(typed_with(replace(node(True, "neg"), qformat=None)), "neg", "no Q-format", typed=True)


@pytest.mark.parametrize("name, changes, words", [
    ("x", dict(qformat="FIX24_11"), ["differs", "FIX24_12"]),
    ("big", dict(qformat="UFIX2_0"), ["UFIX1_0"]),
    ("big", dict(qformat="FIX1_0"), ["UFIX1_0"]),
    ("sgn", dict(qformat="UFIX2_0"), ["UFIX1_0"]),
    ("bits", dict(qformat="UFIX3_0"), ["UFIX2_0"]),
    ("bits", dict(qformat="UFIX2_1"), ["UFIX2_0"]),
    ("bits", dict(hi=5, lo=0, qformat="UFIX6_0"), ["outside", "2-bit"]),
    ("f", dict(qformat="UFIX3_0"), ["UFIX2_0"]),
    ("k", dict(cfmt="FIX40_39"), ["constant", "40 bits"]),
    ("k", dict(value=3.0), ["does not fit", "FIX32_31"]),
    ("t", dict(table=(0,) * 16), ["17 entries"]),
    ("t", dict(table=(1 << 20,) * 17), ["entry 0", "FIX16_14"]),
    ("t", dict(shift=-1), ["shift"]),
    ("t", dict(lo=-2.0, hi=1.5, periodic=True), ["period"]),
    ("t", dict(qformat="FIX60_14"), ["interpolation", "71 bits"]),
    ("cast", dict(qformat="FIX64_60"), ["aligned to the output", "68 bits"]),
])
def test_typed_rules(name, changes, words):
    g = typed_with(tnode(name, **changes))
    verify(g)   # structurally fine: only the typed check finds it
    fails(g, name, *words, typed=True)


@pytest.mark.parametrize("key", ["cfmt", "table", "shift"])
def test_typed_params_required(key):
    name = "k" if key == "cfmt" else "t"
    fails(typed_with(without(node(True, name), key)), name, f"missing param '{key}'", typed=True)


def test_register_input_with_other_format():
    fails(typed_with(tnode("s", qformat="FIX25_12")), "x", "differs", typed=True)


@pytest.mark.parametrize("fmt", ["FIX1_0", "UFIX2_1"])
def test_mux_select_must_be_unsigned_integer(fmt):
    g = typed_with(make("sel", Kind.CAST, ["sgn"], qformat=Q(fmt)),
                   make("ax", Kind.MUX, ["sel", "x", "neg"], qformat=Q("FIX24_12")))
    fails(g, "ax", "select 'sel'", "UFIXw_0", typed=True)


def test_mux_select_reaches_all_inputs():
    g = typed_with(make("ax", Kind.MUX, ["big", "x", "neg", "sgn"], qformat=Q("FIX24_12")),
                   make("big", Kind.COMPARE, ["x", "c1"], op="gt", qformat=Q("UFIX1_0")),
                   make("big2", Kind.COMPARE, ["ax", "c1"], op="gt", qformat=Q("UFIX1_0")))
    g = Graph.build("t", g.nodes, [(p, "big2" if n == "big" else n) for p, n in OUTPUTS])
    fails(g, "ax", "3 data inputs", "1-bit select", typed=True)


def test_mux_input_alignment_fits_64_bits():
    g = typed_with(make("neg", Kind.NEG, ["x"], qformat=Q("FIX60_0")))
    fails(g, "ax", "input 'neg' aligned", "72 bits", typed=True)


@pytest.mark.parametrize("a, b, ok", [("FIX32_12", "FIX32_30", True),       # 20 + 30 + 1 = 51
                                      ("FIX60_0", "FIX16_12", False),       # 60 + 12 + 1 = 73
                                      ("FIX40_20", "FIX40_20", True)])      # 20 + 20 + 1 = 41
def test_aligned_sum_and_compare_fit_64_bits(a, b, ok):
    nodes = [make("a", Kind.INPUT, port="a", qformat=Q(a)), make("b", Kind.INPUT, port="b", qformat=Q(b)),
             make("s", Kind.ADD, ["a", "b"], qformat=Q("FIX32_0")),
             make("d", Kind.SUB, ["a", "b"], qformat=Q("FIX32_0")),
             make("c", Kind.COMPARE, ["a", "b"], op="lt", qformat=Q("UFIX1_0"))]
    for name in ("s", "d", "c"):
        g = Graph.build("t", [n for n in nodes if n.kind is Kind.INPUT or n.name == name], [("y", name)])
        if ok:
            verify(g, typed=True)
        else:
            fails(g, name, "64", typed=True)


def test_negation_fits_64_bits():
    nodes = [make("a", Kind.INPUT, port="a", qformat=Q("FIX64_0")), make("n", Kind.NEG, ["a"], qformat=Q("FIX64_0"))]
    fails(Graph.build("t", nodes, [("y", "n")]), "n", "negation", "65 bits", typed=True)


def test_multiplier_operands_at_most_32_bits():
    g = typed_with(tnode("u", qformat="FIX33_12"))
    # k (GAIN of u) comes before m (MUL of u, u) in evaluation order
    fails(g, "k", "multiplier operand 'u'", "33 bits", typed=True)
    g = typed_with(make("k", Kind.GAIN, ["c1"], value=0.5, cfmt="FIX32_31", qformat=Q("FIX16_12")),
                   tnode("u", qformat="FIX33_12"))
    fails(g, "m", "multiplier operand 'u'", typed=True)


def test_typed_check_needs_lut_domain():
    g = typed_with(tnode("t", lo=None, hi=None))
    fails(g, "t", "domain", typed=True)


def test_rounding_does_not_matter_to_verifier():
    verify(typed_with(replace(node(True, "s"), rounding=Rounding.TRUNCATE)), typed=True)


def test_lowered_pendulum_passes_after_each_pass():
    import numpy as np

    from pendc.model.modelfile import load_model
    from pendc.passes.lower import lower_model
    from pendc.passes.qformats import assign_qformats
    from pendc.passes.ranges import analyze_ranges
    from pendc.passes.tabulate import fill_lut_tables, tabulate_luts

    g = lower_model(load_model(), dt=1e-4)
    verify(g)
    t = np.linspace(0.0, 0.05, 51)
    ranges = analyze_ranges(g, {"s": (t, 6.0 + np.sin(40 * t))}, 1e-4, engine="interpreter")
    g = tabulate_luts(g, ranges)
    verify(g)
    verify(fill_lut_tables(assign_qformats(g, ranges)), typed=True)


def test_text_form_prints_typed_params_in_their_legacy_form():
    # built from the typed classes only; the text form is the one graphs printed before typing
    from pendc.ir.compare_ops import CompareOp as Op
    from pendc.ir.nodes import CompareParams, FsmParams, InputParams, Transition
    nodes = [make("u", Kind.INPUT, params=InputParams("u", max_abs=10.0), qformat=Q("FIX16_12")),
             make("k", Kind.GAIN, ["u"], params=GainParams(0.5, cfmt=Q("FIX32_31")), qformat=Q("FIX16_12")),
             make("sgn", Kind.SLICE, ["k"], params=SliceParams.sign(), qformat=Q("UFIX1_0")),
             make("big", Kind.COMPARE, ["k", "u"], params=CompareParams(Op.GT), qformat=Q("UFIX1_0")),
             make("f", Kind.FSM, ["u"], qformat=Q("UFIX2_0"),
                  params=FsmParams(states=("A", "B"), reset="A", outputs=(0, 3), lo=-10.0, hi=10.0,
                                   transitions=(Transition("*", Op.GE, 0.5, "B"), Transition("*", Op.LT, -0.5, "A"))))]
    g = Graph.build("t", nodes, [("sgn", "sgn"), ("big", "big"), ("f", "f")])
    verify(g, typed=True)
    assert g.text().splitlines()[1:6] == [
        "  u = input() max_abs=10.0 port=u : FIX16_12 round wrap",
        "  f = fsm(u) hi=10.0 lo=-10.0 outputs=(0,3) reset=A states=(A,B) transitions=((*,ge,0.5,B),(*,lt,-0.5,A))"
        " : UFIX2_0 round wrap",
        "  k = gain(u) cfmt=FIX32_31 value=0.5 : FIX16_12 round wrap",
        "  sgn = slice(k) hi=-1 lo=-1 : UFIX1_0 round wrap",
        "  big = cmp(k, u) op=gt : UFIX1_0 round wrap"]
