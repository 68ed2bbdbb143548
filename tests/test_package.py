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

from pendc.caching import build_cache

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
    (package / "cli" / "data.py").write_bytes((package / "cli" / "data.py").read_bytes() + b"\n# edited\n")
    assert build_cache._compiler_digest() == base


def run(cmd, **kw):
    # a PYTHONPATH naming a source checkout shows pip its pendc.egg-info: "already satisfied", nothing installed
    kw.setdefault("env", {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")})
    out = subprocess.run(cmd, capture_output=True, text=True, **kw)
    assert out.returncode == 0, f"{' '.join(map(str, cmd))} failed:\n{out.stdout[-2000:]}\n{out.stderr[-2000:]}"
    return out


def test_an_installed_wheel_builds_verilog_from_another_folder(tmp_path):
    """Build the wheel from a copy of the sources, install it into a fresh venv, run ``pendc build``.

    The dependencies come from this interpreter's site-packages through a ``.pth`` line written
    after the install (so pip does not see the editable pendc and the wheel's copy is the one
    imported); nothing is downloaded. About 20 s with a warm build cache."""
    import setuptools
    assert int(setuptools.__version__.split(".")[0]) >= 77, \
        "building pendc without build isolation needs setuptools >= 77 (pyproject's `license = \"MIT\"`)"
    src = tmp_path / "src"
    for part in ("compiler", "templates", "models"):
        shutil.copytree(ROOT / part, src / part, ignore=shutil.ignore_patterns("__pycache__"))
    for part in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / part, src / part)
    run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
         str(tmp_path / "dist"), str(src)], cwd=tmp_path)
    wheel, = (tmp_path / "dist").glob("pendc-*.whl")
    venv = tmp_path / "venv"
    run([sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", str(venv)])
    py = venv / "bin" / "python"
    run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps", "--no-build-isolation",
         str(wheel)])
    site = Path(run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip())
    (site / "zz_deps_of_the_test_env.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    where = run([str(py), "-c", "import pendc, sys; print(pendc.__file__)"], cwd=elsewhere, env=env).stdout
    assert Path(where.strip()).is_relative_to(venv), f"the source tree's pendc was imported: {where}"
    build = run([str(venv / "bin" / "pendc"), "build", "-o", "out"], cwd=elsewhere, env=env)
    assert "wrote" in build.stderr
    out = elsewhere / "out"
    names = sorted(p.name for p in out.iterdir())
    assert "pendulum_core.v" in names and "report.json" in names
    report = json.loads((out / "report.json").read_text())
    assert set(report["files"]) == set(names)
    assert "module pendulum_core" in (out / "pendulum_core.v").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dist", "elsewhere", "src", "venv"]
