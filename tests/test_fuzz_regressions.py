"""Shrunk counterexamples of the backend fuzzer (tests/test_fuzz_backend.py), one test each.

Each graph is the smallest form of a mismatch the fuzzer found, with the defect it showed
in its docstring; every one is fixed, and the generator (tests/graphgen.py) produces each
kind of case again.
"""

from __future__ import annotations

import pytest

from fuzzcases import case_source
from fuzzharness import check_batch, every_adder_subtracts, simulator_available
from fuzzshrink import shrink
from graphgen import FuzzCase
from pendc.ir.graph import Graph
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import Overflow, QFormat, Rounding
from pendc.ir.verify import verify

pytestmark = pytest.mark.skipif(not simulator_available("icarus"), reason="iverilog not installed")

FLAG = QFormat(False, 1, 0)


def case(u_fmt: QFormat, nodes: list, shown: str, u: tuple, schedule=None) -> FuzzCase:
    """A graph reading ``u`` whose four state ports show node ``shown`` through registers."""
    fmt = {n.name: n.qformat for n in nodes}
    nodes = [make("u", Kind.INPUT, qformat=u_fmt, port="u")] + nodes
    outputs = []
    for port in ("x", "dx", "theta", "dtheta"):
        nodes.append(make(f"p_{port}", Kind.REGISTER, (shown,), qformat=fmt.get(shown, u_fmt), reset=0.0))
        outputs.append((port, f"p_{port}"))
    graph = Graph.build("fuzz", nodes, outputs)
    verify(graph, typed=True)
    return FuzzCase(graph=graph, u=u, schedule=schedule)


def mismatches(c: FuzzCase, tmp_path) -> list:
    return [str(m) for m in check_batch([c], tmp_path, "icarus", golden=None).mismatches]


# ---------------------------------------------------------------- fixed (pendc/backend/arith.py)

def test_negative_value_into_an_unsigned_format_overflows(tmp_path):
    """-2 + -2 into UFIX3_0: wraps to 4 and raises the flag (the adder's result was never checked)."""
    c = case(QFormat(True, 2, 0), [make("s", Kind.ADD, ("u", "u"), qformat=QFormat(False, 3, 0))], "s",
             u=(-2, -2, 1, 0))
    assert mismatches(c, tmp_path) == []


@pytest.mark.parametrize("rounding", [Rounding.NEAREST, Rounding.TRUNCATE])
def test_rounding_away_more_bits_than_the_value_has(tmp_path, rounding):
    """FIX4_0 into FIX4_-6 drops six fraction bits of a four-bit value (was a reversed part select)."""
    c = case(QFormat(True, 4, 0), [make("c", Kind.CAST, ("u",), qformat=QFormat(True, 4, -6), rounding=rounding)],
             "c", u=(7, -8, -1, 0, 5))
    assert mismatches(c, tmp_path) == []


def test_one_bit_signed_operand_is_sign_extended(tmp_path):
    """A FIX1_0 constant (-1) in a sum: its sign extension selected a bit of a scalar wire."""
    nodes = [make("one", Kind.CONST, qformat=QFormat(True, 1, 0), value=-1.0),
             make("s", Kind.ADD, ("u", "one"), qformat=QFormat(True, 9, 0))]
    assert mismatches(case(QFormat(True, 8, 0), nodes, "s", u=(127, -128, 0, 3)), tmp_path) == []


def test_unsigned_saturation_clamps_to_zero(tmp_path):
    nodes = [make("d", Kind.SUB, ("u", "k"), qformat=QFormat(False, 6, 0), overflow=Overflow.SATURATE),
             make("k", Kind.CONST, qformat=QFormat(True, 8, 0), value=10.0)]
    assert mismatches(case(QFormat(True, 8, 0), nodes, "d", u=(3, 100, 10, -128, 127)), tmp_path) == []



def test_sum_of_unsigned_values(tmp_path):
    """255 + 255 (UFIX8_0) into FIX10_0: the sum was sized with no sign bit for the
    unsigned operands and wrapped to -2 (viewmodel ADD/SUB width)."""
    c = case(QFormat(False, 8, 0), [make("s", Kind.ADD, ("u", "u"), qformat=QFormat(True, 10, 0))], "s",
             u=(255, 200, 1, 0))
    assert mismatches(c, tmp_path) == []


def test_cast_of_an_unsigned_value(tmp_path):
    """UFIX8_0 255 cast to FIX10_0: arith.requantize read the unsigned input as
    two's complement and gave -1."""
    c = case(QFormat(False, 8, 0), [make("c", Kind.CAST, ("u",), qformat=QFormat(True, 10, 0))], "c",
             u=(255, 128, 1, 0))
    assert mismatches(c, tmp_path) == []


