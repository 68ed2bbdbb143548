"""round_operands_early: the rounding of a sum or a select moved onto the one operand that carries
the extra fraction bits computes the same numbers to the bit (the short chain's typed graph)."""

import numpy as np
import pytest

from pendc.ir.compare_ops import CompareOp
from pendc.ir.graph import Graph
from pendc.ir.interpret import FixedInterpreter
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat, Rounding
from pendc.passes.round_early import round_operands_early

FINE, COARSE, OUT = QFormat(True, 24, 14), QFormat(True, 16, 4), QFormat(True, 18, 4)


def _graph(rounding=Rounding.NEAREST):
    """fine - coarse, coarse + fine, coarse - fine, fine + fine, and a select of the two, each into
    a format with the coarse input's fraction bits."""
    def out(name, kind, inputs, **kw):
        return make(name, kind, inputs, qformat=OUT, rounding=rounding, **kw)
    nodes = [make("fine", Kind.INPUT, port="fine", max_abs=500.0).typed(FINE),
             make("coarse", Kind.INPUT, port="coarse", max_abs=2000.0).typed(COARSE),
             make("sel", Kind.COMPARE, ["fine", "coarse"], op=CompareOp.GT).typed(QFormat(False, 1, 0)),
             out("sum", Kind.ADD, ["coarse", "fine"]), out("diff", Kind.SUB, ["fine", "coarse"]),
             out("back", Kind.SUB, ["coarse", "fine"]), out("twice", Kind.ADD, ["fine", "fine"]),
             out("pick", Kind.MUX, ["sel", "coarse", "fine"])]
    return Graph.build("t", nodes, [(n, n) for n in ("sum", "diff", "back", "twice", "pick")])


@pytest.mark.parametrize("rounding", [Rounding.NEAREST, Rounding.TRUNCATE])
def test_same_numbers_to_the_bit(rounding):
    g = _graph(rounding)
    moved = round_operands_early(g)
    rng = np.random.default_rng(7)
    fine = [int(v) for v in rng.integers(-(1 << 22), 1 << 22, 4000)]
    coarse = [int(v) for v in rng.integers(-(1 << 14), 1 << 14, 4000)]
    # ties: fine values exactly half an output LSB off the coarse grid
    fine[:200] = [(k << 10) + (1 << 9) for k in range(-100, 100)]
    a = FixedInterpreter(g).run({"fine": fine, "coarse": coarse})
    b = FixedInterpreter(moved).run({"fine": fine, "coarse": coarse})
    for port in ("sum", "diff", "back", "twice", "pick"):
        assert list(a.outputs[port]) == list(b.outputs[port]), port


def test_which_roundings_move():
    """A sum's one fine operand and every fine input of a select get a cast; a subtrahend (a tie
    would round the other way) and a sum of two fine operands keep the rounding after the sum."""
    g = round_operands_early(_graph())
    cast_of = {n.name: n.inputs[0] for n in g.of_kind(Kind.CAST)}
    assert [cast_of.get(i) for i in g["sum"].inputs] == [None, "fine"]
    assert [cast_of.get(i) for i in g["diff"].inputs] == ["fine", None]
    assert g["back"].inputs == ("coarse", "fine") and g["twice"].inputs == ("fine", "fine")
    assert cast_of.get(g["pick"].inputs[2]) == "fine"
    (cast,) = g.of_kind(Kind.CAST)       # one shared cast, one integer bit more than its input
    assert cast.qformat.frac == OUT.frac and cast.qformat.width - cast.qformat.frac == FINE.width - FINE.frac + 1


def test_nothing_to_move_is_the_same_graph():
    g = _graph()
    plain = Graph.build("t", [n for n in g.nodes if n.name in ("coarse", "fine", "back", "twice")],
                        [("back", "back"), ("twice", "twice")])
    assert round_operands_early(plain) is plain
