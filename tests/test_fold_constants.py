"""Constant folding: the graph shrinks as expected and computes the same real values."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

from pendc.ir.graph import Graph, GraphError
from pendc.ir.interpret import FloatInterpreter
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import Overflow, QFormat
from pendc.ir.verify import verify
from pendc.passes.fold_constants import fold_constants

U = np.sin(np.linspace(0.0, 7.0, 60)) * 3.0 + 0.25


def same_outputs(before: Graph, after: Graph, steps=U):
    a = FloatInterpreter(before).run({"u": steps})
    b = FloatInterpreter(after).run({"u": steps})
    assert a.outputs.keys() == b.outputs.keys()
    for port in a.outputs:
        np.testing.assert_allclose(b.outputs[port], a.outputs[port], rtol=1e-12, atol=1e-12, err_msg=port)


def folded(nodes, outputs) -> tuple[Graph, Graph]:
    g = Graph.build("t", nodes, outputs)
    verify(g)
    f = fold_constants(g)
    verify(f)
    same_outputs(g, f)
    return g, f


def accumulator() -> Graph:
    """x[n+1] = x[n] + 0.75 u, written the long way round, plus several foldable side paths."""
    nodes = [
        make("u", Kind.INPUT, port="u", meaning="input"),
        make("x", Kind.REGISTER, ["s"], reset=0.5, meaning="accumulated input"),
        make("c0", Kind.CONST, value=0.0),
        make("c1", Kind.CONST, value=1.0),
        make("c2", Kind.CONST, value=2.0),
        make("c3", Kind.CONST, value=3.0),
        make("two", Kind.ADD, ["c1", "c1"]),                    # -> const 2
        make("six", Kind.MUL, ["two", "c3"]),                   # -> const 6
        make("g", Kind.MUL, ["u", "six"]),                      # -> gain(u) 6
        make("g1", Kind.GAIN, ["g"], value=1.0),                # -> g
        make("z", Kind.ADD, ["g1", "c0"], meaning="six u"),     # -> g (which takes the meaning)
        make("n1", Kind.NEG, ["z"]),
        make("n2", Kind.NEG, ["n1"]),                           # -> g
        make("half", Kind.GAIN, ["n2"], value=0.5),             # -> gain(u) 3
        make("inc", Kind.GAIN, ["half"], value=0.25, meaning="increment"),  # -> gain(u) 0.75
        make("s", Kind.ADD, ["x", "inc"]),
        make("lt", Kind.COMPARE, ["c1", "c2"], op="lt"),        # -> const 1
        make("pick", Kind.MUX, ["lt", "c0", "x"]),              # -> x
        make("hold", Kind.REGISTER, ["c3"], reset=3.0),         # -> const 3
        make("y", Kind.SUB, ["hold", "u"]),
        make("minus", Kind.SUB, ["c0", "u"]),                   # -> neg(u)
        make("cos1", Kind.LUT, ["c1"], expr="cos(v)", lo=None, hi=None, periodic=False, addr_bits=4,
             interpolate=True),                                 # -> const cos(1)
        make("w", Kind.MUL, ["minus", "cos1"]),                 # -> gain(minus) cos(1), cos1 unused
        make("sign", Kind.SLICE, ["c2"], hi=-1, lo=-1),         # -> const 0
        make("same", Kind.MUX, ["sign", "w", "w"]),             # -> w
    ]
    return Graph.build("acc", nodes, [("x", "x"), ("pick", "pick"), ("y", "y"), ("same", "same")])


def test_accumulator_shrinks_and_keeps_its_values():
    g = accumulator()
    verify(g)
    f = fold_constants(g)
    verify(f)
    same_outputs(g, f)
    assert [n.name for n in f.nodes] == ["u", "x", "hold", "inc", "s", "y", "minus", "w"]
    kinds = {n.name: (n.kind, n.inputs, dict(n.params)) for n in f.nodes}
    assert kinds["inc"] == (Kind.GAIN, ("u",), {"value": 0.75})
    assert kinds["hold"] == (Kind.CONST, (), {"value": 3.0})
    assert kinds["minus"] == (Kind.NEG, ("u",), {})
    assert kinds["w"] == (Kind.GAIN, ("minus",), {"value": math.cos(1.0)})
    assert f.outputs == (("x", "x"), ("pick", "x"), ("y", "y"), ("same", "w"))
    assert f["x"].meaning == "accumulated input" and f["inc"].meaning == "increment"


def test_text_is_deterministic():
    assert fold_constants(accumulator()).text() == fold_constants(accumulator()).text()


def test_text_is_independent_of_hash_seed():
    code = ("import sys; sys.path.insert(0, 'tests'); from test_fold_constants import accumulator;"
            "from pendc.passes.fold_constants import fold_constants; print(fold_constants(accumulator()).text())")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    texts = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=root,
                            env={**os.environ, "PYTHONHASHSEED": seed}).stdout for seed in ("1", "2")}
    assert len(texts) == 1


def test_identity_meaning_moves_to_survivor():
    nodes = [make("u", Kind.INPUT, port="u"), make("c0", Kind.CONST, value=0.0),
             make("a", Kind.GAIN, ["u"], value=2.0),
             make("b", Kind.ADD, ["c0", "a"], meaning="twice u")]
    _, f = folded(nodes, [("y", "b")])
    assert [n.name for n in f.nodes] == ["u", "a"] and f["a"].meaning == "twice u"
    assert f.outputs == (("y", "a"),)


def test_gain_by_zero_and_minus_one():
    nodes = [make("u", Kind.INPUT, port="u"), make("z", Kind.GAIN, ["u"], value=0.0, meaning="nothing"),
             make("m", Kind.GAIN, ["u"], value=-1.0), make("s", Kind.ADD, ["z", "m"])]
    _, f = folded(nodes, [("z", "z"), ("y", "s")])
    assert f["z"].kind is Kind.CONST and f["z"].param("value") == 0.0 and f["z"].meaning == "nothing"
    assert f["m"].kind is Kind.NEG and f["m"].inputs == ("u",)
    # z became a constant 0, so the next sweep turned s = z + m into m
    assert [n.name for n in f.nodes] == ["u", "z", "m"] and f.outputs == (("z", "z"), ("y", "m"))


def test_shared_inner_gain_is_kept():
    # the encoder's increment must be computed from the integrator's own increment
    nodes = [make("u", Kind.INPUT, port="u"), make("inc", Kind.GAIN, ["u"], value=1e-3),
             make("x", Kind.REGISTER, ["xs"], reset=0.0), make("xs", Kind.ADD, ["x", "inc"]),
             make("bands", Kind.GAIN, ["inc"], value=200.0)]
    g, f = folded(nodes, [("x", "x"), ("b", "bands")])
    assert f.text() == g.text()


def test_fsm_with_constant_input_is_not_folded():
    nodes = [make("c", Kind.CONST, value=1.0),
             make("f", Kind.FSM, ["c"], states=("A", "B"), reset="A", transitions=(("*", "ge", 0.5, "B"),),
                  outputs=(0, 1), lo=-2.0, hi=2.0),
             make("u", Kind.INPUT, port="u"), make("y", Kind.ADD, ["u", "f"])]
    g, f = folded(nodes, [("y", "y")])
    assert f.text() == g.text()


def test_register_with_other_reset_is_not_folded():
    nodes = [make("c", Kind.CONST, value=1.0), make("r", Kind.REGISTER, ["c"], reset=0.0),
             make("u", Kind.INPUT, port="u"), make("y", Kind.ADD, ["u", "r"])]
    g, f = folded(nodes, [("y", "y")])
    assert f.text() == g.text()


def test_out_of_domain_lut_and_non_finite_values_are_not_folded():
    nodes = [make("c", Kind.CONST, value=3.0), make("c0", Kind.CONST, value=0.0),
             make("t", Kind.LUT, ["c"], expr="sin(v)", lo=-1.0, hi=1.0, periodic=False, addr_bits=4,
                  interpolate=True),
             make("inv", Kind.LUT, ["c0"], expr="1/v", lo=None, hi=None, periodic=False, addr_bits=4,
                  interpolate=True),
             make("u", Kind.INPUT, port="u"), make("a", Kind.ADD, ["u", "t"]), make("y", Kind.ADD, ["a", "inv"])]
    g = Graph.build("t", nodes, [("y", "y")])
    f = fold_constants(g)
    assert f["t"].kind is Kind.LUT and f["inv"].kind is Kind.LUT


def test_bit_field_of_a_constant_is_not_folded():
    # bits 2..1 of a constant depend on the Q-format it is given later
    nodes = [make("c", Kind.CONST, value=6.0), make("b", Kind.SLICE, ["c"], hi=2, lo=1),
             make("u", Kind.INPUT, port="u"), make("y", Kind.ADD, ["u", "b"])]
    g, f = folded(nodes, [("y", "y")])
    assert f["b"].kind is Kind.SLICE


def test_mux_select_out_of_range_is_left_alone():
    nodes = [make("c", Kind.CONST, value=5.0), make("u", Kind.INPUT, port="u"), make("v", Kind.NEG, ["u"]),
             make("m", Kind.MUX, ["c", "u", "v"])]
    f = fold_constants(Graph.build("t", nodes, [("y", "m")]))
    assert f["m"].kind is Kind.MUX


def test_rewritten_node_keeps_overflow_choice():
    nodes = [make("u", Kind.INPUT, port="u"), make("c", Kind.CONST, value=2.0),
             make("m", Kind.MUL, ["c", "u"], overflow=Overflow.SATURATE)]
    _, f = folded(nodes, [("y", "m")])
    assert f["m"].kind is Kind.GAIN and f["m"].inputs == ("u",) and f["m"].overflow is Overflow.SATURATE


def test_dead_nodes_and_unused_inputs_are_removed():
    nodes = [make("u", Kind.INPUT, port="u"), make("v", Kind.INPUT, port="v"),
             make("c", Kind.CONST, value=0.0), make("g", Kind.GAIN, ["v"], value=0.0),
             make("r", Kind.REGISTER, ["r"], reset=1.0), make("y", Kind.ADD, ["u", "g"])]
    f = fold_constants(Graph.build("t", nodes, [("y", "y")]))
    verify(f)
    assert [n.name for n in f.nodes] == ["u"]


def test_typed_graph_is_refused():
    g = Graph.build("t", [make("u", Kind.INPUT, port="u", qformat=QFormat(True, 16, 8))], [("y", "u")])
    with pytest.raises(GraphError, match="'u' is typed"):
        fold_constants(g)


def test_lowered_pendulum():
    from pendc.model.modelfile import load_model
    from pendc.passes.lower import lower_model

    g = lower_model(load_model(), dt=1e-4)
    f = fold_constants(g)
    verify(f)

    def constant_only(graph):      # operations whose every input is a constant: what folding removes
        return [n.name for n in graph.nodes
                if n.kind not in (Kind.CONST, Kind.INPUT) and n.inputs and all(graph[i].kind is Kind.CONST for i in n.inputs)]
    assert constant_only(g), "the lowered pendulum no longer gives folding anything to do: pick another graph"
    assert constant_only(f) == []
    assert fold_constants(f).text() == f.text()       # a fixed point
    same_outputs(g, f, steps=np.full(200, 7.0))