def test_product_of_an_unsigned_value(tmp_path):
    """UFIX8_0 200 * 2: timing.Datapath.product sign-extended the unsigned
    operand and gave -112."""
    nodes = [make("two", Kind.CONST, qformat=QFormat(True, 3, 0), value=2.0),
             make("prod", Kind.MUL, ("u", "two"), qformat=QFormat(True, 12, 0))]
    assert mismatches(case(QFormat(False, 8, 0), nodes, "prod", u=(200, 255, 1, 0)), tmp_path) == []


def test_node_names_that_extend_each_other(tmp_path):
    """Nodes 'p' and 'p_x': the helper wire n_p_x of 'p' was declared
    again as the value of 'p_x' (names now come from the netlist's allocator)."""
    nodes = [make("two", Kind.CONST, qformat=QFormat(True, 3, 0), value=2.0),
             make("p", Kind.MUL, ("u", "two"), qformat=QFormat(True, 12, 0))]
    assert mismatches(case(QFormat(True, 8, 0), nodes, "p", u=(100, -3, 1, 0)), tmp_path) == []


def test_a_pipelined_overflow_term_beside_a_node_named_after_it(tmp_path):
    """Under a 4 ns clock the overflow term of 's' is counted from a register named n_s_ovf_p,
    which was also the value of the node 's_ovf_p' (timing.finish named it without the netlist)."""
    f8 = QFormat(True, 8, 0)
    nodes = [make("s", Kind.ADD, ("u", "u"), qformat=f8),
             make("s_ovf_p", Kind.MUL, ("s", "s"), qformat=QFormat(True, 16, 0)),
             make("m", Kind.MUL, ("s_ovf_p", "s_ovf_p"), qformat=QFormat(True, 32, 0)),
             make("m2", Kind.MUL, ("m", "s"), qformat=QFormat(True, 40, 0))]
    c = case(f8, nodes, "m2", u=(100, -3, 1, 0, 127, -128), schedule=(4.0, None))
    assert mismatches(c, tmp_path) == []


def test_slice_of_a_one_bit_value(tmp_path):
    """SLICE 0..0 of a 1-bit flag printed n_f[0], a bit select of a scalar
    wire (Icarus: 'can not select part of scalar')."""
    nodes = [make("f", Kind.COMPARE, ("u", "u"), qformat=FLAG, op="ge"),
             make("b", Kind.SLICE, ("f",), qformat=FLAG, hi=0, lo=0)]
    assert mismatches(case(QFormat(True, 8, 0), nodes, "b", u=(1, 2, 3)), tmp_path) == []


def test_table_with_more_segments_than_its_input_reaches(tmp_path):
    """16 segments, 3-bit index: the index was compared with
    literal(16, 4) = -16, so every input clamped high."""
    from pendc.ir import lut as lut_sem
    fin, fout = QFormat(True, 2, 0), QFormat(True, 12, 8)
    table = lut_sem.fill_table("tanh(v/4)", -2.0, 4, 0, fin, fout, False, False)
    lut = make("t", Kind.LUT, ("u",), qformat=fout, expr="tanh(v/4)", lo=-2.0, hi=13.0, periodic=False,
               addr_bits=4, interpolate=False, shift=0, table=table)
    assert mismatches(case(fin, [lut], "t", u=(0, 1, -2, -1, 0)), tmp_path) == []


def test_fsm_threshold_beyond_its_input_range(tmp_path):
    """Threshold 2 on a UFIX1_0 input was printed 2'sd2 = -2, so 'ge'
    always fired (thresholds beyond the range are now constant tests)."""
    nodes = [make("f", Kind.COMPARE, ("u", "u"), qformat=FLAG, op="gt"),
             make("m", Kind.FSM, ("f",), qformat=QFormat(False, 3, 0), states=("a", "b"), reset="a",
                  transitions=(("*", "ge", 1.5, "b"),), outputs=(1, 6), lo=0.0, hi=1.0)]
    assert mismatches(case(QFormat(True, 4, 0), nodes, "m", u=(1, 2, 3, 4)), tmp_path) == []


def test_fsm_input_range_beyond_its_input_format(tmp_path):
    """lo = hi = 1.5 on a UFIX1_0 input was printed 2'sd2 = -2: the RTL
    never raised the flag the interpreter raised at step 0 (long run, seed 11 batch 9)."""
    nodes = [make("f", Kind.COMPARE, ("u", "u"), qformat=FLAG, op="gt"),
             make("m", Kind.FSM, ("f",), qformat=QFormat(False, 3, 0), states=("a", "b"), reset="a",
                  transitions=(("*", "ge", 1.0, "b"),), outputs=(1, 6), lo=1.5, hi=1.5)]
    assert mismatches(case(QFormat(True, 4, 0), nodes, "m", u=(1, 2, 3, 4)), tmp_path) == []


