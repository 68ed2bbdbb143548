"""The tables' memory-initialisation files beside a build's Verilog, and getting them to the
folder a tool reads them from.

Every table is an instance of the core's one ROM module (``<core>_rom.v``), whose words come
from ``<core>_rom_<table>.mem`` through ``$readmemh``. The instance names the file without a
folder, so Icarus, Verilator and Yosys look for it in their *working* folder, which is seldom
the build folder (hdl_out/ is committed and moves between machines, so it cannot name an
absolute path): whatever runs a tool on a build puts the ``.mem`` files there first. The
functions take either a build's ``{name: text}`` or its folder.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..atomic import write_atomic

VERILOG_SUFFIX = ".v"
MEMORY_SUFFIX = ".mem"


def is_verilog(name: str) -> bool:
    """Whether a build's file is Verilog source (what a simulator or synthesis tool compiles)."""
    return name.endswith(VERILOG_SUFFIX)


def is_memory(name: str) -> bool:
    """Whether a build's file is a table's memory-initialisation file (read at elaboration)."""
    return name.endswith(MEMORY_SUFFIX)


def read_design(folder: str | os.PathLike) -> dict:
    """A build folder's Verilog and memory-initialisation files as ``{name: text}``, by name."""
    return {p.name: p.read_text(encoding="utf-8") for p in sorted(Path(folder).iterdir())
            if p.is_file() and (is_verilog(p.name) or is_memory(p.name))}


def verilog_names(files: dict) -> list:
    """The Verilog files of ``{name: text}``, sorted: the sources to compile (never the .mem files)."""
    return sorted(name for name in files if is_verilog(name))


def put_memory_files(design: dict | str | os.PathLike, dest: str | os.PathLike) -> list:
    """Write the ``.mem`` files of ``design`` (``{name: text}`` or a build folder) into ``dest``,
    the working folder of the tool that will read them; their paths, sorted."""
    files = design if isinstance(design, dict) else read_design(design)
    out = []
    for name in sorted(n for n in files if is_memory(n)):
        write_atomic(Path(dest) / name, files[name])
        out.append(Path(dest) / name)
    return out
