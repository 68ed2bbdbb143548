"""The command line ``pendc``: a thin layer over the Python API (nothing in pendc imports it).

* :mod:`.program` - the parser and ``main`` (pyproject's entry point ``pendc.cli:main``);
* one module per command or family, each with ``add_parsers(sub)`` and its ``cmd_*``:
  :mod:`.build` (build, build --check), :mod:`.simulate`, :mod:`.stimulus`, :mod:`.report`
  (qformat, resources, synth), :mod:`.compare`, :mod:`.ident` (diagnose, fit), :mod:`.hil`
  (hil, animate), :mod:`.plant` (plant new, plant check), :mod:`.robust`, :mod:`.explore`;
* :mod:`.options` - what several commands share: the argument types and help texts, writing
  an output, compiling the model with the command's options, the sweep engine's options;
* :mod:`.data` - the data files' positional arguments and reading options (compare, diagnose, fit);
* :mod:`.help` - help texts that cite the plant's own signal names.

May import everything in pendc. Inside: program -> the command modules -> data -> options;
help and options import no other module of the package.
"""

from .program import build_parser, main

__all__ = ["build_parser", "main"]
