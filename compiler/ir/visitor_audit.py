"""List every node visitor of the compiler that lacks a method for some kind, all at once.

``python -m pendc.ir.visitor_audit`` imports the packages that hold printers and
evaluators with :attr:`NodeVisitor.strict` off, so an incomplete visitor is recorded
instead of failing the import, and prints one line per visitor and missing method;
the exit status is 1 if any is missing. After adding a ``Kind`` this is the to-do list
(a normal import stops at the first incomplete visitor with the same message).
"""

from __future__ import annotations

import importlib
import importlib.util
import pkgutil
import sys

from .visitor import NodeVisitor

AUDITED = ("pendc.ir", "pendc.passes", "pendc.backend", "pendc.golden")


def _modules(names=AUDITED):
    for name in names:
        yield name
        spec = importlib.util.find_spec(name)
        for info in pkgutil.iter_modules(spec.submodule_search_locations or []):
            if info.name != "visitor_audit":
                yield f"{name}.{info.name}"


def audit(names=AUDITED) -> tuple[list, list]:
    """Import the modules under ``names`` collecting incomplete visitors.

    Returns (incomplete: [(qualified name, missing methods or the import error)], complete
    class names). A module that fails to import for another reason (a kind table of its own)
    is reported with its error instead of its visitors."""
    was = NodeVisitor.strict
    NodeVisitor.strict = False
    failed = []
    try:
        for module in _modules(names):
            try:
                importlib.import_module(module)
            except Exception as exc:    # noqa: BLE001 - reported, the audit goes on
                failed.append((module, (f"import failed: {type(exc).__name__}: {exc}",)))
    finally:
        NodeVisitor.strict = was
    incomplete = [(f"{c.__module__}.{c.__qualname__}", m) for c, m in NodeVisitor.incomplete] + failed
    bad = {name for name, _ in incomplete}
    complete = sorted(f"{c.__module__}.{c.__qualname__}" for c in _subclasses(NodeVisitor)
                      if c._dispatch and f"{c.__module__}.{c.__qualname__}" not in bad)
    return incomplete, complete


def _subclasses(cls) -> list:
    out = []
    for sub in cls.__subclasses__():
        out += [sub] + _subclasses(sub)
    return out


def main() -> int:
    """Print the audit; 1 if a visitor lacks a method."""
    incomplete, complete = audit()
    for name, missing in incomplete:
        text = ", ".join(missing)
        print(f"{name}: {text}" if text.startswith("import failed") else f"{name}: define {text}")
    print(f"{len(complete)} complete visitor(s), {len(incomplete)} incomplete")
    return 1 if incomplete else 0


if __name__ == "__main__":
    sys.exit(main())
