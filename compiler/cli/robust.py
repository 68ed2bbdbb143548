"""``pendc robust``: Monte-Carlo HIL over what identification does not know, on Dask.

A thin layer over :mod:`pendc.robust`: parse the options, build the spec and the sample plan,
run the sweep (or replay one run), print the answer.
"""

from __future__ import annotations

import sys
from pathlib import Path

from .options import MODEL_HELP, add_engine_arguments, check_sweep_arguments, positive
from ..errors import PendcError

DEFAULT_OUT = "robust_out"
# options that define a sweep: a resumed sweep takes them from its sweep.json, never from the command line
_SWEEP_OPTIONS = ("model", "design", "controller", "scenario", "samples", "plant", "seed", "method", "vary",
                  "seconds")


def _new_sweep(args):
    """(spec, plan) of the sweep the options describe."""
    from ..model.model_writer import dumps_model
    from ..model.modelfile import fit_uncertainty_of, load_model, parse_model, read_model_text
    from ..robust.sampling import parse_vary, plan_for
    from ..robust.scenario_runner import SweepSpec, check_spec

    text, source = read_model_text(args.model)
    model = parse_model(text, source=source)
    uncertainty = fit_uncertainty_of(text, source, model)
    design = load_model(args.design) if args.design else model
    vary = [parse_vary(v) for v in args.vary or ()]
    plan = plan_for(model, uncertainty, vary, args.method or "lhs", args.seed if args.seed is not None else 0,
                    args.samples if args.samples is not None else 100)
    model_text = dumps_model(model)
    spec = SweepSpec(model_text=model_text, design_text=dumps_model(design) if args.design else model_text,
                     model_source=source, design_source=design.source if args.design else source,
                     controller=args.controller or "builtin", scenario=args.scenario or "swing_up_balance",
                     plant=args.plant or "float", seconds=args.seconds if args.seconds is not None else 12.0)
    check_spec(spec)
    return spec, plan


def _prepare_golden(spec, plan, defaulted: bool):
    """Build (or read from the build cache) the nominal core here, once, before the workers need it.
    A parameter whose range ends change the core's structure (an exponent leaving 1) cannot be
    retyped: held at its nominal value when the ranges are the defaults (said in the output),
    a one-line error when the user asked for it."""
    from ..robust.golden_retype import RetypeTemplate
    from ..robust.scenario_runner import WorkerCache

    model = WorkerCache().models(spec)[0]
    template = RetypeTemplate.of(model)
    held = {}
    for name, lo, hi in plan.ranges:
        for value in (lo, hi):
            try:
                template.graph_for(model.with_params({name: value}))
            except PendcError as exc:
                held.setdefault(name, str(exc))
    if held and not defaulted:
        name, why = next(iter(held.items()))
        raise PendcError(f"--plant golden: --vary {name}: {why}")
    if held:
        return plan.without(set(held), f"held for the golden plant (their values shape the core): {', '.join(held)}")
    return plan


def _replay(args) -> int:
    from ..hil.records import write_run
    from ..robust.engine import read_manifest
    from ..robust.scenario_runner import run_alone

    spec, plan = read_manifest(args.resume)
    params = plan.params_of(args.replay)
    result = run_alone(spec, params)
    folder = Path(args.resume) / f"replay_{args.replay}"
    write_run(folder, result.run, {"model": spec.model_source, "controller": spec.controller,
                                   "robust_run": str(args.replay),
                                   **{k: f"{v:.9g}" for k, v in params.items()}})
    print(f"run {args.replay}: " + ", ".join(f"{k} = {v:.6g}" for k, v in params.items()))
    print(f"{result.name}: {'passed' if result.passed else 'failed: ' + '; '.join(result.failures)}")
    print(f"wrote {folder}/run.csv, summary.json, run.png")
    return 0


