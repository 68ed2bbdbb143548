"""The package's layout as users and readers meet it (issue 25).

pyproject.toml lists the packages explicitly (``pendc`` maps to the folder ``compiler/``), so a
folder of the package missing there is missing from every installed wheel: ``pendc`` then fails
for users only, never in the source tree.
"""

from __future__ import annotations

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
