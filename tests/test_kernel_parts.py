"""A step split into parts (pendc.ir.kernel_parts) computes the same bits as the one-function step,
and LUTs printed as a group (one address computation, shared calls) the same bits as alone.

The split is forced on the hand graph of every node kind (test_compiled) by lowering the
thresholds, so each part boundary falls between nodes of every kind, states and checks
included; fixed and float kernels, the tracked extremes, the overflow steps and the resumable
golden stepper (whose parts record overflow steps counted from its saved step) must all agree.

The one-function kernels compared with are test_compiled's own (the same graph under the same
name prints the same source, so the compile cache serves them); the split golden stepper is
compared with the reference interpreter, which needs no compile.
"""

import ast
import re

import numpy as np
import pytest

from pendc.golden import GoldenStepper
from pendc.ir import kernel_module, kernel_parts
from pendc.ir.compiled import CompiledGraph
from pendc.ir.graph import Graph
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat
from pendc.ir.interpret import FixedInterpreter
from pendc.ir.qformat import Rounding
from test_compiled import MODES, assert_same, block, hand_graph, lut, random_inputs


def force_split(monkeypatch):
    monkeypatch.setattr(kernel_module, "SPLIT_ABOVE", 40)
    monkeypatch.setattr(kernel_parts, "PART_LINES", 25)


def parts_of(source: str) -> list:
    """The sources of the part modules a kernel module loads."""
    return [ast.literal_eval(a.value.value.args[0]) for a in ast.parse(source).body
            if isinstance(a, ast.Assign) and a.targets[0].id.startswith("part")]


def same(a, b):
    assert a.outputs.keys() == b.outputs.keys()
    for port in a.outputs:
        assert np.array_equal(a.outputs[port], b.outputs[port], equal_nan=True), port
    assert a.overflows == b.overflows
    assert a.max_abs.keys() == b.max_abs.keys()
    for k in a.max_abs:
        assert a.max_abs[k] == b.max_abs[k] or (np.isnan(a.max_abs[k]) and np.isnan(b.max_abs[k])), k
    assert a.extremes.keys() == b.extremes.keys()


@pytest.mark.parametrize("mode", ["fixed", "float"])
def test_split_step_is_bit_identical(mode, monkeypatch):
    g = hand_graph()          # test_compiled's graph: its one-function kernels come from the cache
    inputs = random_inputs(2500, seed=3)
    whole = CompiledGraph(g, mode)
    assert parts_of(whole.source) == []
    force_split(monkeypatch)
    parted = CompiledGraph(g, mode)
    assert len(parts_of(parted.source)) > 5
    for every, track in ((1, True), (3, True), (7, False)):
        same(parted.run(inputs, track_max=track, every=every), whole.run(inputs, track_max=track, every=every))
    overflows = parted.run(inputs).overflows
    assert any(k.startswith("fsm") for k in overflows) and any(k.startswith("lut_ci") for k in overflows)


def one_input_graph(name: str) -> Graph:
    """The hand graph's blocks on one input port (``w`` a wrapping cast of ``u``), as a golden
    stepper needs."""
    nodes = [make("u", Kind.INPUT, qformat=QFormat.parse("FIX16_8"), port="u"),
             make("w", Kind.CAST, ["u"], qformat=QFormat.parse("FIX12_4"))]
    for sfx, (rounding, overflow) in MODES.items():
        nodes += block(sfx, rounding, overflow)
    return Graph.build(name, nodes, [(x.name, x.name) for x in nodes if x.kind is not Kind.INPUT])


def stepped(stepper: GoldenStepper, levels, n: int) -> tuple:
    """The first ``n`` rows of each advance (the steps run at its level) and the overflow steps."""
    rows = [stepper.advance(int(u), n)[:n] for u in levels]
    return np.concatenate(rows), dict(stepper.overflows)


