"""Benchmark of ``pendc robust``'s engine: runs per second on 1 and 2 local Dask workers and the
scaling efficiency.

Usage: .venv/bin/python bench/bench_robust.py [-o bench/out/robust.json] [--samples 16] [--plant float|golden]
       [--seconds 12]
The same sweep (the rig model, alpha and b_x varied, the builtin swing-up and balance, seed 0) runs
on a LocalCluster of 1 worker, then of 2. Each figure is the whole sweep's wall time, the cluster's
start and each worker's first kernel load included, as a user sees it; ``steady_runs_per_s``
leaves out the cluster's start (from its first finished row). Efficiency = rate(2) / (2 x rate(1)).
The rows of the two sweeps must be identical (checked: the figure is void otherwise).
"""

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def sweep(spec, plan, workers: int) -> dict:
    from pendc.robust.engine import read_rows, run_sweep, write_manifest

    with tempfile.TemporaryDirectory(prefix="bench_robust_") as tmp:
        write_manifest(Path(tmp), spec, plan)
        outcome = run_sweep(spec, plan, tmp, workers=workers, progress=False)
        files = sorted((Path(tmp) / "rows").glob("*.json"), key=lambda p: p.stat().st_mtime)
        first = files[0].stat().st_mtime
        last = files[-1].stat().st_mtime
        rows = [read_rows(tmp, plan.count)[i] for i in range(plan.count)]
    steady = (len(files) - 1) / (last - first) if last > first else None
    return {"workers": workers, "runs": outcome.ran_now, "wall_s": round(outcome.wall_s, 3),
            "runs_per_s": round(outcome.ran_now / outcome.wall_s, 4),
            "steady_runs_per_s": round(steady, 4) if steady else None,
            "passed": sum(r["passed"] for r in rows)}, rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default="bench/out/robust.json")
    ap.add_argument("--samples", type=int, default=16)
    ap.add_argument("--plant", default="float", choices=("float", "golden"))
    ap.add_argument("--seconds", type=float, default=12.0)
    args = ap.parse_args()
    from pendc.model.model_writer import dumps_model
    from pendc.model.modelfile import load_model
    from pendc.robust.sampling import plan_for
    from pendc.robust.scenario_runner import SweepSpec

    model = load_model(REPO / "models" / "sct_rig.toml")
    text = dumps_model(model)
    spec = SweepSpec(model_text=text, design_text=text, model_source="models/sct_rig.toml",
                     design_source="models/sct_rig.toml", plant=args.plant, seconds=args.seconds)
    plan = plan_for(model, None, [("alpha", 200.0, 320.0), ("b_x", 700.0, 1000.0)], "lhs", 0, args.samples)
    if args.plant == "golden":        # the nominal build once, before the workers read it from the cache
        from pendc.robust.golden_retype import RetypeTemplate
        RetypeTemplate.of(model)
    one, rows_one = sweep(spec, plan, 1)
    print(f"1 worker: {one}", file=sys.stderr)
    two, rows_two = sweep(spec, plan, 2)
    print(f"2 workers: {two}", file=sys.stderr)
    result = {"benchmark": "robust", "plant": args.plant, "scenario": spec.scenario, "seconds_per_run": args.seconds,
              "samples": args.samples, "cores": os.cpu_count(), "load_average": list(os.getloadavg()),
              "one_worker": one, "two_workers": two, "rows_identical": rows_one == rows_two,
              "scaling_efficiency": round(two["runs_per_s"] / (2 * one["runs_per_s"]), 3),
              "steady_scaling_efficiency": (round(two["steady_runs_per_s"] / (2 * one["steady_runs_per_s"]), 3)
                                            if one["steady_runs_per_s"] and two["steady_runs_per_s"] else None),
              "measured": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    return 0 if result["rows_identical"] else 1


if __name__ == "__main__":
    sys.exit(main())
