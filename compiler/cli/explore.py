"""``pendc explore``: the synthesis design space (schedules x targets) on Dask, as a Pareto table.

A thin layer over :mod:`pendc.sweep`: parse the options, write the sweep's manifest, run one task
per design point (``pendc build`` and ``synthesize``) on the sweep engine, print the table of
step time against DSP multipliers and LUTs with the Pareto-optimal points marked.
"""

from __future__ import annotations

import sys
from pathlib import Path

from .options import MODEL_HELP, add_engine_arguments, check_sweep_arguments, positive
from ..errors import PendcError

DEFAULT_OUT = "explore_out"
DEFAULT_TARGET = "ecp5-85k"
# options that define a sweep: a resumed sweep takes them from its explore.json
_SWEEP_OPTIONS = ("model", "preset", "target", "ii", "freq")


def _say(text: str) -> None:
    print(f"pendc: {text}", file=sys.stderr)


def _point_line(points: list):
    """The engine's ``after``: one line per finished design point."""
    def after(index: int, row: dict, done: dict) -> str:
        p = points[index]
        head = f"explore: {p.target} {p.label} ({len(done)} of {len(points)}): "
        if row.get("error"):
            return head + f"failed: {row['error']}"
        est = " (estimated)" if row["step_source"] == "estimated" else ""
        step = f"{row['step_time_ns']:.1f} ns{est}" if row["step_time_ns"] is not None else "no step time"
        return head + f"ii {row['ii']}, step {step}, {row['dsp']} DSP, {row['lut']} LUTs"
    return after


def _new_sweep(args) -> dict:
    """The manifest of the sweep the options describe (written once the cluster answers)."""
    from ..model.model_writer import dumps_model
    from ..model.modelfile import load_model
    from ..sweep.explore import points_for

    points = points_for(args.preset or [], args.target or [DEFAULT_TARGET], args.ii or [])
    model = load_model(args.model)
    return {"model_text": dumps_model(model), "model_source": model.source, "points": points,
            "freq_mhz": args.freq if args.freq is not None else 100.0}


def cmd_explore(args) -> int:
    from ..sweep.engine import Task, run_tasks
    from ..sweep.explore import (MANIFEST, ROWS, build_and_synthesize, keep_build, read_manifest, sweep_key,
                                write_manifest)
    from ..sweep.pareto import format_table, pareto_rows, write_table

    check_sweep_arguments("explore", args, _SWEEP_OPTIONS, "explore.json")
    if args.resume:
        folder = Path(args.resume)
        manifest = read_manifest(folder)
    else:
        folder = Path(args.out or DEFAULT_OUT)
        if (folder / MANIFEST).exists():
            raise PendcError(f"{folder}: already holds an explore sweep; continue it with --resume {folder} "
                             "or choose another --out")
        if folder.exists() and not folder.is_dir():
            raise PendcError(f"{folder}: is a file; --out names a folder for the sweep")
        manifest = _new_sweep(args)
    points, freq = manifest["points"], float(manifest["freq_mhz"])

    def start(workers: int) -> None:
        if not args.resume:
            write_manifest(folder, manifest["model_text"], manifest["model_source"], points, freq)
        _say(f"{len(points)} design points of {manifest['model_source']} (build and synthesis each, clock goal "
             f"{freq:g} MHz): " + ", ".join(f"{p.target} {p.label}" for p in points))
    outcome = run_tasks(lambda i: Task(build_and_synthesize, (points[i], manifest["model_text"], freq)),
                        range(len(points)), folder / ROWS, key=sweep_key(manifest), scheduler=args.scheduler,
                        workers=args.workers, progress=not args.no_progress, unit="point",
                        keep=keep_build(folder, points), after=_point_line(points), on_start=start)
    rows = pareto_rows(list(outcome.results.values()))
    meta = {"model_source": manifest["model_source"], "freq_mhz": freq, "objectives": ["step_time_ns", "dsp", "lut"],
            "points": len(points), "finished": len(rows)}
    written = write_table(folder, rows, meta)
    if args.json:
        import json
        print(json.dumps({**meta, "rows": rows}, indent=1))
    else:
        sys.stdout.write(format_table(rows))
    if outcome.ran_now:
        _say(f"ran {outcome.ran_now} design points on {outcome.workers} workers ({outcome.scheduler}) in "
             f"{outcome.wall_s:.1f} s")
    _say(f"wrote {folder}/{', '.join(written)} (* = Pareto-optimal in step time, DSP blocks and LUTs; "
         f"the builds in {folder}/builds/)")
    for index, why in outcome.failed.items():
        _say(f"{points[index].target} {points[index].label}: not finished ({why}); "
             f"run it again with pendc explore --resume {folder}")
    if outcome.interrupted:
        _say(f"interrupted: {len(rows)} of {len(points)} design points kept; continue with "
             f"pendc explore --resume {folder}")
        return 130
    if outcome.failed or (rows and all(r.get("error") for r in rows)):
        return 1
    return 0


def add_parsers(sub) -> None:
    """Register ``explore`` on the top-level subparsers."""
    p = sub.add_parser("explore", help="the synthesis design space on Dask: a build and a synthesis per schedule "
                                       "and target, a Pareto table of step time against DSP blocks and LUTs",
                       description="Build and synthesise the model for every --preset and every --ii (each a "
                                   "`pendc build` schedule) on every --target, as tasks on Dask, and print the "
                                   "step time (ns) against DSP multipliers and LUTs, the Pareto-optimal points "
                                   "marked *. Writes pareto.json, pareto.csv (and pareto.parquet) and the builds "
                                   "into --out.")
    p.add_argument("--model", help=MODEL_HELP)
    p.add_argument("--preset", action="append", metavar="NAME", help="a `pendc build --preset` schedule "
                   "(default, fast, fmax, small, comb; repeatable)")
    p.add_argument("--ii", action="append", type=int, metavar="N", help="a `pendc build --ii N` schedule "
                   "(clock cycles per model step; repeatable)")
    p.add_argument("--target", action="append", metavar="T", help="synthesis target of `pendc report synth` "
                   f"(repeatable; default {DEFAULT_TARGET}; a target without an open place-and-route gives the "
                   "scheduler's estimated step time)")
    p.add_argument("--freq", type=positive, help="clock goal for nextpnr in MHz (default 100)")
    add_engine_arguments(p, DEFAULT_OUT, "design points")
    p.add_argument("--json", action="store_true", help="print the table as JSON (the rows of pareto.json)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_explore)
