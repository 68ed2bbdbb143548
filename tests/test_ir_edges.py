"""Edges of the IR's semantics the backend fuzzer once found disagreeing across engines:
a MUX select beyond its data inputs, FSM thresholds beyond the input's range, unsigned
operands near the 64-bit limit of the golden model. The interpreters and the compiled golden
kernel must agree (the Verilog side: tests/test_fuzz_regressions.py)."""

import numpy as np
import pytest

from pendc.ir import fsm as fsm_sem
from pendc.ir.compare_ops import ORDERING_OPS
from pendc.ir.compiled import CompiledGraph
from pendc.ir.graph import Graph, GraphError
from pendc.ir.interpret import FixedInterpreter, FloatInterpreter
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat
from pendc.ir.verify import verify

U8 = QFormat(True, 8, 0)


def _mux_graph():
    nodes = [make("u", Kind.INPUT, qformat=U8, port="u"),
             make("sel", Kind.SLICE, ("u",), qformat=QFormat(False, 2, 0), hi=1, lo=0),
             make("ten", Kind.CONST, qformat=U8, value=10.0),
             make("twenty", Kind.CONST, qformat=U8, value=20.0),
             make("m", Kind.MUX, ("sel", "u", "ten", "twenty"), qformat=QFormat(True, 9, 0))]
    graph = Graph.build("mux", nodes, [("y", "m")])
    verify(graph, typed=True)
    return graph


def test_a_mux_select_beyond_its_inputs_picks_the_last_one_in_every_engine():
    graph = _mux_graph()
    u = [0, 1, 2, 3, 7, -1]           # low two bits: 0 1 2 3 3 3
    want = [0, 10, 20, 20, 20, 20]
    assert list(FixedInterpreter(graph).run({"u": u}).outputs["y"]) == want
    assert list(CompiledGraph(graph, "fixed").run({"u": np.asarray(u, np.int64)}).outputs["y"]) == want
    assert list(FloatInterpreter(graph).run({"u": [float(v) for v in u]}).outputs["y"]) == want


def test_the_mux_docstring_states_the_rule():
    from pendc.ir import kinds
    assert "a select beyond the last input picks the last" in kinds.__doc__
    assert "it selects the last data input, in the interpreters, the golden kernel and the\nVerilog alike" in kinds.__doc__


@pytest.mark.parametrize("threshold, want", [(1e300, 128), (-1e300, -129), (200.0, 128), (-200.0, -129),
                                             (127.4, 127), (127.6, 128), (-128.5, -128), (-128.6, -129)])
def test_a_threshold_beyond_the_input_range_is_clamped_one_step_outside(threshold, want):
    assert fsm_sem.threshold_int(threshold, U8) == want


def test_constant_outcomes_of_a_test_beyond_the_range():
    for v in range(U8.min_int, U8.max_int + 1, 17):
        for t in (U8.max_int + 1, U8.min_int - 1):
            for op in ORDERING_OPS:
                assert fsm_sem.constant_outcome(op, t, U8) == op.apply(v, t)
                assert fsm_sem.constant_outcome(op.value, t, U8) == (v < t if op.value in ("lt", "le") else v > t)
    assert fsm_sem.constant_outcome("lt", 5, U8) is None


def test_fsm_thresholds_beyond_the_range_agree_between_interpreter_and_kernel():
    flag = QFormat(False, 1, 0)
    nodes = [make("u", Kind.INPUT, qformat=flag, port="u"),
             make("m", Kind.FSM, ("u",), qformat=QFormat(False, 3, 0), states=("a", "b", "c"), reset="a",
                  transitions=(("a", "ge", 1.5, "b"), ("a", "lt", 1e300, "c"), ("c", "gt", -7.0, "a")),
                  outputs=(1, 6, 3), lo=1.5, hi=1e300)]
    graph = Graph.build("fsm", nodes, [("y", "m")])
    verify(graph, typed=True)
    u = [0, 1, 1, 0, 1]
    interp = FixedInterpreter(graph).run({"u": u})
    gold = CompiledGraph(graph, "fixed").run({"u": np.asarray(u, np.int64)})
    assert list(interp.outputs["y"]) == list(gold.outputs["y"]) == [1, 3, 1, 3, 1]
    assert interp.overflows == gold.overflows == {"m": 0}     # lo = 1.5 is beyond a 1-bit input


@pytest.mark.parametrize("kind, fmts, ok", [
    (Kind.ADD, (QFormat(False, 62, 0), QFormat(False, 62, 0)), True),
    (Kind.ADD, (QFormat(False, 63, 0), QFormat(False, 63, 0)), False),    # 2**64 - 2 is no int64
    (Kind.ADD, (QFormat(True, 63, 0), QFormat(True, 63, 0)), True),
    (Kind.MUL, (QFormat(False, 32, 0), QFormat(False, 32, 0)), False),
    (Kind.MUL, (QFormat(False, 32, 0), QFormat(True, 31, 0)), True),
])
def test_unsigned_operands_count_a_sign_bit_in_the_64_bit_rule(kind, fmts, ok):
    nodes = [make("a", Kind.INPUT, qformat=fmts[0], port="a"), make("b", Kind.INPUT, qformat=fmts[1], port="b"),
             make("y", kind, ("a", "b"), qformat=QFormat(True, 64, 0))]
    graph = Graph.build("w", nodes, [("y", "y")])
    if ok:
        verify(graph, typed=True)
    else:
        with pytest.raises(GraphError, match="more than 64"):
            verify(graph, typed=True)


def test_the_comparison_table_agrees_with_python_and_names_every_op():
    from pendc.ir.compare_ops import CompareOp
    from pendc.ir.nodes import COMPARE_OPS
    assert COMPARE_OPS == ("lt", "le", "gt", "ge", "eq", "ne")
    assert [o.orders for o in CompareOp] == [True, True, True, True, False, False]
    for op in CompareOp:
        assert CompareOp.parse(op.value) is op and CompareOp.parse(op) is op
        for a in (-2, 0, 3):
            for b in (-2, 0, 3):
                # the infix spelling the kernel printer and the Verilog use, evaluated by Python itself
                assert eval(f"a {op.symbol} b") == op.apply(a, b)      # noqa: S307 - our own six symbols
    with pytest.raises(ValueError, match="'lte' is not one of lt, le, gt, ge, eq, ne"):
        CompareOp.parse("lte")
