"""The visitor protocol: a printer or evaluator without a method for some node kind cannot be
defined, and adding a kind makes the compiler list every printer that lacks it."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from pendc.ir.nodes import Kind, make
from pendc.ir.visitor import NodeVisitor, method_name

PACKAGE = Path(__file__).resolve().parent.parent / "compiler"


def _methods(skip=()):
    """A namespace with a visit method for every kind but ``skip``, each returning the kind."""
    return {method_name(k): (lambda self, node, k=k: k) for k in Kind if k not in skip}


def test_method_names_follow_the_kind():
    assert method_name(Kind.REGISTER) == "visit_register" and method_name(Kind.COMPARE) == "visit_compare"


def test_complete_visitor_dispatches_on_the_kind():
    Complete = type("Complete", (NodeVisitor,), _methods())
    v = Complete()
    assert v.visit(make("c", Kind.CONST, value=1.0)) is Kind.CONST
    assert v.visit(make("m", Kind.MUX, ["s", "a", "b"])) is Kind.MUX
    assert all(v.handles(k) for k in Kind)


def test_a_missing_method_fails_when_the_class_is_defined():
    with pytest.raises(TypeError, match=r"does not handle every node kind: define visit_lut, visit_fsm$"):
        type("Forgetful", (NodeVisitor,), _methods(skip=(Kind.LUT, Kind.FSM)))
    with pytest.raises(TypeError, match="visit_slice"):
        class Printer(NodeVisitor):      # noqa: F841 - the class statement itself must fail
            locals().update(_methods(skip=(Kind.SLICE,)))


def test_elsewhere_and_abstract_bases():
    # an abstract base is not checked; its concrete subclass is, minus the kinds declared elsewhere
    Base = type("Base", (NodeVisitor,), {}, abstract=True, elsewhere=(Kind.CONST, Kind.INPUT))
    Concrete = type("Concrete", (Base,), _methods(skip=(Kind.CONST, Kind.INPUT)))
    v = Concrete()
    assert not v.handles(Kind.CONST) and v.handles(Kind.ADD)
    with pytest.raises(ValueError, match="const node 'c'.*elsewhere"):
        v.visit(make("c", Kind.CONST, value=1.0))
    with pytest.raises(TypeError, match="define visit_add$"):
        type("Short", (Base,), _methods(skip=(Kind.CONST, Kind.INPUT, Kind.ADD)))


def test_the_compiler_visitors_are_complete():
    from pendc.ir.visitor_audit import audit
    incomplete, complete = audit()
    assert incomplete == []
    # the interpreters, the kernel printers, the verifier's rules and the passes' rules all dispatch this way
    for name in ("pendc.ir.interpret.FixedInterpreter", "pendc.ir.interpret.FloatInterpreter",
                 "pendc.ir.compiled_source._FixedGen", "pendc.ir.float_source.FloatGen",
                 "pendc.ir.verify._TypedRules", "pendc.passes.fold_constants._Rewrite"):
        assert name in complete


# the worked example of docs/architecture.md: ABS (|a|, f = fa) added to a copy of the compiler
NEW_KIND = ("ir/kinds.py", '    FSM = ("fsm", FsmParams, 1)\n', '    ABS = ("abs", NoParams, 1)\n')
PRINTERS = [   # (file, line after which the method goes, the method): one per IR visitor
    ("ir/interpret.py", "        return -vals[ins[0]], False\n",
     "\n    def visit_abs(self, node, vals, ins):\n        return abs(vals[ins[0]]), False\n"),
    ("ir/interpret.py", "        return self._requant(node, -vals[ins[0]], self.fmt[ins[0]].frac)\n",
     "\n    def visit_abs(self, node, vals, ins):\n"
     "        return self._requant(node, abs(vals[ins[0]]), self.fmt[ins[0]].frac)\n"),
    ("ir/compiled_source.py", '        return self.rq(i, node, f"-v{self.idx[a]}", (-hi, -lo), self.g[a].qformat.frac)\n',
     "\n    def visit_abs(self, node, i):\n        a = node.inputs[0]\n        lo, hi = self.bounds(a)\n"
     '        return self.rq(i, node, f"abs(v{self.idx[a]})", (0, max(-lo, hi)), self.g[a].qformat.frac)\n'),
    ("ir/float_source.py", '        return [f"v{i} = -{self._a(node)[0]}"]\n',
     '\n    def visit_abs(self, node, i):\n        return [f"v{i} = abs({self._a(node)[0]})"]\n'),
    ("ir/requant_source.py", "visit_mux = visit_cast = _own\n", "    visit_abs = _own\n"),
    ("ir/verify.py", '"the negation")      # -min_int needs one bit more\n', "\n    visit_abs = visit_neg\n"),
    ("passes/fold_constants.py", "    visit_cast = visit_compare = visit_lut = _evaluate_only\n",
     "    visit_abs = _evaluate_only\n"),
    ("passes/qformats.py", "    visit_register = visit_lut = visit_mux = visit_cast = _ranged\n", "    visit_abs = _ranged\n"),
    # the estimates: |a| costs what a negation and its mux cost
    ("passes/resources.py", "    visit_add = visit_sub = visit_neg = _adder\n", "    visit_abs = _adder\n"),
    ("passes/resources.py", "visit_gain = visit_add = visit_sub = visit_neg = visit_mul = visit_lut = visit_mux = "
     "visit_compare = _logic\n", "    visit_abs = _logic\n"),
    ("passes/resources.py", "    visit_add = visit_sub = _sum\n", "    visit_abs = _sum\n"),
    ("passes/node_delay.py", "    visit_add = visit_sub = visit_neg = _adder\n", "    visit_abs = _adder\n"),
]
ABS_RUN = """
import numpy as np
from pendc.ir.compiled import CompiledGraph
from pendc.ir.graph import Graph
from pendc.ir.interpret import FixedInterpreter, FloatInterpreter
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat
from pendc.ir.verify import verify
from pendc.passes.fold_constants import fold_constants
q = QFormat.parse
nodes = [make("u", Kind.INPUT, port="u", qformat=q("FIX16_8")), make("c", Kind.CONST, value=0.5, qformat=q("FIX16_8")),
         make("d", Kind.SUB, ["u", "c"], qformat=q("FIX17_8")), make("y", Kind.ABS, ["d"], qformat=q("FIX18_8"))]
