"""No import circles in the package (issue 25): the modules of ``pendc`` import one another one
way only, so each can be read, tested and moved knowing what it stands on.

The graph is read from the source (every ``import`` statement, those inside functions too: a
deferred import is still a dependency, only a later one), with a package's ``__init__`` left
out as a target (the package face re-exports; ``from .. import __version__`` reads the face, not
a module). A circle names its modules; docs/architecture.md says which way each pair goes. The folders
(``hil/plants`` and ``hil/controllers`` each a folder of its own) must form no circle either.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "compiler"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(["pendc", *parts])


def modules() -> dict:
    """{module name: path} of every module of the package."""
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def imports_of(name: str, path: Path, known: dict) -> set:
    """The package modules (not package faces) that module ``name`` imports anywhere."""
    is_package = path.name == "__init__.py"
    here = name.split(".") if is_package else name.split(".")[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [a.name.replace("pendc", "pendc", 1) for a in node.names if a.name.startswith("pendc")]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[:len(here) - node.level + 1] if node.level > 1 else here
                stem = ".".join(base + ([node.module] if node.module else []))
            elif node.module and node.module.startswith("pendc"):
                stem = node.module
            else:
                continue
            targets = [stem] + [f"{stem}.{a.name}" for a in node.names]
        else:
            continue
        for t in targets:
            if t in known and not known[t].name == "__init__.py" and t != name:
                out.add(t)
    return out


def circles(graph: dict) -> list:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


# subfolders that are folders of their own in the folder graph (the rest count as their parent)
OWN_FOLDERS = ("pendc.hil.plants", "pendc.hil.controllers")


def folder(name: str) -> str:
    """The folder (or top-level module) a module belongs to: ``pendc.passes.lower`` -> ``passes``,
    ``pendc.hil.plants.rtl_cpp`` -> ``hil.plants``, ``pendc.golden`` -> ``golden``."""
    for own in OWN_FOLDERS:
        if name == own or name.startswith(own + "."):
            return own.removeprefix("pendc.")
    parts = name.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def folder_graph(graph: dict) -> dict:
    """{folder: the other folders its modules import}."""
    out = {folder(name): set() for name in graph}
    for name, deps in graph.items():
        out[folder(name)] |= {folder(d) for d in deps} - {folder(name)}
    return out


def test_the_reader_sees_imports_inside_functions_and_relative_ones():
    known = modules()
    deps = imports_of("pendc.sim.readers", known["pendc.sim.readers"], known)
    assert "pendc.sim.signals" in deps and "pendc.errors" in deps and "pendc.sim.csvread" in deps
    # three levels down, relative imports two folders up, and make_plant's deferred imports
    deps = imports_of("pendc.hil.plants.plant", known["pendc.hil.plants.plant"], known)
    assert {"pendc.hil.plants.golden_plant", "pendc.hil.plants.rtl_cpp", "pendc.sim.simulator", "pendc.errors"} <= deps
    assert "pendc.cli.program" in known and "pendc.hil.controllers.measurement" in known
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert folder("pendc.hil.plants.rtl_cpp") == "hil.plants" and folder("pendc.hil.loop") == "hil"
    assert folder_graph({"pendc.ir.a": {"pendc.passes.b"}, "pendc.passes.b": {"pendc.ir.c"}, "pendc.ir.c": set()}) \
        == {"ir": {"passes"}, "passes": {"ir"}}


def test_no_import_circle_in_the_package():
    known = modules()
    graph = {name: imports_of(name, path, known) for name, path in known.items()}
    assert circles(graph) == []


def test_no_import_circle_between_folders():
    """Folders import one another one way (docs/architecture.md's table): ir never imports passes
    back, the plants never the controllers, nothing but the command line imports cli."""
    known = modules()
    graph = folder_graph({name: imports_of(name, path, known) for name, path in known.items()})
    assert {"cli", "hil", "hil.plants", "hil.controllers", "caching", "synth"} <= set(graph)
    assert circles(graph) == []
    assert not [f for f, deps in graph.items() if "cli" in deps and f != "pendc"]
