"""Benchmark of reading a large measurement CSV (issue 11 target: a 1e7-row file in well under 1 GiB).

Usage: .venv/bin/python bench/bench_read_csv.py [--rows 10000000] [-o bench/out/read_csv.json]
Writes a file of ``--rows`` rows (t,u,x,theta at 1 kHz, encoder-quantised) to a
temporary folder, then reads it in a fresh process the way the identification
commands do (pendc.cli.data: all checks, resolution estimates, uniform grid) and
records the peak resident memory above the process's baseline, bytes per row and time.
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

TARGET_BYTES = 1 << 30
BLOCK_ROWS = 1_000_000

READER = r"""
import json, resource, sys, time
from pendc.sim.measurements import read_measurements
from pendc.sim.readers import ReadOptions
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
started = time.perf_counter()
m = read_measurements(sys.argv[1], options=ReadOptions(uniform=True, plausible=True))
seconds = time.perf_counter() - started
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"rows": len(m.t), "baseline_bytes": base, "peak_bytes": peak, "seconds": seconds,
                  "resolution": m.resolution, "notes": list(m.notes)}))
"""


def write_file(path: Path, rows: int) -> None:
    """A realistic file, written in blocks so the writer itself stays small."""
    q_theta, q_x = 2 * np.pi / 20000, 2.5e-6
    with open(path, "w") as f:
        f.write("# generator: bench/bench_read_csv.py\nt,u,x,theta\n")
        for start in range(0, rows, BLOCK_ROWS):
            k = np.arange(start, min(rows, start + BLOCK_ROWS))
            t = k * 1e-3
            theta = np.round(2.5 * np.sin(2 * np.pi * 0.9 * t) / q_theta) * q_theta
            x = np.round(0.2 * np.sin(2 * np.pi * 0.3 * t) / q_x) * q_x
            u = 5.0 + 3.0 * np.sin(2 * np.pi * 0.3 * t)
            np.savetxt(f, np.column_stack([t, u, x, theta]), fmt=["%.3f", "%.6f", "%.7g", "%.9g"], delimiter=",")


def measure(path: Path) -> dict:
    """Read ``path`` in a fresh interpreter; its peak RSS above the post-import baseline."""
    root = Path(__file__).resolve().parents[1]
    res = subprocess.run([sys.executable, "-c", READER, str(path)], capture_output=True, text=True, cwd=root,
                         check=True)
    out = json.loads(res.stdout)
    out["extra_bytes"] = out["peak_bytes"] - out["baseline_bytes"]
    out["bytes_per_row"] = out["extra_bytes"] / out["rows"]
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=10_000_000)
    ap.add_argument("-o", "--output", default="bench/out/read_csv.json")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.csv"
        started = time.perf_counter()
        write_file(path, args.rows)
        written = time.perf_counter() - started
        size = path.stat().st_size
        result = measure(path)
    result.update({"benchmark": "read_csv", "file_bytes": size, "write_seconds": written,
                   "target_peak_bytes": TARGET_BYTES, "meets_target": result["peak_bytes"] < TARGET_BYTES})
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"read_csv: {result['rows']} rows ({size / 2**20:.0f} MiB) in {result['seconds']:.1f} s, peak RSS "
          f"{result['peak_bytes'] / 2**20:.0f} MiB ({result['bytes_per_row']:.1f} B/row above baseline; target "
          f"< 1024 MiB: {'met' if result['meets_target'] else 'MISSED'}) -> {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
