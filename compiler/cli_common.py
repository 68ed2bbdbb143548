"""What several commands share: writing a command's output, compiling its model with its options.

The commands' modules (:mod:`pendc.cli` and the ``cli_*`` modules) import this one; it imports
none of them.
"""

from __future__ import annotations

import sys


def write_output(output: str | None, text: str) -> None:
    """``text`` to standard output (no ``-o``, or ``-o -``) or, atomically, to the file ``output``."""
    from .atomic import write_atomic

    if output in (None, "-"):
        sys.stdout.write(text)
    else:
        write_atomic(output, text)


def build_model(model, args):
    """The model compiled with the command's options (from the build cache when it has it)."""
    from .build_cache import compile_cached
    from .passes.pipeline import options_from_model, preset_options

    def tell():
        print("pendc: compiling the model (range analysis and error budget, about half a minute; "
              "cached afterwards)...", file=sys.stderr)

    # a step-time preset also picks its arithmetic (the short chain); other commands have no preset
    options = options_from_model(model, target=getattr(args, "target", None),
                                 **preset_options(getattr(args, "preset", None)))
    return compile_cached(model, options, use_cache=not getattr(args, "no_cache", False), on_miss=tell)
