"""``pendc stimulus``: one of the standard input signals of a model, as a CSV."""

from __future__ import annotations

from ..errors import PendcError
from .options import write_output


def cmd_stimulus(args) -> int:
    from ..sim.measurements import format_csv
    from ..sim.signals import TIME
    from ..model.modelfile import load_model
    from ..sim.stimuli import Stimuli

    inp = load_model(getattr(args, "model", None)).interface.input
    stimuli = Stimuli(inp).named()
    if args.name not in stimuli:
        raise PendcError(f"unknown stimulus '{args.name}' (known: {', '.join(stimuli)})")
    t, u = stimuli[args.name]
    name = inp.name
    write_output(args.output, format_csv({TIME: t, name: u}, {"generator": "pendc stimulus", "stimulus": args.name}))
    return 0


def add_parsers(sub) -> None:
    p = sub.add_parser("stimulus", help="write one of the standard input signals as a CSV (t and the model's input)")
    p.add_argument("name", help="chirp_low, chirp_high, steps, swing_up or random")
    p.add_argument("--model", help="model whose input the signal drives: its name, range and neutral value (default: the default model)")
    p.add_argument("-o", "--output", help="output CSV; default (or '-'): standard output")
    p.set_defaults(func=cmd_stimulus)
