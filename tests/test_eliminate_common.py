"""Common-subexpression elimination: equal nodes merge, identities stay, values do not change."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

from pendc.ir.graph import Graph
from pendc.ir.interpret import FixedInterpreter, FloatInterpreter
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat, Rounding
from pendc.ir.verify import verify
from pendc.passes.eliminate_common import eliminate_common_subexpressions as cse

U = np.cos(np.linspace(0.0, 5.0, 50)) * 2.0
Q = QFormat.parse
FSM = dict(states=("A", "B"), reset="A", transitions=(("*", "ge", 0.5, "B"), ("*", "lt", -0.5, "A")),
           outputs=(0, 1), lo=-100.0, hi=100.0)


def same_outputs(before: Graph, after: Graph, interp=FloatInterpreter):
    a = interp(before).run({"u": U})
    b = interp(after).run({"u": U})
    assert a.outputs.keys() == b.outputs.keys()
    for port in a.outputs:
        np.testing.assert_array_equal(b.outputs[port], a.outputs[port], err_msg=port)


def accumulator() -> Graph:
    """Two copies of the same accumulator input path, written with commuted operands."""
    nodes = [
        make("u", Kind.INPUT, port="u"),
        make("x", Kind.REGISTER, ["s"], reset=0.0, meaning="sum"),
        make("x2", Kind.REGISTER, ["s"], reset=0.0),                # same input: still its own register
        make("ka", Kind.CONST, value=0.25),
        make("kb", Kind.CONST, value=0.25, meaning="quarter"),
        make("pa", Kind.MUL, ["u", "ka"]),
        make("pb", Kind.MUL, ["kb", "u"], meaning="quarter of u"),  # equal to pa once kb is ka
        make("ga", Kind.GAIN, ["pa"], value=2.0),
        make("gb", Kind.GAIN, ["pb"], value=2.0),                   # equal to ga once pb is pa
        make("gc", Kind.GAIN, ["pb"], value=3.0),                   # a different gain
        make("da", Kind.SUB, ["ga", "gc"]),
        make("db", Kind.SUB, ["gc", "gb"]),                         # SUB is not commutative
        make("s", Kind.ADD, ["x", "ga"]),
        make("t", Kind.ADD, ["gb", "x"]),                           # equal to s
        make("fa", Kind.FSM, ["t"], **FSM),
        make("fb", Kind.FSM, ["t"], **FSM),                         # FSMs have identity too
        make("y", Kind.ADD, ["da", "db"]),
        make("z", Kind.ADD, ["fa", "fb"]),
    ]
    return Graph.build("acc", nodes, [("x", "x"), ("x2", "x2"), ("t", "t"), ("y", "y"), ("z", "z")])


def test_accumulator_merges_to_a_fixed_point():
    g = accumulator()
    verify(g)
    c = cse(g)
    verify(c)
    same_outputs(g, c)
    assert [n.name for n in c.nodes] == ["u", "x", "x2", "ka", "fa", "fb", "pa", "ga", "gc", "da", "db", "s", "y", "z"]
    assert c["x"].inputs == ("s",) and c["x2"].inputs == ("s",)
    assert c["fa"].inputs == ("s",) and c["fb"].inputs == ("s",)
    assert c["db"].inputs == ("gc", "ga") and c["gc"].inputs == ("pa",)
    assert c.outputs == (("x", "x"), ("x2", "x2"), ("t", "s"), ("y", "y"), ("z", "z"))
    # survivors keep their own meaning or take the first non-empty one merged into them
    assert c["x"].meaning == "sum" and c["ka"].meaning == "quarter" and c["pa"].meaning == "quarter of u"


def test_idempotent_and_deterministic():
    once = cse(accumulator())
    assert cse(once).text() == once.text()
    assert cse(accumulator()).text() == once.text()


def test_text_is_independent_of_hash_seed():
    code = ("import sys; sys.path.insert(0, 'tests'); from test_eliminate_common import accumulator;"
            "from pendc.passes.eliminate_common import eliminate_common_subexpressions as cse;"
            "print(cse(accumulator()).text())")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    texts = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=root,
                            env={**os.environ, "PYTHONHASHSEED": seed}).stdout for seed in ("1", "2")}
    assert len(texts) == 1


def test_inputs_are_never_merged():
    nodes = [make("u", Kind.INPUT, port="u"), make("v", Kind.INPUT, port="u2"), make("y", Kind.ADD, ["u", "v"])]
    g = Graph.build("t", nodes, [("y", "y")])
    assert cse(g).text() == g.text()


def typed_pair(fa: QFormat, fb: QFormat, ra=Rounding.NEAREST, rb=Rounding.NEAREST) -> Graph:
    nodes = [make("u", Kind.INPUT, port="u", qformat=Q("FIX16_12")),
             make("c", Kind.CONST, value=0.5, qformat=Q("FIX16_14")),
             make("d", Kind.CONST, value=0.5, qformat=Q("FIX16_14")),
             make("a", Kind.ADD, ["u", "c"], qformat=fa, rounding=ra),
             make("b", Kind.ADD, ["d", "u"], qformat=fb, rounding=rb),
             make("y", Kind.SUB, ["a", "b"], qformat=Q("FIX20_12"))]
    return Graph.build("t", nodes, [("y", "y")])


def test_typed_equal_nodes_merge():
    g = typed_pair(Q("FIX16_12"), Q("FIX16_12"))
    c = cse(g)
    verify(c, typed=True)
    same_outputs(g, c, FixedInterpreter)
    assert [n.name for n in c.nodes] == ["u", "c", "a", "y"] and c["y"].inputs == ("a", "a")


def test_different_format_or_rounding_do_not_merge():
    for g in (typed_pair(Q("FIX16_12"), Q("FIX16_10")),
              typed_pair(Q("FIX16_12"), Q("FIX16_12"), rb=Rounding.TRUNCATE)):
        c = cse(g)
        assert [n.name for n in c.nodes] == ["u", "c", "a", "b", "y"]   # only the constants merged
        assert c["b"].inputs == ("c", "u")
        same_outputs(g, c, FixedInterpreter)


def test_lowered_pendulum():
    from pendc.model.modelfile import load_model
    from pendc.passes.fold_constants import fold_constants
    from pendc.passes.lower import lower_model

    g = fold_constants(lower_model(load_model(), dt=1e-4))
    c = cse(g)
    verify(c)
    assert len(c.nodes) < len(g.nodes)
    assert cse(c).text() == c.text()
    u = np.full(200, 7.0)
    a, b = FloatInterpreter(g).run({"u": u}), FloatInterpreter(c).run({"u": u})
    for port in a.outputs:
        np.testing.assert_array_equal(b.outputs[port], a.outputs[port], err_msg=port)