def test_split_golden_stepper_resumes_with_the_same_integers_and_overflow_steps(monkeypatch):
    g = one_input_graph("hand_parts_golden")
    levels = np.random.default_rng(5).integers(-30000, 30000, 40)
    force_split(monkeypatch)
    parted = GoldenStepper(g)
    assert len(parts_of(parted.compiled.source)) > 5
    parted_rows, parted_ov = stepped(parted, levels, 37)
    # the same steps in one run of the interpreter: each level held for 37 steps (u is FIX16_8,
    # so level / 256 is exactly the integer level)
    ref = FixedInterpreter(g).run({"u": np.repeat(levels / 256.0, 37)})
    assert np.array_equal(parted_rows, np.column_stack([ref.outputs[p] for p in parted.ports]))
    assert parted_ov == ref.overflows and any(step > 37 for step in ref.overflows.values())


def test_retypings_share_the_parts_they_print_alike(monkeypatch):
    """A graph typed again with one node's format changed prints most parts alike: those load the
    modules (and machine code) the first typing compiled."""
    force_split(monkeypatch)
    g = hand_graph("hand_parts_shared")
    name = "a1_nt"
    other = g.map_nodes(lambda n: n.typed(QFormat.parse("FIX11_3")) if n.name == name else n)
    mine, theirs = parts_of(CompiledGraph(g, "fixed").source), parts_of(CompiledGraph(other, "fixed").source)
    assert len(mine) == len(theirs) > 5
    differ = sum(a != b for a, b in zip(mine, theirs))
    assert 1 <= differ <= len(mine) // 2
    assert all("hand_parts_shared" not in part for part in mine)


def test_parts_are_about_the_chosen_size():
    groups = [([i], ["x"] * (1 + i % 7)) for i in range(200)]
    parts = kernel_parts.split_groups(groups)
    assert [ids for part in parts for ids, _ in part] == [[i] for i in range(200)]
    sizes = [sum(len(lines) for _, lines in part) for part in parts]
    assert all(kernel_parts.PART_LINES <= s < kernel_parts.PART_LINES + 7 for s in sizes[:-1])


def lut_family(name: str) -> Graph:
    """The hand graph plus LUTs that share an input and a grid with its own (clamped and periodic,
    both roundings): the kernels print each family once."""
    g = hand_graph(name)
    extra = []
    for sfx, (rounding, _) in MODES.items():
        fin_u, fin_k = QFormat.parse("FIX16_8"), QFormat.parse("FIX16_12")
        extra += [lut(f"lut_ci2_{sfx}", "u", fin_u, QFormat.parse("FIX16_14"), "cos(v)", -2.0, 3.0, 4, True, False, rounding),
                  lut(f"lut_ci3_{sfx}", "u", fin_u, QFormat.parse("FIX12_8"), "sin(v)*cos(v)", -2.0, 3.0, 4, True, False,
                      Rounding.TRUNCATE),
                  lut(f"lut_pi2_{sfx}", f"k9_{sfx}", fin_k, QFormat.parse("FIX16_14"), "sin(2*pi*v)**2", 0.0, 1.0, 6,
                      True, True, rounding)]
    nodes = list(g.nodes) + extra
    return Graph.build(name, nodes, [(x.name, x.name) for x in nodes])


def test_lut_families_print_once_and_compute_the_same_bits():
    g = lut_family("hand_lut_family")
    fixed = CompiledGraph(g, "fixed")
    u = g.nodes.index(g["u"])
    address = [s for s in fixed.source.splitlines() if re.match(rf"\s+d\d+ = v{u} - ", s)]
    assert len(address) == 2          # two grids on u (lut_ci's family, lut_cn's), every mode's LUTs in them
    inputs = random_inputs(2500, seed=9)
    assert_same(fixed.run(inputs, track_max=True), FixedInterpreter(g).run(inputs, track_max=True))
    flt = CompiledGraph(g, "float")
    assert flt.source.count("math.sin(2*math.pi*x") < 4 * 2       # the wrapped angle's calls are shared
    ov = fixed.run(inputs).overflows
    assert {f"lut_ci2_{s}" for s in MODES} | {f"lut_ci3_{s}" for s in MODES} <= set(ov)
