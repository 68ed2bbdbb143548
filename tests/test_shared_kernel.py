"""Kernels shared between typings of one graph (pendc.ir.shared_source): bit-identical to the
interpreter where every number is data, and one compile for retypings that differ alike."""

import re
from dataclasses import replace

import numpy as np

from pendc.ir.compiled import _SIGNATURE, CompiledGraph
from pendc.ir.graph import Graph
from pendc.ir.interpret import FixedInterpreter
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat
from pendc.ir.resumable import make_resumable
from pendc.ir.shared_source import same_structure, shared_kernel_source

from test_compiled import MODES, Q, assert_same, block, random_inputs, requant_nodes

# every rounding and every overflow mode once (the general form prints them independently); one
# mode a part keeps the compile of the all-general kernel (numba: ~0.1 s a node) short
HAND_MODES = ("nt",)
REQUANT_MODES = {"ts": MODES["ts"]}


def mixed_graph(name: str) -> Graph:
    nodes = [make("u", Kind.INPUT, qformat=Q("FIX16_8"), port="u"),
             make("w", Kind.INPUT, qformat=Q("FIX12_4"), port="w")]
    for sfx in HAND_MODES:
        nodes += block(sfx, *MODES[sfx])
    nodes += requant_nodes(REQUANT_MODES)
    return Graph.build(name, nodes, [(x.name, x.name) for x in nodes])


def retyped(graph: Graph, formats: dict) -> Graph:
    return graph.map_nodes(lambda n: replace(n, qformat=formats[n.name]) if n.name in formats else n)


def shifted(graph: Graph) -> Graph:
    """Every format one fraction bit finer: nearly every node's baked code differs."""
    return retyped(graph, {n.name: QFormat(n.qformat.signed, n.qformat.width, n.qformat.frac + 1)
                           for n in graph.nodes})


def test_general_form_is_bit_identical_on_every_node_kind():
    g = mixed_graph("shared_mixed")
    src, _, params = shared_kernel_source(g, shifted(g))
    assert {int(k) for k in re.findall(r"qp\[(\d+)\]", src)} == set(range(len(params)))
    assert len(params) > 5 * len(g.nodes)
    cg = CompiledGraph(g, "fixed", like=shifted(g))
    assert cg.source == make_resumable(src, g, "pendc.ir.compiled", _SIGNATURE[True]) and {n.kind for n in g.nodes} == set(Kind)
    interp = FixedInterpreter(g)
    inputs = dict(random_inputs(2000, seed=13), a=np.random.default_rng(2).integers(-300, 300, 2000))
    trace = cg.run(inputs, track_max=True)
    assert_same(trace, interp.run(inputs, track_max=True))
    assert len(trace.overflows) > 30
    for v in range(-300, 300):              # each value of (and around) FIX8_2 through every requant
        ins = {"u": np.array([1.5, -3.0]), "w": np.array([2.0, 0.25]), "a": np.array([v, v], dtype=np.int64)}
        assert_same(cg.run(ins, track_max=True), interp.run(ins, track_max=True))


def test_retypings_that_differ_alike_share_one_kernel():
    """Like the error budget's widening rounds: the same nodes change, by different amounts."""
    nodes = [make("u", Kind.INPUT, qformat=Q("FIX16_8"), port="u"),
             make("w", Kind.INPUT, qformat=Q("FIX12_4"), port="w")] + block("ns", *MODES["ns"])
    base = Graph.build("shared_rounds", nodes, [(x.name, x.name) for x in nodes])
    rounds = [retyped(base, {"r1_ns": Q(f), "r2_ns": Q(f), "acc_ns": Q(f)}) for f in ("FIX20_10", "FIX26_15")]
    first, second = (CompiledGraph(r, "fixed", like=base) for r in rounds)
    assert first.source == second.source and first._kernel is second._kernel
    assert first.source != CompiledGraph(base, "fixed").source
    assert 0 < first.source.count("qp[") < 10 * len(base.nodes)     # only the retyped nodes and readers
    inputs = random_inputs(1500, seed=21)
    for graph, cg in zip(rounds, (first, second)):
        assert_same(cg.run(inputs, track_max=True), FixedInterpreter(graph).run(inputs, track_max=True))
    # another structure, or no reference: the baked kernel, the one every other caller compiles
    other = Graph.build("shared_rounds", nodes[:-1], [(x.name, x.name) for x in nodes[:-1]])
    assert not same_structure(other, base) and same_structure(rounds[0], base)
    assert CompiledGraph(rounds[0], "fixed", like=other).source == CompiledGraph(rounds[0], "fixed").source
    assert "qp" not in CompiledGraph(rounds[0], "fixed").source
