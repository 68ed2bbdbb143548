"""Reading measurement files for the identification commands (shared by compare, diagnose, fit).

One place that knows how a command line names its data: the positional files and the
options that map other labs' formats onto pendc's columns. Every command calls
:func:`load_datasets`; notes about what was done to a file go to stderr, one line each.
"""

from __future__ import annotations

import sys


def add_data_options(p, many: bool = True) -> None:
    """The positional data file(s) and the reading options, added to parser ``p``."""
    p.add_argument("data", nargs="+" if many else 1, help="measurement file(s) (CSV: t,u,x,theta)")


def note(text: str) -> None:
    print(f"pendc: note: {text}", file=sys.stderr)


def load_datasets(args, paths=None) -> list:
    """Read ``paths`` (default: ``args.data``) with the reading options in ``args``."""
    from .sim.measurements import read_measurements

    datasets = [read_measurements(p) for p in (args.data if paths is None else paths)]
    for d in datasets:
        for w in d.warnings:
            print(f"pendc: warning: {w}", file=sys.stderr)
    return datasets


def load_model_and_data(args):
    from .model.modelfile import load_model

    return load_model(args.model), load_datasets(args)