def cmd_robust(args) -> int:
    from ..robust.engine import MANIFEST, read_manifest, run_sweep, write_manifest
    from ..robust.results import write_results

    if args.replay is not None and not args.resume:
        raise PendcError("robust: --replay K replays run K of a finished sweep: give its folder with --resume DIR")
    check_sweep_arguments("robust", args, _SWEEP_OPTIONS, "sweep.json")
    if args.resume:
        if args.replay is not None:
            return _replay(args)
        folder = Path(args.resume)
        spec, plan = read_manifest(folder)
    else:
        folder = Path(args.out or DEFAULT_OUT)
        if (folder / MANIFEST).exists():
            raise PendcError(f"{folder}: already holds a sweep; continue it with --resume {folder} or choose another --out")
        if folder.exists() and not folder.is_dir():
            raise PendcError(f"{folder}: is a file; --out names a folder for the sweep")
        spec, plan = _new_sweep(args)
        if spec.plant == "golden":
            plan = _prepare_golden(spec, plan, defaulted=not args.vary and plan.origin.startswith("default"))
        write_manifest(folder, spec, plan)
    print(f"{plan.count} plants sampled around {spec.model_source} ({plan.method}, seed {plan.seed}) "
          f"from {plan.origin}:")
    for line in plan.describe():
        print(f"  {line}")
    outcome = run_sweep(spec, plan, folder, scheduler=args.scheduler, workers=args.workers,
                        progress=not args.no_progress)
    summary = write_results(folder, outcome.rows, spec, plan, outcome)
    _print_summary(summary, outcome, folder)
    if outcome.interrupted:
        print(f"pendc: interrupted: {summary['finished']} of {plan.count} runs kept; continue with "
              f"pendc robust --resume {folder}", file=sys.stderr)
        return 130
    return 0


def _print_summary(summary: dict, outcome, folder: Path) -> None:
    rate = summary["finished"] and summary["success_rate"]
    if outcome.ran_now:
        print(f"ran {outcome.ran_now} runs on {outcome.workers} workers ({outcome.scheduler}) in "
              f"{outcome.wall_s:.1f} s ({outcome.ran_now / outcome.wall_s:.3g} runs/s)")
    if summary["finished"]:
        lo, hi = summary["success_rate_95"]
        print(f"success rate {100 * rate:.1f} % ({summary['passed']} of {summary['finished']} passed; 95 % "
              f"interval {100 * lo:.1f}-{100 * hi:.1f} %)" + (f", {summary['raised']} raised" if summary["raised"] else ""))
    sens = summary["sensitivity"]
    if sens:
        top = sens["ranking"][0]
        print(f"the parameter that matters most: {top['parameter']} (first-order index {top['S1']:.2f} of "
              f"{sens['outcome']}); then " + ", ".join(f"{r['parameter']} {r['S1']:.2f}" for r in sens["ranking"][1:4]))
    failing = [w for w in summary["worst_runs"] if not w["passed"]]
    for w in failing[:3]:
        print(f"  run {w['index']}: {w['why']}  (replay: {w['replay']})")
    print(f"wrote {folder}/rows.parquet, rows.csv, summary.json, report.html")


def add_parsers(sub) -> None:
    """Register ``robust`` on the top-level subparsers."""
    p = sub.add_parser("robust", help="Monte-Carlo HIL on Dask: does the controller hold on every plant the "
                                      "model's uncertainty allows, and which parameter breaks it")
    p.add_argument("--model", help=MODEL_HELP + "; plants are sampled around it")
    p.add_argument("--design", help="model the controller is designed on (default: --model's nominal values)")
    p.add_argument("--controller", help="builtin (default) or package.module:Class (or any pendc hil controller), "
                                        "designed on the nominal model")
    p.add_argument("--scenario", choices=("swing_up_balance", "balance_step", "swing_up_only"),
                   help="the scenario and its pass criterion (default swing_up_balance; docs/hil.md)")
    p.add_argument("--samples", type=int, help="number of sampled plants (default 100)")
    p.add_argument("--plant", choices=("float", "golden"), help="float (default) or golden (bit-exact, the "
                   "nominal build's formats with each sample's constants and tables)")
    p.add_argument("--seed", type=int, help="seed of the design (default 0): the same seed, the same rows")
    p.add_argument("--method", choices=("lhs", "sobol"), help="Latin hypercube (default) or scrambled Sobol")
    p.add_argument("--vary", action="append", metavar="NAME=LO:HI",
                   help="draw NAME uniformly on [LO, HI] (repeatable); without it: the fit's covariance or "
                        "intervals in the model file, else +-5 %% of each constant and +-20 %% of each effect parameter")
    p.add_argument("--seconds", type=positive, help="simulated seconds per run (default 12)")
    add_engine_arguments(p, DEFAULT_OUT, "runs")
    p.add_argument("--replay", type=int, metavar="K", help="with --resume DIR: run K alone, its record into DIR/replay_K")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_robust)
