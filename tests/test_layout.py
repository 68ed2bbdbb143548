"""The package's layout as users and readers meet it (issue 25).

docs/architecture.md draws the tree: every path it names in backticks exists (and a
``file.py::name`` is defined there), every ``pendc.x.y`` it names imports. pyproject.toml lists the packages explicitly (``pendc`` maps to the folder ``compiler/``), so a
folder of the package missing there is missing from every installed wheel: ``pendc`` then fails
for users only, never in the source tree.
"""

from __future__ import annotations

import importlib
import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "compiler"


def packages_in_tree() -> set:
    """``pendc.<sub>`` for every folder of ``compiler/`` holding an ``__init__.py``."""
    return {".".join(["pendc", *p.parent.relative_to(PACKAGE).parts])
            for p in PACKAGE.rglob("__init__.py")}


def test_every_package_folder_is_listed_in_pyproject():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    assert {"pendc", "pendc.cli", "pendc.ir"} <= packages_in_tree()
    assert packages_in_tree() - listed == set(), "add these to pyproject.toml's packages"


# a backticked path of docs/architecture.md: relative to the repository, the package or docs/
PATH_LIKE = re.compile(r"^[\w./*-]+(::[\w.]+)?$")
SUFFIXES = (".py", ".md", ".toml", ".j2", ".json", ".v", ".csv")
DOTTED = re.compile(r"\bpendc(?:\.\w+)+(?::\w+)?")


def named_paths(text: str) -> list:
    """The backticked spans of ``text`` that name a file or folder (``x/y.py``, ``x/``, ``a.md``,
    ``x/y.py::name``); templates like ``tests/test_<pass>.py`` are not paths."""
    spans = re.findall(r"`([^`\n]+)`", text)
    return [s for s in spans if PATH_LIKE.match(s) and ("/" in s or s.split("::")[0].endswith(SUFFIXES))]


def missing_paths(text: str) -> list:
    """The named paths that exist nowhere, and ``file::name`` whose file does not define name."""
    missing = []
    for span in named_paths(text):
        path, _, name = span.partition("::")
        found = [base / path for base in (ROOT, PACKAGE, ROOT / "docs")
                 if (any(base.glob(path)) if "*" in path else (base / path).exists())]
        if not found:
            missing.append(span)
        elif name and not re.search(rf"^\s*(def|class)\s+{re.escape(name.split('.')[0])}\b|^{re.escape(name)}\s*=",
                                    found[0].read_text(encoding="utf-8"), re.M):
            missing.append(span)
    return missing


def unresolved_names(text: str) -> list:
    """The ``pendc.a.b[:c]`` names in backticks that do not import (module, then attributes)."""
    out = []
    for span in re.findall(r"`([^`\n]+)`", text):
        for dotted in DOTTED.findall(span):
            parts = dotted.replace(":", ".").split(".")
            for cut in range(len(parts), 0, -1):
                try:
                    obj = importlib.import_module(".".join(parts[:cut]))
                except ImportError:
                    continue
                try:
                    for attr in parts[cut:]:
                        obj = getattr(obj, attr)
                except AttributeError:
                    out.append(dotted)
                break
            else:
                out.append(dotted)
    return out


def test_every_path_docs_architecture_names_exists():
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert len(named_paths(text)) > 40           # the tree, the import table, where a newcomer adds
    assert missing_paths(text) == []
    assert unresolved_names(text) == []


def test_the_path_check_sees_a_wrong_path():
    text = "`cli/build.py`, `hil/plants/plant.py::make_plant`, `docs/nowhere.md`, `ir/kinds.py::NoSuchKind`, " \
           "`tests/test_<pass>.py`, `hdl_out/*.v`, `pendc.hil.plants.make_plant`, `pendc.cli.nowhere`"
    assert missing_paths(text) == ["docs/nowhere.md", "ir/kinds.py::NoSuchKind"]
    assert unresolved_names(text) == ["pendc.cli.nowhere"]
