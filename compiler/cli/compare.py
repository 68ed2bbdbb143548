"""The compare command of the CLI (a thin layer over pendc.ident.compare and its reports)."""

from __future__ import annotations

import json
import sys

from .data import add_data_options, load_datasets, note
from .options import add_horizon_option, horizon_of
from ..errors import PendcError

EPILOG = """\
examples:
  pendc compare data/hidden_spring_validation.csv
  pendc compare data/hidden_spring_validation.csv --model MODEL.toml \\
      --model demo_out/with_spring.toml --html demo_out/compare.html     (two models side by side)

The first line is the headline: the free-run fit where a free run is meaningful on the
data, else the 0.5 s horizon fit, and the next line says why. A model written by `pendc fit` carries the covariance of what
was fitted: compare draws its 95 %% prediction band and says how often the data leave it."""


def cmd_compare(args) -> int:
    import numpy as np

    from ..ident.outputs import parse_outputs
    from ..ident.report_html import write_html_report
    from ..ident.report_text import text_report
    from ..ident.sidebyside import compare_models
    from ..model.modelfile import fit_uncertainty_of, parse_model, read_model_text
    from ..sim.signals import signals_of

    if args.band < 0 or args.band == 1:
        raise PendcError(f"--band must be 0 (no band) or at least 2 draws, got {args.band}")
    paths = args.model or [None]
    texts = [read_model_text(p) for p in paths]
    models = [parse_model(text, source=source) for text, source in texts]
    uncertainties = [fit_uncertainty_of(text, source, m) for (text, source), m in zip(texts, models)]
    columns = {m.interface.name: signals_of(m).all_columns for m in models}
    if len(set(columns.values())) > 1:
        raise PendcError("the models describe different plants (" + "; ".join(
            f"{name}: {', '.join(cols)}" for name, cols in columns.items()) + "): compare one plant's models at a time")
    datasets = load_datasets(args, plant=models[0])
    horizon = horizon_of(args, models[0], datasets)
    with np.errstate(all="ignore"):   # an undefined figure is NaN by design; no warning for it
        s = compare_models(models, datasets, horizon=horizon, outputs=parse_outputs(args.outputs, models[0]),
                           uncertainties=uncertainties, band_samples=args.band, seed=args.seed)
        for line in s.notes():
            note(line)
        if args.html:
            write_html_report(s, args.html)
    if args.json:
        out = s.runs[0][0].to_json() if len(models) == 1 and len(datasets) == 1 else s.to_json()
        json.dump(out, sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(text_report(s))
    return 0


def add_parsers(sub) -> None:
    """``pendc compare``: its data options, models and outputs."""
    import argparse

    from ..model.fit_uncertainty import BAND_SAMPLES

    p = sub.add_parser("compare", help="compare a model (or several) with measurements: fit, where and why it fails",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_data_options(p, many=True)
    p.add_argument("--model", action="append", metavar="MODEL.toml",
                   help="model file; repeat to put models side by side (default: the shipped default model)")
    add_horizon_option(p, "the horizon fit")
    p.add_argument("--outputs", help="outputs to compare: positions of the model's plant, comma-separated (the "
                                     "default model's: {plant:positions}, or any of them; default: every output "
                                     "the data move; held or missing ones are left out with a note)")
    p.add_argument("--band", type=int, default=BAND_SAMPLES, metavar="N",
                   help="a fitted model's 95 %% prediction band from N parameter draws of its [fit] covariance "
                        f"(default {BAND_SAMPLES}; 0: none; a model no fit wrote has none)")
    p.add_argument("--seed", type=int, default=0, help="seed of the prediction band's draws (default 0)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument("--html", help="write a self-contained HTML report here")
    p.set_defaults(func=cmd_compare)
