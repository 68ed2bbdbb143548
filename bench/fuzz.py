"""Long differential fuzzing run of the Verilog backend (``make fuzz``; issue 11, point 1).

Draws ``--graphs`` random typed graphs (tests/graphgen.py) from ``--seed``, checks them in
batches of ``--batch`` (one Verilator build each) against the reference interpreter at every
step and, for the first ``--golden`` graphs of each batch, against the compiled golden kernel;
writes the count, the seed, timings and every mismatch to ``-o`` (JSON), with the first
mismatched graphs of a batch shrunk (under Icarus) and printed as Python for a regression
test. Exit status 1 if any mismatch was found.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
import warnings
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from fuzzcases import case_source, draw_cases  # noqa: E402
from fuzzharness import check_batch  # noqa: E402
from fuzzshrink import shrink  # noqa: E402

from pendc.atomic import write_atomic  # noqa: E402


def write_report(args, done, mismatches, timings, kinds, ii, golden, lint, t_start, complete) -> None:
    """The JSON record, rewritten after every batch so an interrupted run still leaves its count."""
    report = {
        "graphs": done, "complete": complete, "seed": args.seed, "batch_seeds": "seed + batch index", "batch": args.batch,
        "simulator": args.sim, "steps_per_graph": 40, "golden_checked": golden,
        "mismatches": len(mismatches),
        "mismatched_graphs": len({(m["batch"], m["case"]) for m in mismatches}),
        "node_kinds": dict(sorted(kinds.items())), "ii": {str(k): v for k, v in sorted(ii.items())},
        "lint_warnings": dict(lint), "timings_s": {k: round(v, 2) for k, v in timings.items()},
        "wall_s": round(time.perf_counter() - t_start, 1), "python": platform.python_version(),
        "details": mismatches[:50],
    }
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(out, json.dumps(report, indent=2) + "\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--graphs", type=int, default=5000, help="graphs to check (default 5000)")
    ap.add_argument("--seed", type=int, default=int(time.time()) % 1_000_000, help="hypothesis seed (default: clock)")
    ap.add_argument("--batch", type=int, default=250, help="graphs per simulator build (default 250)")
    ap.add_argument("--golden", type=int, default=10, help="graphs per batch also run by the golden kernel")
    ap.add_argument("--sim", choices=("verilator", "icarus"), default="verilator")
    ap.add_argument("--shrink", type=int, default=3, help="mismatched graphs per batch to shrink (Icarus)")
    ap.add_argument("-o", "--output", default=str(ROOT / "bench" / "out" / "fuzz.json"))
    args = ap.parse_args(argv)
    if args.graphs < 1 or args.batch < 1 or args.golden < 0:
        ap.error("--graphs and --batch must be >= 1, --golden >= 0")
    warnings.simplefilter("ignore")     # hypothesis' own notes about non-test use
    t_start = time.perf_counter()
    mismatches, timings, kinds, ii, golden, lint = [], Counter(), Counter(), Counter(), 0, Counter()
    done = 0
    with tempfile.TemporaryDirectory(prefix="pendc-fuzz-") as tmp:
        for b, start in enumerate(range(0, args.graphs, args.batch)):
            n = min(args.batch, args.graphs - start)
            t0 = time.perf_counter()
            cases = draw_cases(n, args.seed + b)
            timings["generate"] += time.perf_counter() - t0
            result = check_batch(cases, Path(tmp) / f"b{b}", args.sim, golden=args.golden)
            timings.update(result.timings)
            golden += result.golden_checked
            ii.update(result.ii)
            lint.update(w.split(":")[0] for w in result.warnings)
            for c in cases:
                kinds.update(n.kind.value for n in c.graph.nodes)
            shrunk = {}
            for m in result.mismatches:
                if m.case not in shrunk and len(shrunk) < args.shrink:
                    small = shrink(cases[m.case], Path(tmp) / "shrink", "icarus")
                    shrunk[m.case] = case_source(small)
                mismatches.append({"batch": b, "seed": args.seed + b, "case": m.case, "engine": m.engine,
                                   "step": m.step, "port": m.port, "expected": m.expected, "actual": m.actual,
                                   "detail": m.detail, "graph": cases[m.case].graph.text(),
                                   "shrunk": shrunk.get(m.case)})
            done += n
            write_report(args, done, mismatches, timings, kinds, ii, golden, lint, t_start,
                         complete=done == args.graphs)
            print(f"fuzz: batch {b}: {done}/{args.graphs} graphs, {len(mismatches)} mismatches "
                  f"({time.perf_counter() - t_start:.0f} s)", flush=True)
    print(f"fuzz: {done} graphs, seed {args.seed}, {len(mismatches)} mismatches -> {args.output}")
    return 1 if mismatches else 0


if __name__ == "__main__":
    sys.exit(main())
