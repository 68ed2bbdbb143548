"""Benchmark: the float simulator on the issue's chirp.

Simulates the default model (thesis Table 14) on the 20 s chirp
(``Stimuli(input).chirp()``: level 1 about the input's neutral, 0.3 -> 2 Hz, 1 kHz samples)
with the default integrator, forward Euler at 1 us (2e7 steps), on one thread.
Equation derivation, kernel compilation (a warm-up call on a few samples) and the
timed run are reported separately; RK4 at the same step is timed as well.

    .venv/bin/python bench/bench_simulate.py [-o bench/out/simulate.json] [--repeat N] [--warm-cache]

By default the kernel is compiled into a fresh temporary cache directory so that
``compile_seconds`` is a real compile time; ``--warm-cache`` uses pendc's normal
kernel cache instead (what a user sees on the second run).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

os.environ["NUMBA_NUM_THREADS"] = "1"  # before numba is imported (via pendc)

TARGET_SECONDS = 10.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default="bench/out/simulate.json", help="JSON result file")
    ap.add_argument("--model", default=None, help="model file (default: models/sct_thesis_final.toml)")
    ap.add_argument("--repeat", type=int, default=1, help="timed runs per method; the fastest counts")
    ap.add_argument("--warm-cache", action="store_true", help="use pendc's kernel cache instead of a fresh one")
    ap.add_argument("--no-rk4", action="store_true", help="skip the RK4 timing")
    args = ap.parse_args(argv)

    tmp = None
    if not args.warm_cache:
        tmp = tempfile.TemporaryDirectory(prefix="pendc-bench-kernels-")
        os.environ["PENDC_CACHE_DIR"] = tmp.name

    import numba
    import numpy as np

    from pendc.model.modelfile import default_model_path, load_model
    from pendc.sim.stimuli import REFERENCE_SPAN, Stimuli
    from pendc.sim.simulator import Simulator

    dt = 1e-6
    t0 = time.perf_counter()
    model = load_model(args.model)
    model.equations  # sympy derivation + effect assembly
    derive_seconds = time.perf_counter() - t0

    inp = model.interface.input
    t, u = Stimuli(inp).chirp()
    steps = int(np.sum(np.maximum(1, np.ceil(np.diff(t) / dt - 1e-6))))

    def timed(method):
        t0 = time.perf_counter()
        sim = Simulator(model, dt=dt, method=method)
        sim(t[:5], u[:5])  # warm-up: import/compile the kernel
        compile_s = time.perf_counter() - t0
        best = float("inf")
        for _ in range(max(1, args.repeat)):
            t0 = time.perf_counter()
            res = sim(t, u)
            best = min(best, time.perf_counter() - t0)
        return compile_s, best, res

    compile_seconds, seconds, res = timed("euler")
    rk4_seconds = None
    if not args.no_rk4:
        _, rk4_seconds, _ = timed("rk4")  # same kernel: rk4 is a run-time switch

    name = Path(args.model).stem if args.model else default_model_path().stem
    out = {
        "benchmark": "simulate",
        "model": name,
        "stimulus": f"chirp 20 s, {inp.neutral:g} {inp.unit} +- {(inp.hi - inp.lo) / REFERENCE_SPAN:g} {inp.unit}, "
                    "0.3->2 Hz, 1 kHz",
        "method": "euler",
        "dt": dt,
        "steps": steps,
        "seconds": round(seconds, 4),
        "steps_per_second": round(steps / seconds),
        "ns_per_step": round(seconds / steps * 1e9, 2),
        "compile_seconds": round(compile_seconds, 4),
        "derive_seconds": round(derive_seconds, 4),
        "kernel_cache": "warm" if args.warm_cache else "cold",
        "target_seconds": TARGET_SECONDS,
        "meets_target": bool(seconds <= TARGET_SECONDS),
        "rk4_seconds": None if rk4_seconds is None else round(rk4_seconds, 4),
        "threads": numba.config.NUMBA_NUM_THREADS,
        "repeat": max(1, args.repeat),
        "final_x": float(res["x"][-1]),
        "final_theta": float(res["theta"][-1]),
        "python": platform.python_version(),
        "numba": numba.__version__,
        "machine": platform.machine(),
    }
    path = Path(args.output)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=2) + "\n")
    if tmp is not None:
        tmp.cleanup()

    rk4 = "" if rk4_seconds is None else f", rk4 {rk4_seconds:.2f} s"
    print(f"simulate {name}: {steps} Euler steps in {seconds:.2f} s ({steps / seconds / 1e6:.1f} M steps/s, "
          f"target {TARGET_SECONDS:.0f} s: {'met' if out['meets_target'] else 'MISSED'}), "
          f"compile {compile_seconds:.2f} s ({out['kernel_cache']} cache), derive {derive_seconds:.2f} s{rk4} -> {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
