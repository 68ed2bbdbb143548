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
                 "pendc.ir.compiled_source._FixedGen", "pendc.ir.compiled_source._FloatGen",
                 "pendc.ir.verify._TypedRules", "pendc.passes.fold_constants._Rewrite"):
        assert name in complete


def test_adding_a_kind_lists_every_printer_that_lacks_it(tmp_path):
    """A copy of the compiler with one new Kind member (and nothing else changed): a normal
    import fails at the first printer without ``visit_abs``, the audit lists them all."""
    pkg = tmp_path / "pendc"
    shutil.copytree(PACKAGE, pkg, ignore=shutil.ignore_patterns("__pycache__"))
    nodes = pkg / "ir" / "kinds.py"
    text = nodes.read_text()
    anchor = '    FSM = ("fsm", FsmParams, 1)\n'
    assert anchor in text
    nodes.write_text(text.replace(anchor, anchor + '    ABS = ("abs", NoParams, 1)\n'))
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "PYTHONDONTWRITEBYTECODE": "1"}
    run = subprocess.run([sys.executable, "-c", "import pendc.ir.interpret"], env=env, cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode != 0
    assert re.search(r"TypeError: pendc\.ir\.interpret\.\w+ does not handle every node kind: define visit_abs",
                     run.stderr), run.stderr[-2000:]
    audit = subprocess.run([sys.executable, "-m", "pendc.ir.visitor_audit"], env=env, cwd=tmp_path,
                           capture_output=True, text=True, timeout=300)
    assert audit.returncode == 1, audit.stdout + audit.stderr[-2000:]
    lacking = {line.split(":")[0] for line in audit.stdout.splitlines() if line.endswith("define visit_abs")}
    assert {"pendc.ir.interpret.FixedInterpreter", "pendc.ir.interpret.FloatInterpreter",
            "pendc.ir.compiled_source._FixedGen", "pendc.ir.compiled_source._FloatGen",
            "pendc.ir.requant_source.Bounds", "pendc.ir.verify._TypedRules",
            "pendc.passes.fold_constants._Rewrite", "pendc.passes.qformats._KindFormat"} <= lacking
