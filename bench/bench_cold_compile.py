"""Benchmark: compiling a plant cold, as a new user's first `pendc build` does.

For each model (default: every shipped plant file in models/ that declares physics, and the
reference's example of docs/plant_files.md), a fresh process with an empty pendc cache
(``PENDC_CACHE_DIR`` pointing at a new folder: no derived equations, no compiled kernels, no
build) runs ``pendc plant check`` and then ``pendc build -o <tmp>``; the wall time of each is
recorded. Issue 21's target: under 3 minutes for a new plant on 2 cores.

    .venv/bin/python bench/bench_cold_compile.py [-o bench/out/cold_compile.json] [--model M.toml ...]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TARGET_SECONDS = 180.0
PENDC = [str(Path(sys.executable).parent / "pendc")]   # the console script beside this Python


def default_models(folder: Path) -> list:
    """The shipped plant files (those with physics, not the values-only ones that extend
    another) and the reference's example, written into ``folder``."""
    out = [p for p in sorted((REPO / "models").glob("*.toml"))
           if not re.search(r"^extends\s*=", p.read_text(encoding="utf-8"), re.M)]
    docs = (REPO / "docs" / "plant_files.md").read_text(encoding="utf-8")
    example = folder / "docs_example_my_cart.toml"
    example.write_text(re.search(r"```toml\n(.*?)```", docs, re.S).group(1), encoding="utf-8")
    return out + [example]


def timed(argv: list, env: dict) -> tuple:
    t0 = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, env=env)
    return time.perf_counter() - t0, done


def cold(model: Path, work: Path) -> dict:
    cache = work / f"cache_{model.stem}"
    env = {**os.environ, "PENDC_CACHE_DIR": str(cache)}
    row = {"model": str(model.relative_to(REPO) if REPO in model.parents else model.name)}
    check_s, done = timed([*PENDC, "plant", "check", str(model)], env)
    row["check_seconds"] = round(check_s, 2)
    if done.returncode != 0:
        return {**row, "error": done.stderr.strip().splitlines()[-1:]}
    build_s, done = timed([*PENDC, "build", "--model", str(model), "-o", str(work / f"hdl_{model.stem}")], env)
    row["build_seconds"] = round(build_s, 2)
    if done.returncode != 0:
        return {**row, "error": done.stderr.strip().splitlines()[-1:]}
    row["summary"] = (done.stdout + done.stderr).strip().splitlines()[-1]
    row["total_seconds"] = round(check_s + build_s, 2)
    row["met"] = row["total_seconds"] < TARGET_SECONDS
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default="bench/out/cold_compile.json", help="JSON result file")
    ap.add_argument("--model", action="append", help="model file (repeat; default: every shipped plant file)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="pendc-cold.") as tmp:
        work = Path(tmp)
        models = [Path(m).resolve() for m in args.model] if args.model else default_models(work)
        rows = []
        for model in models:
            row = cold(model, work)
            print(json.dumps(row), flush=True)
            rows.append(row)
    out = {"benchmark": "cold_compile", "target_seconds": TARGET_SECONDS, "cpus": os.cpu_count(),
           "python": platform.python_version(), "rows": rows,
           "met": all(r.get("met", False) for r in rows)}
    Path(args.output).parent.mkdir(parents=True, exist_ok=True)
    Path(args.output).write_text(json.dumps(out, indent=2) + "\n", encoding="utf-8")
    print(f"wrote {args.output}: " + ("every plant under" if out["met"] else "NOT every plant under")
          + f" {TARGET_SECONDS:g} s cold")
    return 0


if __name__ == "__main__":
    sys.exit(main())
