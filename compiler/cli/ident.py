"""The identification commands diagnose and fit (a thin layer over pendc.ident); compare is in cli/compare.py.

Every figure printed says what it is (the 0.5 s horizon fit or the free-run fit, pooled
or for which file); notes about what was left out go to stderr as ``pendc: note: ...``.
"""

from __future__ import annotations

import json
import math
import sys

from .data import add_data_options, load_datasets, load_model_and_data, note
from .options import DEFAULT_HORIZON, add_horizon_option, horizon_of, horizon_words
from ..errors import PendcError


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


def _json_ready(value):
    """``value`` with non-finite floats as null, so the output is strict JSON."""
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _dump(out: dict) -> None:
    json.dump(_json_ready(out), sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")


def diverging_note(figures: dict) -> list:
    """A note when the model's horizon runs leave the data far behind (fit below -100 %): on a
    plant unstable faster than the horizon (a magnet's 17 ms against 0.5 s) recorded under feedback,
    each restart diverges, and whatever a candidate changes is judged on that divergence."""
    bad = {o: v for o, v in (figures.get("pooled") or {}).items() if v < DIVERGING_FIT}
    if not bad:
        return []
    worst = ", ".join(f"{o} {v:.0f} %" for o, v in bad.items())
    return [f"the model's {figures.get('label', 'horizon fit')} leaves these data far behind ({worst}): its runs "
            f"between restarts diverge (a plant unstable faster than the horizon, recorded under feedback); "
            f"a shorter --horizon, a few of its time constants, lets them follow (compare --horizon shows which)"]


DIVERGING_FIT = -100.0      # %: a horizon fit below this means the restarts diverge


def _notes(lines) -> None:
    for line in dict.fromkeys(lines):
        note(line)


def _figure_lines(fig: dict, indent: str = "") -> list:
    """The pooled figure, then one line per file when there are several."""
    from ..ident.figures import describe, values_text

    lines = [indent + describe(fig) + (f" (pooled over {len(fig['files'])} files)" if len(fig["files"]) > 1 else "")]
    if len(fig["files"]) > 1:
        for f in fig["files"]:
            lines.append(f"{indent}  {f['file']} ({f['experiment']}): {values_text(f)}")
    return lines


def cmd_diagnose(args) -> int:
    from ..ident.diagnose import diagnose
    from ..ident.evidence import parameter_hint
    from ..ident.parameter_trials import try_parameters
    from ..model.modelfile import fitted_parameters
    from ..ident.outputs import parse_outputs
    from ..ident.shooting import horizon_figures

    model, datasets = load_model_and_data(args)
    outputs = parse_outputs(args.outputs, model)
    horizon = horizon_of(args, model, datasets)
    before = horizon_figures(model, datasets, horizon, outputs=outputs)
    only = [e.strip() for e in (args.effects or "").split(",") if e.strip()] or None
    d = diagnose(model, datasets, segment=horizon, workers=args.workers, progress=_progress(not args.json),
                 outputs=outputs, effects=only)
    _notes(list(d.notes) + diverging_note(before))
    out = d.to_json()
    out["fit_now"] = before
    for c, row in zip(d.candidates, out["candidates"]):
        row["fit_after"] = (horizon_figures(model.with_effect(c.effect, c.params), datasets, horizon, outputs=outputs)
                            if c.score > 0.05 else before)
    hint = parameter_hint(model, d.correlations, fitted_parameters(args.model)) if d.unexplained else None
    trials = try_parameters(model, datasets, hint[0].split(","), segment=horizon, outputs=outputs) if hint else []
    if hint:
        out["parameter_hint"] = {"free": hint[0].split(","), "reason": hint[1],
                                 "tested": [t.to_json() for t in trials]}
    if args.json:
        _dump(out)
        return 0
    shown = list(before["pooled"])
    lines = _figure_lines(before, "now: ") + [""]
    heads = " ".join(f"{'fit ' + o:>9s}" for o in shown)
    lines.append(f"{'rank':4s} {'effect':18s} {'score':>6s} {heads}  parameters ({horizon:g} s horizon fit after "
                 f"adding it)")
    for i, row in enumerate(out["candidates"], 1):
        params = ", ".join(f"{k}={v:.4g}" for k, v in row["params"].items())
        figs = " ".join(f"{row['fit_after']['pooled'].get(o, float('nan')):9.1f}" for o in shown)
        pinned = "  (at its bound)" if row["at_bound"] else ""
        lines.append(f"{i:<4d} {row['effect']:18s} {row['score']:6.3f} {figs}  {params}{pinned}")
    lines.append("")
    ratio = ", ".join(f"{o} {r:.2f}x" for o, r in (d.noise_ratio or {}).items())
    if d.at_noise_level:
        lines.append(f"Nothing systematic left: the remaining error is at the noise level of the measurement "
                     f"chain (the sensors' quantisation and input noise; residual / noise-only residual: {ratio}).")
    elif d.unexplained:
        pinned = [c for c in d.candidates if c.at_bound and c.score >= 0.5]
        why = ("the best removes less than half of it" if d.candidates else "no candidate was tested") + "".join(
            f"; {c.effect} removes {100 * c.score:.0f} % only with {c.at_bound}, where the data push it"
            for c in pinned[:2])
        lines.append(f"No catalogue effect explains the error ({why}), and it is "
                     f"above the noise level ({ratio} the noise-only residual).")
        if d.correlations:
            lines.append("The unexplained acceleration correlates with:")
            lines += [f"  {r['target']:21s} ~ {r['signal']:20s} r = {r['r']:+.2f}" for r in d.correlations]
        else:
            lines.append("No equation error to correlate: it is the acceleration of a measured position with a "
                         "rate state, and these data have none.")
        if hint:
            lines.append(f"This points at a constant the model has: {hint[1]}.")
            lines.append(f"Tested, each freed alone (a short {horizon:g} s horizon fit): "
                         + "; ".join(t.words() for t in trials) + ".")
            lines.append(f"Try: pendc fit {_data_words(args)} --model {args.model or _default_model()}"
                         f"{horizon_words(horizon)} --free {hint[0]} -o NEW.toml")
    elif d.tie:
        lines.append(f"Ambiguous: {d.tie['message']}")
        for name in d.tie["effects"]:
            c = next(c for c in d.candidates if c.effect == name)
            lines.append(f"  {name}: {c.evidence}")
        lines.append(f"Next: run the separating experiment, then pendc diagnose both files together; or fit each: "
                     f"pendc fit {_data_words(args)} --model {args.model or _default_model()}"
                     f"{horizon_words(horizon)} --add {d.tie['effects'][0]} -o NEW.toml")
    else:
        best = d.candidates[0]
        lines.append(f"Most likely missing: {best.effect}. Evidence: {best.evidence}")
        lines.append(f"Next: pendc fit {_data_words(args)} --model {args.model or _default_model()}"
                     f"{horizon_words(horizon)} --add {best.effect} -o NEW.toml")
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


def _default_model() -> str:
    """The shipped default model's file as a command names it (``models/<file>``)."""
    from ..model.modelfile import default_model_path

    return f"models/{default_model_path().name}"


def _data_words(args) -> str:
    """The data files and the reading options they were read with, for a command to suggest or record."""
    from .data import reading_arguments

    return " ".join([*args.data, *reading_arguments(args)])


def _command(args) -> str:
    """The fit command line, rebuilt from the parsed options (paths as given)."""
    parts = ["pendc fit", _data_words(args)]
    for flag, value in (("--model", args.model), ("--add", args.add), ("--free", args.free),
                        ("--outputs", args.outputs), ("--objective", getattr(args, "objective", "auto"))):
        if value:
            parts += [flag, str(value)]
    if getattr(args, "horizon", None) is not None:
        parts += ["--horizon", f"{args.horizon:g}"]
    if args.validate:
        parts += ["--validate", *args.validate]
    return " ".join(parts + ["-o", str(args.output)])


def _provenance(args, free: list, before: dict, after: dict) -> dict:
    """Where a fitted model came from: source model, data (by content hash), command, figures."""
    from ..model.modelfile import data_fingerprint

    meta = {"generator": "pendc fit", "source_model": args.model or _default_model(),
            "data": "; ".join(data_fingerprint(p) for p in args.data),
            "command": _command(args),
            "fitted": ", ".join(free)}
    if args.validate:
        meta["validation_data"] = "; ".join(data_fingerprint(p) for p in args.validate)
    for o, v in before["pooled"].items():
        meta[f"horizon_fit_{o}_before"] = round(v, 3)
    for o, v in after["pooled"].items():
        meta[f"horizon_fit_{o}_after"] = round(v, 3)
    return meta


def cmd_fit(args) -> int:
    from pathlib import Path

    from ..ident.diagnose import free_parameters
    from ..ident.figures import free_run_figures
    from ..ident.fit import fit_parameters
    from ..ident.outputs import parse_outputs
    from ..ident.shooting import horizon_figures
    from ..atomic import write_atomic
    from ..model.modelfile import default_model_path
    from ..model.model_writer import dumps_fitted
    from ..sim.signals import signals_of

    model, datasets = load_model_and_data(args)
    outputs = parse_outputs(args.outputs, model)
    horizon = horizon_of(args, model, datasets)
    validation = load_datasets(args, args.validate, plant=model) if args.validate else datasets
    before = horizon_figures(model, validation, horizon, outputs=outputs)   # the model as given
    free_before = free_run_figures(model, validation, outputs=outputs)
    added = [e.strip() for e in (args.add or "").split(",") if e.strip()]
    for effect in added:
        if effect in model.effects:   # asking to add what is there means: fit it
            note(f"the model has {effect} already; its parameters are fitted from their current values")
            continue
        model = model.with_effect(effect)
    free = [p.strip() for p in (args.free or "").split(",") if p.strip()]
    free = list(dict.fromkeys([p for e in added for p in free_parameters(e, model)] + free)) or list(model.free)
    if not free:
        raise PendcError("nothing to fit: name effects with --add or parameters with --free")
    result = fit_parameters(model, datasets, free, segment=horizon, max_evaluations=args.max_evaluations,
                            outputs=outputs, objective=args.objective)
    _notes(result.notes)
    if not result.converged:
        raise PendcError(f"the fit did not converge ({result.message}, {result.evaluations} evaluations); "
                         f"no model written")
    if result.unidentifiable and not args.force:
        raise PendcError(f"the data do not identify {', '.join(result.unidentifiable)} "
                         f"({result.refused()}); no model written (--force writes it anyway)")
    after = horizon_figures(result.model, validation, horizon, outputs=outputs)
    free_after = free_run_figures(result.model, validation, outputs=outputs)
    source = Path(args.model) if args.model else default_model_path()
    meta = {**_provenance(args, free, before, after), "objective": result.objective}
    text = dumps_fitted(result.model, source.read_text(encoding="utf-8"), meta,
                        {p: result.ci95[p] for p in free if p not in result.unidentifiable},
                        covariance=result.covariance_of(free))
    write_atomic(args.output, text)
    for p, why in result.unidentifiable.items():
        note(f"{p} is not identified by these data ({why}); written because of --force")
    out = {"fit_before": before, "fit_after": after, "free_run_before": free_before, "free_run_after": free_after,
           "params": {p: {"value": result.values[p], "ci95": result.ci95[p],
                          "identifiable": p not in result.unidentifiable} for p in free},
           "objective": result.objective, "horizons": [h if h < 1e8 else "whole record" for h in result.horizons],
           "objective_reason": result.objective_reason,
           "model": args.output}
    if args.json:
        _dump(out)
        return 0
    judged = ", ".join(args.validate) if args.validate else "the fit data"
    lines = [f"figures on {judged}" + (" (held out: --validate)" if args.validate else "") + ":"]
    lines += ["before: " + line for line in _figure_lines(before)] + ["after:  " + line for line in _figure_lines(after)]
    lines += ["before: " + line for line in _figure_lines(free_before)]
    lines += ["after:  " + line for line in _figure_lines(free_after)]
    angles = set(signals_of(model).periodic)
    if any(v < 0 for f in (free_before, free_after) for o, v in f["pooled"].items() if o in angles):
        from ..ident.figures import UNWRAPPED_NOTE
        lines.append(f"(free-run: {UNWRAPPED_NOTE})")
    for p in free:
        lo, hi = result.ci95[p]
        flag = "   NOT IDENTIFIED" if p in result.unidentifiable else ""
        lines.append(f"  {p:10s} = {result.values[p]:.6g}   95 % CI [{lo:.6g}, {hi:.6g}]{flag}")
    stages = " -> ".join(f"{h:g} s" if h < 1e8 else "the whole record" for h in result.horizons)
    lines.append(f"objective: {result.objective} (fitted on horizons {stages}; the 95 % intervals from the "
                 f"{result.horizons[0]:g} s horizon's segments)"
                 + (f": {result.objective_reason}" if result.objective_reason else ""))
    lines.append(f"wrote {args.output}")
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


def _add_ident_options(p) -> None:
    p.add_argument("--model", help="model file (default: the shipped default model, which models/DEFAULT names)")
    p.add_argument("--outputs", help="outputs to compare: positions of the model's plant, comma-separated (the "
                                     "default model's: {plant:positions}, or any of them; default: every output "
                                     "the data move; held or missing ones are left out with a note)")
    p.add_argument("--json", action="store_true",
                   help="print the result as JSON instead of text (non-finite numbers as null)")


def add_parsers(sub) -> None:
    p = sub.add_parser("diagnose", help="which catalogue effect is missing from the model?")
    add_data_options(p)
    _add_ident_options(p)
    p.add_argument("--workers", type=int, default=2, help="parallel processes (default 2)")
    add_horizon_option(p, "each candidate")
    p.add_argument("--effects", metavar="A,B", help="test only these catalogue effects, comma-separated "
                                                    "(default: every effect the model lacks and the data could show)")
    p.set_defaults(func=cmd_diagnose)

    p = sub.add_parser("fit", help="add effects, refit parameters, write a new model file",
                       description="Files of different experiments fit together, each simulated under its own "
                                   "experiment; any plant constant ({plant:constants}) or effect parameter can be freed.")
    add_data_options(p)
    _add_ident_options(p)
    p.add_argument("--add", help="effects to add, comma-separated (their parameters are fitted)")
    p.add_argument("--free", help="more parameters to fit, comma-separated: plant constants or effect parameters "
                   "(the plant file's [constants] and its catalogue's params)")
    p.add_argument("--validate", nargs="+", help="measurement files to report the fit on (default: the fit data)")
    p.add_argument("-o", "--output", required=True, help="new model file")
    p.add_argument("--max-evaluations", type=int, default=200, help="budget of model evaluations (default 200)")
    add_horizon_option(p, "the fit (its first stage and its intervals)")
    p.add_argument("--objective", choices=("horizon", "free-run", "auto"), default="auto",
                   help="what the fit minimises: the 0.5 s horizon error; or, continued from it to 2 s, 8 s and "
                        "the whole record, the free run's; auto (default): the free run where it is reproducible "
                        "on these data (the headline test), else the horizon")
    p.add_argument("--force", action="store_true",
                   help="write the model even if the data do not identify every fitted parameter")
    p.set_defaults(func=cmd_fit)
