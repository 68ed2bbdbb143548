"""The compare command of the CLI (a thin layer over pendc.ident.compare)."""

from __future__ import annotations

import json
import sys

from .cli_data import add_data_options, load_model_and_data
from .errors import PendcError


def cmd_compare(args) -> int:
    from .ident.compare import compare, format_comparison, write_html_report
    from .ident.shooting import horizon_fit

    model, datasets = load_model_and_data(args)
    if len(datasets) != 1:
        raise PendcError("compare takes one data file")
    c = compare(model, datasets[0])
    horizon = horizon_fit(model, datasets)
    if args.html:
        write_html_report(c, args.html)
    if args.json:
        json.dump({**c.to_json(), "fit_horizon": horizon, "horizon_s": 0.5}, sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_comparison(c))
        sys.stdout.write(f"\nfit with a 0.5 s prediction horizon (restarting from the measured state; what "
                         f"diagnose and fit use): x {horizon['x']:.2f} %, theta {horizon['theta']:.2f} %\n")
    return 0


def add_parser(sub) -> None:
    p = sub.add_parser("compare", help="compare a model with a measurement: fit, where and why it fails")
    add_data_options(p, many=False)
    p.add_argument("--model", help="model file (default: models/sct_thesis_final.toml)")
    p.add_argument("--json", action="store_true")
    p.add_argument("--html", help="write a self-contained HTML report here")
    p.set_defaults(func=cmd_compare)

