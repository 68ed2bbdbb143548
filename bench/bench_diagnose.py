"""Benchmark of `pendc diagnose` on 20 s of 1 kHz data (issue 5 target: < 2 min on 2 cores).

Usage: .venv/bin/python bench/bench_diagnose.py [-o bench/out/diagnose.json] [--workers 2]
Writes the total wall time and the time spent on each candidate effect.
"""

import argparse
import json
import sys
import time
from pathlib import Path

TARGET = 120.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default="bench/out/diagnose.json")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--data", default=str(Path(__file__).resolve().parents[1] / "data" / "hidden_spring.csv"))
    args = ap.parse_args()
    from pendc import load_model
    from pendc.ident.diagnose import diagnose
    from pendc.sim.measurements import read_measurements

    data = read_measurements(args.data)
    model = load_model()
    started = time.perf_counter()
    d = diagnose(model, [data], workers=args.workers)
    total = time.perf_counter() - started
    result = {"benchmark": "diagnose", "data": args.data, "samples": len(data.t),
              "duration_s": float(data.t[-1] - data.t[0]), "workers": args.workers, "seconds": total,
              "target_seconds": TARGET, "meets_target": total < TARGET, "best": d.candidates[0].effect,
              "per_candidate_seconds": {c.effect: c.seconds for c in d.candidates}}
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"diagnose: {total:.1f} s on {args.workers} workers for {len(d.candidates)} candidates "
          f"(target {TARGET:.0f} s: {'met' if result['meets_target'] else 'MISSED'}); best {result['best']} -> {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
