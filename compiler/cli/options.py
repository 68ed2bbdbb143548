"""What several commands share: the argument types and the --model help, writing a command's
output, compiling its model with its options, the sweep engine's options (robust, explore).

The command modules of :mod:`pendc.cli` import this one; it imports none of them.
"""

from __future__ import annotations

import argparse
import math
import sys

DEFAULT_HORIZON = 0.5   # s: pendc.ident.horizon.DEFAULT_HORIZON, not imported (building the parser loads no numpy)
MODEL_HELP = "model file (default: the shipped default model, which models/DEFAULT names; '-': standard input)"


def finite(text: str) -> float:
    """An argparse type: a finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


def positive(text: str) -> float:
    """An argparse type: a finite number above zero (a step, a rate, a time)."""
    value = finite(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return value


def write_output(output: str | None, text: str) -> None:
    """``text`` to standard output (no ``-o``, or ``-o -``) or, atomically, to the file ``output``."""
    from ..atomic import write_atomic

    if output in (None, "-"):
        sys.stdout.write(text)
    else:
        write_atomic(output, text)


def build_model(model, args):
    """The model compiled with the command's options (from the build cache when it has it)."""
    from ..caching.build_cache import compile_cached
    from ..passes.pipeline import options_from_model, preset_options

    def tell():
        print("pendc: compiling the model (range analysis and error budget, about half a minute; "
              "cached afterwards)...", file=sys.stderr)

    # a step-time preset also picks its arithmetic (the short chain); other commands have no preset
    options = options_from_model(model, target=getattr(args, "target", None),
                                 **preset_options(getattr(args, "preset", None)))
    return compile_cached(model, options, use_cache=not getattr(args, "no_cache", False), on_miss=tell)


def check_sweep_arguments(command: str, args, sweep_options: tuple, manifest: str) -> None:
    """The checks ``pendc robust`` and ``pendc explore`` share on the engine's options: --workers
    sizes a LocalCluster only, and --resume takes neither sweep options nor another --out (the
    sweep continues as its ``manifest`` describes, in its own folder)."""
    from pathlib import Path

    from ..errors import PendcError

    if args.workers is not None and args.workers < 1:
        raise PendcError(f"{command}: --workers must be at least 1, got {args.workers}")
    if args.workers is not None and args.scheduler:
        raise PendcError(f"{command}: --workers sizes the LocalCluster; a --scheduler's cluster has its own workers")
    if args.resume:
        given = [f"--{o}" for o in sweep_options if getattr(args, o) not in (None, [])]
        if given:
            raise PendcError(f"{command}: --resume continues the sweep its {manifest} describes; drop {', '.join(given)}")
        if args.out and Path(args.out) != Path(args.resume):
            raise PendcError(f"{command}: --resume writes into the sweep's own folder; drop --out")


def add_engine_arguments(p, default_out: str, resumed: str) -> None:
    """The sweep engine's options ``pendc robust`` and ``pendc explore`` share (``resumed``: what a
    resume runs, for its help)."""
    p.add_argument("--out", help=f"sweep folder (default {default_out})")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="run on this Dask scheduler (default: a "
                   "LocalCluster on this machine's cores)")
    p.add_argument("--workers", type=int, help="LocalCluster worker processes (default: one per core)")
    p.add_argument("--resume", metavar="DIR", help=f"continue the sweep in DIR (only its missing {resumed})")


def note_offsets(model, what: str) -> None:
    """A note when ``model`` has sensor offsets on encoder-read positions, which ``what`` (the
    core, a HIL plant) leaves out (a converter's offset is in the core)."""
    names = model.sensor_offsets_without_hardware()
    if names:
        print(f"pendc: note: {', '.join(names)} (a sensor offset on an encoder) is left out of {what}: an "
              f"incremental encoder counts from where it was homed; simulate --quantize and identification "
              f"apply it", file=sys.stderr)


def horizon_of(args, model=None, datasets=()) -> float:
    """``--horizon``, checked: seconds between the restarts from the measured state; not given,
    the data's (:func:`pendc.ident.horizon.chosen_horizon`, with a note when it is not 0.5 s)."""
    from ..ident.horizon import chosen_horizon

    horizon, why = chosen_horizon(args.horizon, datasets, model, "--horizon")
    if why:
        print(f"pendc: note: {why}", file=sys.stderr)
    return horizon


def horizon_words(horizon: float) -> str:
    """`` --horizon H`` for a suggested command when it is not the default."""
    return "" if horizon == DEFAULT_HORIZON else f" --horizon {horizon:g}"


def add_horizon_option(p, who: str) -> None:
    """The ``--horizon`` option compare, diagnose and fit share."""
    p.add_argument("--horizon", type=float, metavar="SECONDS",
                   help=f"seconds between restarts from the measured state, over which {who} judges the model "
                        f"(default {DEFAULT_HORIZON:g}, doubled while the data move less than four sensor steps "
                        f"in it: a heater's minutes; shortened to 0.2, 0.1, 0.05, ... where the records hold "
                        f"fewer than eight segments and a segment still spans ten time constants of the plant's "
                        f"fastest mode: a converter's milliseconds); a plant unstable faster than that, recorded "
                        f"under feedback, needs a few of its time constants (a magnet: 0.02)")
