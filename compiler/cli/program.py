"""The program ``pendc``: its parser (each command's module adds its sub-parsers) and ``main``.

Every command turns bad input into one ``pendc: error: ...`` line on stderr and
exit status 2; nothing is half-written (outputs go through a temporary file).
"""

from __future__ import annotations

import argparse
import re
import sys

from ..errors import PendcError
from . import build, compare, explore, hil, ident, plant, report, robust, simulate, stimulus


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage mistake is one line, like every other error."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # argparse takes "-1e-6" for an option ("expected one argument"); a number in any
        # notation is a value, so `--dt -1e-6` is refused for being negative, not misread
        self._negative_number_matcher = re.compile(r"^-(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?$|^-(?:inf|nan)$")

    def _get_formatter(self):
        # help texts cite the plant through {plant:WORD}, filled from the interface when printed
        from .help import formatter_with_plant_words

        return formatter_with_plant_words(self.formatter_class)(prog=self.prog)

    def format_help(self) -> str:
        """argparse's help; fit and diagnose also list every body's effect catalogue (names for --add)."""
        text = super().format_help()
        if self.prog.split()[-1] in ("fit", "diagnose"):
            from .help import effects_by_body

            text += "\n" + effects_by_body()
        return text

    def parse_known_args(self, args=None, namespace=None):
        """argparse's, but a sub-command refuses what it does not take itself, naming itself and
        what it does take (the top level would only say "unrecognized arguments"); a command
        reading data also takes ``--<SIGNAL>-unit/-zero/-sign VALUE`` for ``--unit/--zero/--sign
        SIGNAL=VALUE``."""
        if args is not None and "--unit" in self._option_string_actions:
            from .data import expand_signal_options

            try:
                args = expand_signal_options(list(args), self._option_string_actions)
            except PendcError as exc:
                self.error(str(exc))
        parsed, extras = super().parse_known_args(args, namespace)
        if extras and self.prog != "pendc":
            takes = [a.option_strings[-1] for a in self._actions
                     if a.option_strings and not isinstance(a, argparse._HelpAction)]
            self.error(f"unrecognized arguments: {' '.join(extras)}"
                       + (f" ({self.prog.removeprefix('pendc ')} takes {', '.join(takes)})" if takes else ""))
        return parsed, extras

    def error(self, message):
        # the top-level parser's prog is "pendc", which main() already prints once
        prefix = self.prog.removeprefix("pendc").strip()
        raise PendcError(f"{prefix}: {message}" if prefix else message)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="pendc", description="Compiler and identification workbench for HIL plant models.")
    from .. import __version__
    parser.add_argument("--version", action="version", version=f"pendc {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    # the order of `pendc --help`'s list of commands
    for module in (simulate, build, hil, robust, explore, plant, compare, ident, report, stimulus):
        module.add_parsers(sub)
    return parser


# the arguments that name a file to read (where '-' means standard input), by attribute
_INPUTS = {"model": "--model", "input": "--input", "data": "data file", "validate": "--validate", "run": "run"}


def _stdin_read_once(args) -> None:
    """Standard input holds one file: refuse a command line that gives '-' to two inputs."""
    given = []
    for attr, name in _INPUTS.items():
        value = getattr(args, attr, None)
        values = value if isinstance(value, list) else [value]
        given += [name for v in values if v is not None and str(v) == "-"]
    if len(given) > 1:
        raise PendcError(f"standard input ('-') can be read only once; it is given to {' and '.join(given)}")


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if not getattr(args, "func", None):
            parser.print_help(sys.stderr)
            return 2
        _stdin_read_once(args)
        return args.func(args)
    except PendcError as exc:
        print(f"pendc: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. `pendc ... | head`
        return 0
    except OSError as exc:  # unwritable output folder, disk full, ...
        print(f"pendc: error: {exc.filename or ''}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pendc: interrupted", file=sys.stderr)
        return 130
