"""The identification commands diagnose and fit (a thin layer over pendc.ident); compare is in cli_compare."""

from __future__ import annotations

import json
import sys

from .cli_data import add_data_options, load_datasets, load_model_and_data
from .errors import PendcError


def _progress(enabled: bool):
    """A one-line progress bar on stderr when it is a terminal."""
    if not (enabled and sys.stderr.isatty()):
        return None

    def show(done, total, name):
        width = 30
        filled = int(width * done / total)
        sys.stderr.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} {name:<20s}")
        if done == total:
            sys.stderr.write("\n")
        sys.stderr.flush()
    return show


def _fit_of(model, datasets) -> dict:
    """fit% per output with a 0.5 s prediction horizon (see pendc.ident.shooting.horizon_fit)."""
    from .ident.shooting import horizon_fit

    return horizon_fit(model, datasets)


def cmd_diagnose(args) -> int:
    from .ident.diagnose import diagnose

    model, datasets = load_model_and_data(args)
    before = _fit_of(model, datasets)
    d = diagnose(model, datasets, workers=args.workers, progress=_progress(not args.json))
    out = d.to_json()
    for c, row in zip(d.candidates, out["candidates"]):
        row["fit_before"] = before
        row["fit_after"] = _fit_of(model.with_effect(c.effect, c.params), datasets) if c.score > 0.05 else before
    if args.json:
        json.dump(out, sys.stdout, indent=2)
        sys.stdout.write("\n")
        return 0
    lines = [f"fit now: x {before['x']:.1f} %, theta {before['theta']:.1f} %", ""]
    lines.append(f"{'rank':4s} {'effect':18s} {'score':>6s} {'fit x':>7s} {'fit theta':>9s}  parameters")
    for i, row in enumerate(out["candidates"], 1):
        params = ", ".join(f"{k}={v:.4g}" for k, v in row["params"].items())
        lines.append(f"{i:<4d} {row['effect']:18s} {row['score']:6.3f} {row['fit_after']['x']:7.1f} "
                     f"{row['fit_after']['theta']:9.1f}  {params}")
    lines.append("")
    if d.unexplained:
        lines.append("No catalogue effect explains the error (the best removes less than half of it).")
        lines.append("The unexplained force/torque correlates with:")
        lines += [f"  {r['target']:12s} ~ {r['signal']:16s} r = {r['r']:+.2f}" for r in d.correlations]
    else:
        best = d.candidates[0]
        lines.append(f"Most likely missing: {best.effect}. Evidence: {best.evidence}")
        lines.append(f"Next: pendc fit {' '.join(args.data)} --model {args.model or 'models/sct_thesis_final.toml'} "
                     f"--add {best.effect} -o NEW.toml")
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


def cmd_fit(args) -> int:
    from .ident.fit import fit_parameters
    from .ident.diagnose import free_parameters
    from .model.modelfile import save_model

    model, datasets = load_model_and_data(args)
    validation = load_datasets(args, args.validate) if args.validate else datasets
    before = _fit_of(model, validation)           # the model as given, before anything is added
    added = [e.strip() for e in (args.add or "").split(",") if e.strip()]
    for effect in added:
        model = model.with_effect(effect)
    free = [p.strip() for p in (args.free or "").split(",") if p.strip()]
    free = list(dict.fromkeys([p for e in added for p in free_parameters(e)] + free)) or list(model.free)
    if not free:
        raise PendcError("nothing to fit: name effects with --add or parameters with --free")
    result = fit_parameters(model, datasets, free, max_evaluations=args.max_evaluations)
    if not result.converged:
        raise PendcError(f"the fit did not converge ({result.message}, {result.evaluations} evaluations); "
                         f"no model written")
    after = _fit_of(result.model, validation)
    meta = {"generator": "pendc fit", "data": " ".join(args.data), "fitted": ", ".join(free),
            "fit_x_before": round(before["x"], 3), "fit_x_after": round(after["x"], 3),
            "fit_theta_before": round(before["theta"], 3), "fit_theta_after": round(after["theta"], 3)}
    save_model(result.model, args.output, meta=meta)
    out = {"fit_before": before, "fit_after": after,
           "params": {p: {"value": result.values[p], "ci95": result.ci95[p]} for p in free},
           "model": args.output}
    if args.json:
        json.dump(out, sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        print(f"fit x {before['x']:.1f} % -> {after['x']:.1f} %, theta {before['theta']:.1f} % -> {after['theta']:.1f} %")
        for p in free:
            lo, hi = result.ci95[p]
            print(f"  {p:10s} = {result.values[p]:.6g}   95 % CI [{lo:.6g}, {hi:.6g}]")
        print(f"wrote {args.output}")
    return 0


def add_parsers(sub) -> None:
    from .cli_compare import add_parser as add_compare_parser

    add_compare_parser(sub)

    p = sub.add_parser("diagnose", help="which catalogue effect is missing from the model?")
    add_data_options(p)
    p.add_argument("--model", help="model file (default: models/sct_thesis_final.toml)")
    p.add_argument("--json", action="store_true")
    p.add_argument("--workers", type=int, default=2, help="parallel processes (default 2)")
    p.set_defaults(func=cmd_diagnose)

    p = sub.add_parser("fit", help="add effects, refit parameters, write a new model file")
    add_data_options(p)
    p.add_argument("--model", help="model file (default: models/sct_thesis_final.toml)")
    p.add_argument("--add", help="effects to add, comma-separated (their parameters are fitted)")
    p.add_argument("--free", help="more parameters to fit, comma-separated")
    p.add_argument("--validate", nargs="+", help="measurement files to report the fit on (default: the fit data)")
    p.add_argument("-o", "--output", required=True, help="new model file")
    p.add_argument("--max-evaluations", type=int, default=200, help="budget of model evaluations (default 200)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_fit)
