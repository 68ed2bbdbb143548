"""``pendc stimulus``: one of the standard input signals of a model, as a CSV."""

from __future__ import annotations

import math

from ..errors import PendcError
from .options import write_output

MIN_RATE, MAX_RATE = 10.0, 10e6      # Hz: below 10 Hz the standard signals' own swings are lost
MAX_ROWS = 5e6                       # a 20 s chirp at 250 kHz; a CSV of some 100 MB


def cmd_stimulus(args) -> int:
    from ..sim.measurements import format_csv
    from ..sim.signals import TIME
    from ..model.modelfile import load_model
    from ..sim.stimuli import Stimuli

    rate = args.rate
    if not (math.isfinite(rate) and MIN_RATE <= rate <= MAX_RATE):
        raise PendcError(f"--rate {rate:g}: the sample rate must be between {MIN_RATE:g} and {MAX_RATE:g} Hz")
    inp = load_model(getattr(args, "model", None)).interface.input
    names = Stimuli(inp).named(fs=MIN_RATE)           # cheap: only the names and durations are read
    if args.name not in names:
        raise PendcError(f"unknown stimulus '{args.name}' (known: {', '.join(names)})")
    rows = (names[args.name][0][-1] + 1.0 / MIN_RATE) * rate
    if rows > MAX_ROWS:
        raise PendcError(f"--rate {rate:g}: {args.name} would be {rows:.3g} rows, more than {MAX_ROWS:.0e}; "
                         f"a plant that fast needs a shorter input file of its own")
    t, u = Stimuli(inp).named(fs=rate)[args.name]
    header = {"generator": "pendc stimulus", "stimulus": args.name, "rate": f"{rate:g} Hz"}
    write_output(args.output, format_csv({TIME: t, inp.name: u}, header))
    return 0


def add_parsers(sub) -> None:
    p = sub.add_parser("stimulus", help="write one of the standard input signals as a CSV (t and the model's input)")
    p.add_argument("name", help="chirp_low, chirp_high, steps, swing_up or random")
    p.add_argument("--model", help="model whose input the signal drives: its name, range and neutral value (default: the default model)")
    p.add_argument("--rate", type=float, default=1000.0,
                   help="samples a second (default 1000); a fast plant needs ten a period of its fastest mode "
                        "(pendc plant check names it), e.g. --rate 20000 for a converter's kHz")
    p.add_argument("-o", "--output", help="output CSV; default (or '-'): standard output")
    p.set_defaults(func=cmd_stimulus)
