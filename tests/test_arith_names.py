"""Names in the generated core are unique by construction (pendc.backend.arith.Netlist):
node values are claimed first, helper wires and registers take fresh names around them."""

from collections import Counter

import pytest

from pendc.backend.arith import Netlist, signed_width, wrap_signed
from pendc.backend.viewmodel import build_view
from pendc.ir.graph import Graph
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat
from pendc.passes.schedule import schedule_graph


def test_fresh_names_step_around_taken_ones():
    net = Netlist()
    net.claim("n_p_x")
    assert net.fresh("n_p_x") == "n_p_x_1"
    assert net.fresh("n_p_x") == "n_p_x_2"
    assert net.fresh("n_q") == "n_q"
    with pytest.raises(ValueError, match="claimed twice"):
        net.claim("n_q")


def test_an_own_wire_needs_its_claim_and_is_declared_once():
    net = Netlist()
    net.claim("n_a")
    assert net.wire("n_a", 4, "4'sd1", own=True) == "n_a"
    with pytest.raises(ValueError, match="not claimed"):
        net.wire("n_a", 4, "4'sd1", own=True)
    assert net.wire("n_a", 4, "4'sd2") == "n_a_1"       # a helper asking for it gets a fresh name


@pytest.mark.parametrize("lo, hi, bits", [(0, 0, 1), (-1, 0, 1), (0, 1, 2), (-128, 127, 8), (-129, 0, 9),
                                          (0, 255, 9), (-5, 16, 6)])
def test_signed_width(lo, hi, bits):
    assert signed_width(lo, hi) == bits


def test_wrap_signed():
    assert [wrap_signed(v, 4) for v in (7, 8, -8, -9, 16, 21)] == [7, -8, -8, 7, 0, 5]


def _colliding_graph():
    """Node names that extend each other the way helper wires extend a node's name."""
    f8, f12 = QFormat(True, 8, 0), QFormat(True, 12, 2)
    nodes = [make("u", Kind.INPUT, qformat=f8, port="u"),
             make("k", Kind.CONST, qformat=QFormat(True, 6, 2), value=1.25),
             make("p", Kind.MUL, ("u", "k"), qformat=f12),
             make("p_x", Kind.ADD, ("p", "k"), qformat=f12),
             make("p_x_a", Kind.SUB, ("p_x", "p"), qformat=f12),
             make("p_x_ovf", Kind.CAST, ("p_x_a",), qformat=QFormat(True, 6, 0)),
             make("f", Kind.COMPARE, ("u", "k"), qformat=QFormat(False, 1, 0), op="ge"),
             make("m", Kind.FSM, ("f",), qformat=QFormat(False, 2, 0), states=("a", "b"), reset="a",
                  transitions=(("*", "ge", 0.5, "b"),), outputs=(1, 2), lo=0.0, hi=1.0),
             make("m_state", Kind.CAST, ("m",), qformat=QFormat(True, 4, 0)),
             make("s", Kind.ADD, ("p_x_ovf", "m_state"), qformat=QFormat(True, 8, 0))]
    outputs = []
    for port in ("x", "dx", "theta", "dtheta"):
        nodes.append(make(f"r_{port}", Kind.REGISTER, ("s",), qformat=QFormat(True, 8, 0), reset=0.0))
        outputs.append((port, f"r_{port}"))
    return Graph.build("names", nodes, outputs)


@pytest.mark.parametrize("clock_ns", [float("inf"), 4.0])
def test_every_name_of_the_core_is_declared_once(clock_ns):
    graph = _colliding_graph()
    view = build_view(graph, "core", schedule_graph(graph, clock_ns=clock_ns))
    names = ([d[0] for d in view.net.decls] + [r[0] for r in view.registers] + [f["state"] for f in view.fsms]
             + [r[0] for r in view.lut_regs] + [r[0] for r in view.dp.pipe_regs] + [p[1] for p in view.ports])
    assert [n for n, c in Counter(names).items() if c > 1] == []
    declared = set(names)
    for n in graph.nodes:       # every node's value is exactly n_<name>
        assert f"n_{n.name}" in declared
    assert "n_m_state" in declared and view.fsms[0]["state"] != "n_m_state"


def test_a_pipelined_overflow_flag_does_not_take_a_node_name():
    """The pipeline register of node s's overflow term (n_s_ovf_p) beside a node named s_ovf_p."""
    f8 = QFormat(True, 8, 0)
    nodes = [make("u", Kind.INPUT, qformat=f8, port="u"),
             make("s", Kind.ADD, ("u", "u"), qformat=f8),
             make("s_ovf_p", Kind.MUL, ("s", "s"), qformat=QFormat(True, 16, 0)),
             make("m", Kind.MUL, ("s_ovf_p", "s_ovf_p"), qformat=QFormat(True, 32, 0)),
             make("m2", Kind.MUL, ("m", "s"), qformat=QFormat(True, 40, 0))]
    outputs = []
    for port in ("x", "dx", "theta", "dtheta"):
        nodes.append(make(f"r_{port}", Kind.REGISTER, ("m2",), qformat=QFormat(True, 40, 0), reset=0.0))
        outputs.append((port, f"r_{port}"))
    graph = Graph.build("ovf", nodes, outputs)
    view = build_view(graph, "core", schedule_graph(graph, clock_ns=4.0))
    assert view.ii > 1 and view.dp.pipe_regs
    names = [d[0] for d in view.net.decls] + [r[0] for r in view.registers] + [r[0] for r in view.dp.pipe_regs]
    assert [n for n, c in Counter(names).items() if c > 1] == []