def test_pipelined_schedule_of_a_register_loop(tmp_path):
    """A register reading a node emitted after it, under a 10 ns clock goal (was a KeyError in timing.py)."""
    nodes = [make("r", Kind.REGISTER, ("s",), qformat=QFormat(True, 12, 0), reset=0.0),
             make("s", Kind.ADD, ("r", "u"), qformat=QFormat(True, 12, 0))]
    c = case(QFormat(True, 8, 0), nodes, "r", u=(1, 2, 3, 4, 5), schedule=(10.0, None))
    assert mismatches(c, tmp_path) == []


def test_table_addressed_by_a_shared_multiplier(tmp_path):
    from pendc.ir import lut as lut_sem
    fin, fout = QFormat(True, 2, -5), QFormat(True, 25, 25)
    table = lut_sem.fill_table("tanh(v/4)", 0.0, 1, 2, fin, fout, True, True)
    nodes = [make("r0", Kind.REGISTER, ("r0_next",), qformat=QFormat(True, 4, 0), reset=6.0),
             make("r0_next", Kind.CONST, qformat=QFormat(True, 4, 0), value=0.0),
             make("sq", Kind.MUL, ("r0", "r0"), qformat=fin, rounding=Rounding.TRUNCATE, overflow=Overflow.SATURATE),
             make("t", Kind.LUT, ("sq",), qformat=fout, expr="tanh(v/4)", lo=0.0, hi=256.0, periodic=True,
                  addr_bits=1, interpolate=True, shift=2, table=table),
             make("k", Kind.CONST, qformat=QFormat(True, 6, -3), value=0.0),
             make("g", Kind.GAIN, ("k",), qformat=QFormat(True, 28, 22), cfmt="FIX32_29", value=-3.999999998137355),
             make("s", Kind.ADD, ("t", "g"), qformat=QFormat(True, 30, 22)),
             make("uu", Kind.ADD, ("u", "s"), qformat=QFormat(True, 30, 22))]
    c = case(QFormat(True, 8, 0), nodes, "uu", u=(3, 4, 5), schedule=(10.0, 3))
    assert mismatches(c, tmp_path) == []


def test_mux_select_beyond_its_inputs(tmp_path):
    """A 2-bit select over three data inputs reading 3: the interpreter and
    golden kernel raised IndexError, the Verilog picked the last input; now all pick the last
    input (pendc.ir.nodes)."""
    nodes = [make("sel", Kind.SLICE, ("u",), qformat=QFormat(False, 2, 0), hi=1, lo=0),
             make("m", Kind.MUX, ("sel", "u", "u", "u"), qformat=QFormat(True, 8, 0))]
    assert mismatches(case(QFormat(True, 8, 0), nodes, "m", u=(0, 1, 2, 3)), tmp_path) == []



def test_shrinking_keeps_the_failure_and_drops_the_rest(tmp_path):
    """The shrinker on a planted miscompile padded with an unrelated node and a long input."""
    nodes = [make("k", Kind.CONST, qformat=QFormat(True, 6, 2), value=1.5),
             make("s", Kind.ADD, ("u", "k"), qformat=QFormat(True, 12, 2)),
             make("n", Kind.NEG, ("u",), qformat=QFormat(True, 10, 0)),
             make("z", Kind.CAST, ("n",), qformat=QFormat(True, 12, 2)),
             make("t", Kind.ADD, ("s", "z"), qformat=QFormat(True, 12, 2))]
    big = case(QFormat(False, 8, 0), nodes, "t", u=(0, 0, 0, 255, 3) + (7,) * 15)
    assert check_batch([big], tmp_path, "icarus", golden=0, mutate=every_adder_subtracts).mismatches
    small = shrink(big, tmp_path, "icarus", budget=25, mutate=every_adder_subtracts)
    assert check_batch([small], tmp_path, "icarus", golden=0, mutate=every_adder_subtracts).mismatches
    assert len(small.u) < len(big.u) and len(small.graph.nodes) < len(big.graph.nodes)
    namespace = {}
    exec("import math\nfrom graphgen import FuzzCase\nfrom pendc.ir.graph import Graph\n"
         "from pendc.ir.nodes import Kind, make\nfrom pendc.ir.qformat import Overflow, QFormat, Rounding\n"
         + case_source(small), namespace)
    assert namespace["case"].graph.text() == small.graph.text() and namespace["case"].u == small.u
