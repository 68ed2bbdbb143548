"""Caches and packages that cannot lie (issue 11, point 5).

The build cache's key covers every module the compile reads, and an installed wheel
(not the source tree) carries its templates and default models and builds Verilog.
"""

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import textwrap
from pathlib import Path

import pytest

from pendc import build_cache

ROOT = Path(__file__).resolve().parents[1]


def modules_the_compile_imports() -> list:
    """Source files of the pendc modules a fresh interpreter loads for ``compile_model``."""
    code = textwrap.dedent("""
        import json, sys
        import pendc.passes.pipeline
        print(json.dumps({m: getattr(sys.modules[m], "__file__", None) for m in sys.modules
                          if m.startswith("pendc")}))
    """)
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True, cwd=ROOT)
    files = json.loads(out.stdout)
    files.pop("pendc.api")   # pendc/__init__ re-exports the API; the compile never calls it
    return sorted(Path(f) for f in files.values() if f)


def test_every_module_the_compile_imports_changes_the_cache_key(tmp_path, monkeypatch):
    package = tmp_path / "pendc"
    shutil.copytree(build_cache._PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(build_cache, "_PACKAGE", package)
    base = build_cache._compiler_digest()
    modules = modules_the_compile_imports()
    assert any(m.name == "stimuli.py" for m in modules)       # the passes train on the stimuli
    for module in modules:
        copy = package / module.relative_to(ROOT / "compiler")
        original = copy.read_bytes()
        copy.write_bytes(original + b"\n# edited\n")
        assert build_cache._compiler_digest() != base, f"editing {module.name} leaves the build cache key unchanged"
        copy.write_bytes(original)
    assert build_cache._compiler_digest() == base
    # a front end that only consumes builds does not throw the cache away
    (package / "cli_data.py").write_bytes((package / "cli_data.py").read_bytes() + b"\n# edited\n")
    assert build_cache._compiler_digest() == base
