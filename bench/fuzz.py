"""Long differential fuzzing run of the Verilog backend (``make fuzz``; issue 11, point 1).

Draws ``--graphs`` random typed graphs (tests/graphgen.py) from ``--seed``, checks them in
batches of ``--batch`` (one Verilator build each) against the reference interpreter at every
step and, for the first ``--golden`` graphs of each batch, against the compiled golden kernel;
writes the count, the seed, timings and every mismatch to ``-o`` (JSON), with the first
mismatched graphs of a batch shrunk (under Icarus) and printed as Python for a regression
test. Exit status 1 if any mismatch was found (or a batch could not be run).

The batches are tasks on pendc's sweep engine (:mod:`pendc.sweep.engine`): a Dask LocalCluster
on this machine's cores by default, any Dask cluster with ``--scheduler tcp://HOST:PORT``. Batch
``b`` draws its graphs from ``seed + b`` alone, so the findings are the same for the same seed
whatever the number of workers. Each finished batch is kept in ``--work`` (one JSON file per
batch, the report rewritten after each); Ctrl-C keeps what finished and ``--resume`` continues
the run that folder holds, running only its missing batches.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "bench")]

from fuzz_batch import HELPERS, run_batch  # noqa: E402

from pendc.atomic import write_atomic  # noqa: E402
from pendc.errors import PendcError  # noqa: E402
from pendc.sweep.engine import Task, run_tasks  # noqa: E402

RUN = "run.json"                         # the run's options, in --work: what --resume continues
DEFAULTS = {"graphs": 5000, "batch": 250, "golden": 10, "sim": "verilator", "shrink": 3}


def report_of(run: dict, results: dict, t_start: float, workers: int, scheduler: str, failed: dict) -> dict:
    """The JSON record of the batches finished so far, in batch order (so the same for any
    number of workers, timings and wall time aside)."""
    batches = [results[b] for b in sorted(results)]
    done = sum(r["graphs"] for r in batches)
    mismatches = [m for r in batches for m in r["mismatches"]]
    kinds, ii, lint, timings = Counter(), Counter(), Counter(), Counter()
    for r in batches:
        kinds.update(r["node_kinds"])
        ii.update({int(k): v for k, v in r["ii"].items()})
        lint.update(r["lint_warnings"])
        timings.update(r["timings_s"])
    return {
        "graphs": done, "complete": done == run["graphs"], "seed": run["seed"], "batch_seeds": "seed + batch index",
        "batch": run["batch"], "simulator": run["sim"], "steps_per_graph": 40,
        "golden_checked": sum(r["golden_checked"] for r in batches),
        "mismatches": len(mismatches),
        "mismatched_graphs": len({(m["batch"], m["case"]) for m in mismatches}),
        "node_kinds": dict(sorted(kinds.items())), "ii": {str(k): v for k, v in sorted(ii.items())},
        "lint_warnings": dict(sorted(lint.items())), "timings_s": {k: round(v, 2) for k, v in sorted(timings.items())},
        "wall_s": round(time.perf_counter() - t_start, 1), "workers": workers, "scheduler": scheduler,
        "failed_batches": {str(b): why for b, why in sorted(failed.items())},
        "python": platform.python_version(), "details": mismatches[:50],
    }


def write_report(path: Path, report: dict) -> None:
    """Rewritten after every batch, so an interrupted run still leaves its count."""
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, json.dumps(report, indent=2) + "\n")


def _run_options(args, work: Path) -> dict:
    """The run's options: from the command line (and written to ``work``), or with ``--resume``
    from ``work``'s record; a new run clears the previous run's batches."""
    given = [f"--{k}" for k in ("graphs", "seed", "batch", "golden", "sim", "shrink") if getattr(args, k) is not None]
    if args.resume:
        if given:
            raise PendcError(f"--resume continues the run {work}/{RUN} records; drop {', '.join(given)}")
        try:
            return json.loads((work / RUN).read_text())
        except (OSError, ValueError) as exc:
            raise PendcError(f"{work}: no fuzz run to resume ({exc})") from None
    run = {k: getattr(args, k) if getattr(args, k) is not None else v for k, v in DEFAULTS.items()}
    run["seed"] = args.seed if args.seed is not None else int(time.time()) % 1_000_000
    if run["graphs"] < 1 or run["batch"] < 1 or run["golden"] < 0:
        raise PendcError("--graphs and --batch must be >= 1, --golden >= 0")
    work.mkdir(parents=True, exist_ok=True)
    for old in [*work.glob("[0-9]" * 7 + ".json"), work / RUN]:   # the previous run's: this run is another one
        old.unlink(missing_ok=True)
    write_atomic(work / RUN, json.dumps(run) + "\n")
    return run


def _resume_command(args, output: Path) -> str:
    return f"python bench/fuzz.py --resume -o {output}" + (f" --work {args.work}" if args.work else "")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--graphs", type=int, help=f"graphs to check (default {DEFAULTS['graphs']})")
    ap.add_argument("--seed", type=int, help="hypothesis seed (default: clock)")
    ap.add_argument("--batch", type=int, help=f"graphs per simulator build (default {DEFAULTS['batch']})")
    ap.add_argument("--golden", type=int, help="graphs per batch also run by the golden kernel "
                                               f"(default {DEFAULTS['golden']})")
    ap.add_argument("--sim", choices=("verilator", "icarus"), help="simulator (default verilator)")
    ap.add_argument("--shrink", type=int, help="mismatched graphs per batch to shrink (Icarus; default 3)")
    ap.add_argument("-o", "--output", default=str(ROOT / "bench" / "out" / "fuzz.json"))
    ap.add_argument("--work", help="folder of the finished batches (default: the output's name + _batches)")
    ap.add_argument("--resume", action="store_true", help="continue the run --work holds (its missing batches)")
    ap.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="run the batches on this Dask scheduler "
                    "(default: a LocalCluster on this machine's cores)")
    ap.add_argument("--workers", type=int, help="LocalCluster worker processes (default: one per core)")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = ap.parse_args(argv)
    output = Path(args.output)
    work = Path(args.work) if args.work else output.with_name(output.stem + "_batches")
    try:
        if args.workers is not None and args.workers < 1:
            raise PendcError(f"--workers must be at least 1, got {args.workers}")
        if args.workers is not None and args.scheduler:
            raise PendcError("--workers sizes the LocalCluster; a --scheduler's cluster has its own workers")
        run = _run_options(args, work)
        return _fuzz(run, args, output, work)
    except PendcError as exc:
        print(f"fuzz: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:           # before the engine runs (it keeps what finished itself)
        print(f"fuzz: interrupted; continue with {_resume_command(args, output)}", file=sys.stderr)
        return 130


def _fuzz(run: dict, args, output: Path, work: Path) -> int:
    t_start = time.perf_counter()
    starts = list(range(0, run["graphs"], run["batch"]))
    where = {"workers": None, "scheduler": args.scheduler or "LocalCluster"}   # workers: known at the end

    def task(b: int) -> Task:
        n = min(run["batch"], run["graphs"] - starts[b])
        return Task(run_batch, (b, n, run["seed"] + b, run["sim"], run["golden"], run["shrink"]))

    def after(b: int, result: dict, results: dict) -> str:
        report = report_of(run, results, t_start, where["workers"], where["scheduler"], {})
        write_report(output, report)
        return (f"fuzz: batch {b}: {report['graphs']}/{run['graphs']} graphs, {report['mismatches']} mismatches "
                f"({time.perf_counter() - t_start:.0f} s)")

    key = "pendc-fuzz-" + "-".join(str(run[k]) for k in ("seed", "graphs", "batch", "golden", "sim", "shrink"))
    uploads = [ROOT / "tests" / h for h in HELPERS] + [ROOT / "bench" / "fuzz_batch.py"]
    outcome = run_tasks(task, range(len(starts)), work, key=key, scheduler=args.scheduler, workers=args.workers,
                        progress=not args.no_progress, unit="batch", after=after, upload=uploads)
    where.update(workers=outcome.workers, scheduler=outcome.scheduler)
    report = report_of(run, outcome.results, t_start, outcome.workers, outcome.scheduler, outcome.failed)
    write_report(output, report)
    for b, why in outcome.failed.items():
        print(f"fuzz: batch {b} not run ({why}); run it with {_resume_command(args, output)}", file=sys.stderr)
    ran = f"{outcome.ran_now} batches on {outcome.workers} workers, {outcome.scheduler}" if outcome.ran_now else "none run now"
    print(f"fuzz: {report['graphs']} graphs, seed {run['seed']}, {report['mismatches']} mismatches -> {output}"
          f" ({ran}; batches in {work})")
    if outcome.interrupted:
        print(f"fuzz: interrupted: {len(outcome.results)} of {len(starts)} batches kept (in {work}); "
              f"continue with {_resume_command(args, output)}", file=sys.stderr)
        return 130
    return 1 if report["mismatches"] or outcome.failed else 0


if __name__ == "__main__":
    sys.exit(main())
