"""No module of the package is specific to one plant (issue 21): the shipped plants' names,
coordinates, constants, effects, their parameters and experiments (read from models/ with
pendc's own loader, see tests/test_plant_generic_ident.py for the rules) appear nowhere in
compiler/ or templates/, in code or in words; the plants live in models/, docs/, tests/, data/."""

from __future__ import annotations

from pathlib import Path

from test_plant_generic_ident import offences, shipped_names

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted([*(ROOT / "compiler").rglob("*.py"), *(ROOT / "templates").rglob("*")])


def test_the_package_names_no_shipped_plant():
    long, short = shipped_names()
    found = []
    for path in SOURCES:
        if path.is_file():
            text = path.read_text(encoding="utf-8")
            found += [f"{path.relative_to(ROOT)}:{line}: {name}" for line, name in offences(text, long, short)]
    assert not found, f"{len(found)} mention(s) of a shipped plant in the package:\n" + "\n".join(found[:60])
