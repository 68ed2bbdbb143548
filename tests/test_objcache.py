"""pendc.caching.objcache, the OBJCACHE launcher of Verilator builds: a runtime source compiled twice
with the same compiler, flags and headers is compiled once; anything that changes the
preprocessed source or the flags compiles again; the design's own files and failed compiles are
never stored."""

import os
import shutil
import stat
import sys
from pathlib import Path

import pytest

from pendc.atomic import current_umask
from pendc.caching.objcache import cacheable, objcache_env, run

pytestmark = pytest.mark.skipif(shutil.which("c++") is None, reason="no C++ compiler")


@pytest.fixture
def setup(tmp_path):
    """A 'runtime' folder (a source and its header) outside a build folder, and a compiler
    wrapper that logs each real compile (``-c``) before running c++."""
    runtime, build, cache = tmp_path / "runtime", tmp_path / "build", tmp_path / "cache"
    for d in (runtime, build, cache):
        d.mkdir()
    (runtime / "lib.h").write_text("#define ANSWER 42\n")
    (runtime / "lib.cpp").write_text('#include "lib.h"\nint answer() { return ANSWER; }\n')
    log = tmp_path / "compiles.log"
    cxx = tmp_path / "cxx"
    cxx.write_text(f'#!/bin/sh\ncase " $* " in *" -c "*) echo "$*" >> "{log}";; esac\nexec c++ "$@"\n')
    cxx.chmod(cxx.stat().st_mode | stat.S_IXUSR)
    return runtime, build, cache, log, str(cxx)


def compiles(log: Path) -> int:
    return len(log.read_text().splitlines()) if log.exists() else 0


def test_the_second_identical_compile_is_a_copy(setup):
    runtime, build, cache, log, cxx = setup
    args = [cxx, "-Os", "-MMD", f"-I{runtime}", "-c", "-o", "lib.o", str(runtime / "lib.cpp")]
    assert run(args, str(cache), cwd=str(build)) == 0
    first = (build / "lib.o").read_bytes()
    assert compiles(log) == 1 and (build / "lib.d").is_file()
    (build / "lib.o").unlink()
    (build / "lib.d").unlink()
    other = build / "again"
    other.mkdir()
    assert run(args, str(cache), cwd=str(other)) == 0
    assert compiles(log) == 1, "the stored object was compiled again"
    assert (other / "lib.o").read_bytes() == first and (other / "lib.d").is_file()
    assert (other / "lib.o").stat().st_mode & 0o777 == 0o666 & ~current_umask(), "a copy keeps mkstemp's 0600"


def test_a_changed_header_or_flag_compiles_again(setup):
    runtime, build, cache, log, cxx = setup
    args = [cxx, "-Os", f"-I{runtime}", "-c", "-o", "lib.o", str(runtime / "lib.cpp")]
    run(args, str(cache), cwd=str(build))
    (runtime / "lib.h").write_text("#define ANSWER 43\n")
    run(args, str(cache), cwd=str(build))
    assert compiles(log) == 2
    run([cxx, "-O2"] + args[2:], str(cache), cwd=str(build))
    assert compiles(log) == 3
    run(args, str(cache), cwd=str(build))           # the second header's entry is still there
    assert compiles(log) == 3


def test_two_builds_at_once_compile_the_runtime_once(setup, tmp_path):
    """The suite's Verilator core and bus builds start together: both missed the cache and
    compiled the runtime side by side (verilated.cpp and friends, some 35 CPU s, twice). The
    second now waits for the first's object."""
    import subprocess

    runtime, build, cache, log, cxx = setup
    slow = tmp_path / "slow_cxx"            # a compile that takes a while, so the two overlap
    slow.write_text(f'#!/bin/sh\ncase " $* " in *" -c "*) sleep 1;; esac\nexec "{cxx}" "$@"\n')
    slow.chmod(slow.stat().st_mode | stat.S_IXUSR)
    launcher = Path(__file__).parents[1] / "compiler" / "caching" / "objcache.py"
    procs = []
    for name in ("one", "two"):
        (build / name).mkdir()
        args = [str(slow), "-Os", "-MMD", f"-I{runtime}", "-c", "-o", "lib.o", str(runtime / "lib.cpp")]
        procs.append(subprocess.Popen([sys.executable, "-S", str(launcher), *args], cwd=build / name,
                                      env={**os.environ, "PENDC_OBJCACHE_DIR": str(cache)}))
    assert [p.wait(timeout=120) for p in procs] == [0, 0]
    assert compiles(log) == 1, "both builds compiled the runtime"
    assert (build / "one" / "lib.o").read_bytes() == (build / "two" / "lib.o").read_bytes()


def test_design_files_and_failures_are_never_stored(setup):
    runtime, build, cache, log, cxx = setup
    (build / "design.cpp").write_text("int f() { return 1; }\n")
    for _ in range(2):
        assert run([cxx, "-c", "-o", "design.o", "design.cpp"], str(cache), cwd=str(build)) == 0
    assert compiles(log) == 2
    assert cacheable([cxx, "-c", "-o", "design.o", "design.cpp"], str(build)) is None
    (runtime / "bad.cpp").write_text("int f( {\n")
    for _ in range(2):
        assert run([cxx, "-c", "-o", "bad.o", str(runtime / "bad.cpp")], str(cache), cwd=str(build)) != 0
    assert not any(cache.rglob("*.o")) and not (build / "bad.o").exists()


def test_environment_switch(monkeypatch, tmp_path):
    monkeypatch.setenv("PENDC_CACHE_DIR", str(tmp_path / "c"))
    env = objcache_env({})
    assert env["OBJCACHE"].split() == [sys.executable, "-S", str(Path(__file__).parents[1] / "compiler" / "caching" / "objcache.py")]
    assert Path(env["PENDC_OBJCACHE_DIR"]).is_dir()
    assert "OBJCACHE" not in objcache_env({"PENDC_OBJCACHE": "0"})
    monkeypatch.setenv("PENDC_CACHE_DIR", str(tmp_path / "with space"))
    assert "OBJCACHE" not in objcache_env({}), "make would split a path with a space"
    assert os.environ.get("OBJCACHE") is None
