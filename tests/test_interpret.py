"""Reference interpreters vs the compiled golden model on the compiled default model.

Acceptance criterion: FixedInterpreter and CompiledGraph (fixed) are bit-identical on
10 000 steps of each of the issue's stimuli (low-frequency chirp, swing-up-like input).
"""

import numpy as np
import pytest

import pendc
from pendc.ir.compiled import CompiledGraph
from pendc.ir.graph import Graph
from pendc.ir.interpret import FixedInterpreter, FloatInterpreter
from pendc.ir.nodes import Kind
from pendc.caching.build_cache import compile_cached
from pendc.passes.pipeline import BuildOptions
from pendc.passes.ranges import per_step
from plants import chirp, swing_up

DT = 1e-6
STEPS = 10_000
OPTIONS = BuildOptions(training_scale=0.02)
STIMULI = {"chirp": chirp(), "swing_up": swing_up()}


@pytest.fixture(scope="module")
def build():
    return compile_cached(pendc.load_model(), OPTIONS)     # one short build for the pass tests (the build cache)


@pytest.fixture(scope="module")
def fixed(build):
    return CompiledGraph(build.graph, "fixed")


@pytest.fixture(scope="module")
def flt(build):
    return CompiledGraph(build.graph, "float")


def every_node(graph):
    """The graph with every non-constant node as an extra output (for the interpreters)."""
    names = tuple(n.name for n in graph.nodes if n.kind is not Kind.CONST)
    return Graph(name=graph.name, nodes=graph.nodes, outputs=tuple(graph.outputs) + tuple((f"node:{n}", n)
                                                                                         for n in names),
                 info=graph.info), names


def window(name, start_fraction):
    t, u = STIMULI[name]
    steps = per_step(u, t, DT)
    start = int(len(steps) * start_fraction)
    return steps[start:start + STEPS]


def assert_fixed_identical(build, fixed, u):
    g, names = every_node(build.graph)
    slow = FixedInterpreter(g).run({"u": u}, track_max=True)
    fast = fixed.run({"u": u}, record=names, track_max=True)
    assert slow.steps == fast.steps == len(u)
    for port, node in build.graph.outputs:
        a = np.asarray(slow.outputs[port], dtype=object)
        b = fast.outputs[port]
        assert b.dtype == np.int64
        assert [int(v) for v in a] == b.tolist(), port
    for n in names:
        assert [int(v) for v in slow.outputs[f"node:{n}"]] == fast.outputs[n].tolist(), n
    assert slow.overflows == fast.overflows
    assert slow.max_abs == fast.max_abs
    return fast


@pytest.mark.parametrize("name", sorted(STIMULI))
def test_fixed_interpreter_is_compiled_bit_for_bit(build, fixed, name):
    u = window(name, 0.0)
    assert len(u) == STEPS
    fast = assert_fixed_identical(build, fixed, u)
    assert not fast.overflows


@pytest.mark.parametrize("name", sorted(STIMULI))
def test_bit_identical_from_the_middle_of_the_stimulus(build, fixed, name):
    """A sudden large input from reset (the window starts where the stimulus is large)."""
    u = window(name, 0.4)
    assert np.ptp(u) > 0 or abs(u[0] - 5.2646) > 0.5
    fast = assert_fixed_identical(build, fixed, u)
    x = fast.outputs["x"]
    assert np.any(x != 0)                        # the cart moved


def test_bit_identical_through_overflows(build, fixed):
    """Input at the extremes of the u port's format (beyond the 0-10 V drive range, which the
    ranges are trained on), changing every 10 steps, drives nodes beyond their trained
    ranges: wrap-around and the overflow flags must match too."""
    f = build.graph["u"].qformat
    rng = np.random.default_rng(3)
    u = np.repeat(np.where(rng.random(400) > 0.5, f.max_value, f.min_value), 10)[:4000]
    g, names = every_node(build.graph)
    slow = FixedInterpreter(g).run({"u": u})
    fast = fixed.run({"u": u}, record=names)
    for n in names:
        assert [int(v) for v in slow.outputs[f"node:{n}"]] == fast.outputs[n].tolist(), n
    assert slow.overflows == fast.overflows
    assert slow.overflows, "the input should leave the short build's trained ranges"


def test_subsampled_rows_and_integer_inputs(build, fixed):
    u = window("swing_up", 0.2)[:3000]
    ints = np.array([build.graph["u"].qformat.from_float(float(v)) for v in u], dtype=np.int64)
    slow = FixedInterpreter(build.graph).run({"u": [int(v) for v in ints]}, every=7)
    fast = fixed.run({"u": ints}, every=7)
    from_float = fixed.run({"u": u}, every=7)
    for port, _ in build.graph.outputs:
        assert len(fast.outputs[port]) == -(-3000 // 7)
        assert [int(v) for v in slow.outputs[port]] == fast.outputs[port].tolist() == from_float.outputs[port].tolist()


# -- float mode ---------------------------------------------------------------------------------

def assert_float_equal(graph, compiled, u):
    g, names = every_node(graph)
    slow = FloatInterpreter(g).run({"u": u}, track_max=True)
    fast = compiled.run({"u": u}, record=names, track_max=True)
    for n in names:
        a = np.asarray(slow.outputs[f"node:{n}"], float)
        b = fast.outputs[n]
        scale = max(float(np.max(np.abs(a))), 1e-300)
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-12 * scale, err_msg=n)
    assert slow.overflows == fast.overflows
    for n in names:
        assert fast.max_abs[n] == pytest.approx(slow.max_abs[n], rel=1e-12, abs=1e-300), n
    return fast


@pytest.mark.parametrize("name", sorted(STIMULI))
def test_float_interpreter_equals_compiled_float(build, flt, name):
    u = window(name, 0.4)[:5000]
    fast = assert_float_equal(build.graph, flt, u)
    assert np.any(fast.outputs["theta"] != 0)


def test_float_interpreter_equals_compiled_float_on_the_untyped_graph(build):
    u = window("swing_up", 0.0)[:4000]
    assert_float_equal(build.untyped, CompiledGraph(build.untyped, "float"), u)
