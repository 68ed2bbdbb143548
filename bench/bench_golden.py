"""Benchmark of the bit-accurate golden model: compiled kernel vs reference interpreter.

Usage: .venv/bin/python bench/bench_golden.py [-o bench/out/golden.json]
Writes steps per second of the numba kernel (fixed, its shared form and the float twin) on the default
model's 20 s chirp and 5 s swing-up, and of the Python interpreter on 10 000 steps.
Target (issue 3): >= 1 M steps/s for the fast path on one core.
"""

import argparse
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

TARGET = 1e6


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default="bench/out/golden.json")
    args = ap.parse_args()
    from pendc import load_model
    from pendc.caching.build_cache import compile_cached
    from pendc.golden import GoldenModel
    from pendc.ir.nodes import Kind
    from pendc.ir.qformat import QFormat
    from pendc.ir.compiled import CompiledGraph
    from pendc.ir.interpret import FixedInterpreter
    from pendc.passes.ranges import per_step
    from pendc.sim.stimuli import Stimuli

    t0 = time.perf_counter()
    model = load_model()
    build = compile_cached(model)
    build_seconds = time.perf_counter() - t0
    golden = GoldenModel(build.graph, build.options.dt)
    golden.run_steps(golden.quantize_input([5.0] * 10))          # compile / load the kernel
    floaty = CompiledGraph(build.graph, "float")
    floaty.run({"u": [5.0] * 10})
    # the form the error budget's later rounds share (pendc.ir.shared_source): here the registers
    # and their readers read their numbers from data, as after widening the state accumulators
    finer = build.graph.map_nodes(lambda n: replace(n, qformat=QFormat(n.qformat.signed, n.qformat.width,
                                                                          n.qformat.frac + 1))
                                  if n.kind is Kind.REGISTER else n)
    shared, baked = CompiledGraph(build.graph, "fixed", like=finer), CompiledGraph(build.graph, "fixed")
    shared.run({"u": [5.0] * 10})
    baked.run({"u": [5.0] * 10})
    runs = {}
    on = Stimuli(model.interface.input)
    for name, (t, u) in {"chirp_20s": on.chirp(), "swing_up_5s": on.swing_up()}.items():
        steps = per_step(u, t, build.options.dt)
        ints = golden.quantize_input(steps)
        t0 = time.perf_counter()
        golden.run_steps(ints, every=1000)
        fixed_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        floaty.run({"u": steps}, every=1000)
        float_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        shared.run({"u": ints}, every=1000)
        shared_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        baked.run({"u": ints}, every=1000)      # the same harness as the shared form's
        baked_s = time.perf_counter() - t0
        runs[name] = {"steps": len(steps), "fixed_seconds": fixed_s, "fixed_steps_per_second": len(steps) / fixed_s,
                      "float_seconds": float_s, "float_steps_per_second": len(steps) / float_s,
                      "shared_fixed_steps_per_second": len(steps) / shared_s,
                      "compiled_fixed_steps_per_second": len(steps) / baked_s}
    t_sw, u_sw = on.swing_up()
    ints = golden.quantize_input(per_step(u_sw, t_sw, build.options.dt)[:10_000])
    interp = FixedInterpreter(build.graph)
    t0 = time.perf_counter()
    interp.run({"u": [int(v) for v in ints]})
    interp_rate = 10_000 / (time.perf_counter() - t0)
    slowest = min(r["fixed_steps_per_second"] for r in runs.values())
    result = {"benchmark": "golden", "model": build.model.source, "nodes": len(build.graph.nodes),
              "runs": runs, "interpreter_steps_per_second": interp_rate, "build_seconds": build_seconds,
              "target_steps_per_second": TARGET, "meets_target": slowest >= TARGET}
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"golden: {slowest / 1e6:.1f} M steps/s fixed (target {TARGET / 1e6:.0f} M: "
          f"{'met' if result['meets_target'] else 'MISSED'}), interpreter {interp_rate:.0f} steps/s -> {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
