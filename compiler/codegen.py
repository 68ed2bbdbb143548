"""Shared machinery of the generated numba kernels (float simulator and IR kernels).

Generated Python is written once to a cache folder under the hash of its text and
imported from there, so numba's own on-disk cache (which needs a real source file)
makes the second process start fast. This module knows nothing of pendc's model or IR.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import tempfile
from pathlib import Path

from sympy.printing.pycode import PythonCodePrinter


def cache_dir(sub: str = "kernels") -> Path:
    """``$PENDC_CACHE_DIR/sub``, else ``~/.cache/pendc/sub``, else a temporary folder."""
    root = os.environ.get("PENDC_CACHE_DIR")
    path = Path(root) / sub if root else Path.home() / ".cache" / "pendc" / sub
    try:
        path.mkdir(parents=True, exist_ok=True)
        if os.access(path, os.W_OK):
            return path
    except OSError:
        pass
    path = Path(tempfile.gettempdir()) / f"pendc-{sub}"
    path.mkdir(parents=True, exist_ok=True)
    return path


def load_source(source: str, prefix: str = "pendc_ir"):
    """Import the module ``source`` (written once to the cache folder under its hash)."""
    digest = hashlib.sha256(source.encode()).hexdigest()[:20]
    name = f"{prefix}_{digest}"
    if name in sys.modules:  # already imported in this process
        return sys.modules[name]
    path = cache_dir() / f"{name}.py"
    if not path.exists() or path.read_text() != source:
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(source)
        os.replace(tmp, path)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


class NumbaPrinter(PythonCodePrinter):
    """sympy -> Python that numba compiles: ``math`` functions, and Min/Max as nested
    two-argument min/max (numba has no n-ary form)."""

    def __init__(self):
        super().__init__({"standard": "python3", "fully_qualified_modules": True})

    def _print_Min(self, expr):
        return self._nested("min", expr.args)

    def _print_Max(self, expr):
        return self._nested("max", expr.args)

    def _nested(self, fn, args):
        out = self._print(args[0])
        for a in args[1:]:
            out = f"{fn}({out}, {self._print(a)})"
        return out