g = Graph.build("abs", nodes, [("y", "y")])
verify(g)
verify(g, typed=True)
u = np.array([-3.5, 2.25, -0.125, 0.5, -128.0])
want = np.abs(u - 0.5)
fixed = FixedInterpreter(g).run({"u": u}).outputs["y"]
golden = CompiledGraph(g, "fixed").run({"u": u}).outputs["y"]
assert list(fixed) == list(golden) == list(np.round(want * 256).astype(int)), (fixed, golden)
# the shared kernels' general form prints _FixedGen's method with its numbers as data
wider = g.map_nodes(lambda n: n.typed(q("FIX19_9")) if n.name == "y" else n)
shared = CompiledGraph(g, "fixed", like=wider)
assert "qp[" in shared.source and list(shared.run({"u": u}).outputs["y"]) == list(fixed)
assert list(FloatInterpreter(g).run({"u": u}).outputs["y"]) == list(want)
untyped = Graph.build("abs", [n.typed(None) for n in nodes[1:]] + [make("u", Kind.CONST, value=-2.0)], [("y", "y")])
assert [n.kind for n in fold_constants(untyped).nodes] == [Kind.CONST]
print(g.text().splitlines()[4])
"""


@pytest.fixture(scope="module")
def with_abs(tmp_path_factory):
    """A copy of the compiler whose only change is the new Kind member."""
    root = tmp_path_factory.mktemp("abs")
    shutil.copytree(PACKAGE, root / "pendc", ignore=shutil.ignore_patterns("__pycache__"))
    _patch(root / "pendc", [NEW_KIND])
    return root


def _patch(pkg: Path, edits) -> None:
    for rel, anchor, insert in edits:
        path = pkg / rel
        text = path.read_text()
        assert text.count(anchor) == 1, (rel, anchor)
        path.write_text(text.replace(anchor, anchor + insert))


def _run(root: Path, *args):
    env = {**os.environ, "PYTHONPATH": str(root), "PYTHONDONTWRITEBYTECODE": "1"}
    return subprocess.run([sys.executable, *args], env=env, cwd=root, capture_output=True, text=True, timeout=300)


def test_adding_a_kind_lists_every_printer_that_lacks_it(with_abs):
    """A normal import fails at the first printer without ``visit_abs``; the audit lists them all."""
    run = _run(with_abs, "-c", "import pendc.ir.interpret")
    assert run.returncode != 0
    assert re.search(r"TypeError: pendc\.ir\.interpret\.\w+ does not handle every node kind: define visit_abs",
                     run.stderr), run.stderr[-2000:]
    audit = _run(with_abs, "-m", "pendc.ir.visitor_audit")
    assert audit.returncode == 1, audit.stdout + audit.stderr[-2000:]
    lacking = {line.split(":")[0] for line in audit.stdout.splitlines() if line.endswith("define visit_abs")}
    assert {"pendc.ir.interpret.FixedInterpreter", "pendc.ir.interpret.FloatInterpreter",
            "pendc.ir.compiled_source._FixedGen", "pendc.ir.float_source.FloatGen",
            "pendc.ir.requant_source.Bounds", "pendc.ir.verify._TypedRules",
            "pendc.passes.fold_constants._Rewrite", "pendc.passes.qformats._KindFormat"} <= lacking


def test_a_new_kind_runs_once_its_printers_have_a_method(tmp_path, with_abs):
    """The same copy plus one method per printer the audit listed (the Verilog view-model aside):
    nothing else changes, and ABS builds, verifies, folds and runs bit-exact in the interpreter
    and the compiled golden kernel."""
    root = tmp_path / "abs_done"
    shutil.copytree(with_abs, root)
    _patch(root / "pendc", PRINTERS)
    audit = _run(root, "-m", "pendc.ir.visitor_audit")
    left = [line for line in audit.stdout.splitlines() if "visit_abs" in line]
    assert all(line.startswith("pendc.backend.") for line in left), audit.stdout
    run = _run(root, "-c", ABS_RUN)
    assert run.returncode == 0, run.stderr[-3000:]
    assert run.stdout.strip() == "y = abs(d) : FIX18_8 round wrap"
