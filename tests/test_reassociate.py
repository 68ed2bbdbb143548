"""add_last_term_to_state: ``s + (a + b)`` as ``(s + a) + b`` and ``(a + b) > x`` as ``b > x - a``
compute the same integers when the increment's sum is exact (the short chain's typed graph)."""

import numpy as np

from pendc.ir.compare_ops import CompareOp
from pendc.ir.graph import Graph
from pendc.ir.interpret import FixedInterpreter
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat
from pendc.passes.reassociate import add_last_term_to_state

STATE, TERM, INC = QFormat(True, 28, 22), QFormat(True, 16, 12), QFormat(True, 18, 12)


def _graph(inc_format=INC):
    nodes = [make("s", Kind.REGISTER, ["s_sum"], reset=0.0).typed(STATE),
             make("a", Kind.INPUT, port="a", max_abs=7.0).typed(TERM),
             make("b", Kind.INPUT, port="b", max_abs=7.0).typed(TERM),
             make("room", Kind.INPUT, port="room", max_abs=7.0).typed(QFormat(True, 16, 10)),
             make("inc", Kind.ADD, ["a", "b"]).typed(inc_format),
             make("s_sum", Kind.ADD, ["s", "inc"]).typed(STATE),
             make("over", Kind.COMPARE, ["inc", "room"], op=CompareOp.GT).typed(QFormat(False, 1, 0))]
    return Graph.build("t", nodes, [("s", "s"), ("over", "over")])


def test_same_integers():
    g = _graph()
    moved = add_last_term_to_state(g)
    assert moved["s_sum"].inputs[1] == "b" and moved[moved["s_sum"].inputs[0]].inputs == ("s", "a")
    assert moved["over"].inputs[0] == "b" and moved[moved["over"].inputs[1]].inputs == ("room", "a")
    rng = np.random.default_rng(3)
    ins = {k: [int(v) for v in rng.integers(-(1 << 14), 1 << 14, 3000)] for k in ("a", "b")}
    ins["room"] = [int(v) for v in rng.integers(-(1 << 15), 1 << 15, 3000)]
    ins["b"][:100] = [r * 4 - a for r, a in zip(ins["room"][:100], ins["a"][:100])]     # ties: a + b == room
    before, after = FixedInterpreter(g).run(ins), FixedInterpreter(moved).run(ins)
    for port in ("s", "over"):
        assert list(before.outputs[port]) == list(after.outputs[port]), port
    assert any(before.outputs["over"]) and not all(before.outputs["over"])
    assert "inc" not in moved.by_name          # read by nothing else any more


def test_a_rounding_increment_stays():
    """An increment that rounds its sum (fewer fraction bits than its terms) is left alone."""
    g = _graph(QFormat(True, 16, 10))
    assert add_last_term_to_state(g) is g
