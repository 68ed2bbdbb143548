"""Benchmark: the shortest step any schedule of the default model can reach under the delay model,
with the default arithmetic and with the short chain (``BuildOptions.short_chain``).

``pendc.passes.step_bound`` follows the critical chain of one step (steps do not overlap, so
no schedule is shorter); next to it, what the presets' schedules estimate, and two what-ifs
that no schedule can make: the tables of periodic states read a step ahead (``lookahead``)
and every product priced as one DSP block (``one_block``). docs/hardware.md reads this to
say what blocks ``--preset fast`` from 100 ns per step. Seconds once the compile is cached.

    .venv/bin/python bench/bench_step_bound.py [-o bench/out/step_bound.json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def bounds(short_chain: bool = False) -> dict:
    """{"variants": {name: StepBound JSON}, "presets": {preset: estimated schedule}} of the default
    model built with the default arithmetic or the short chain (BuildOptions.short_chain)."""
    import pendc
    from pendc.caching.build_cache import compile_cached
    from pendc.passes.delays import ECP5_SPEED6
    from pendc.passes.pipeline import options_from_model
    from pendc.passes.schedule import PRESETS, schedule_for
    from pendc.passes.step_bound import periodic_tables, products_on, step_bound
    model = pendc.load_model()
    graph = compile_cached(model, options_from_model(model, short_chain=short_chain)).graph
    ahead = periodic_tables(graph)
    variants = {}
    for name, kw in (("as built", {}), ("lookahead", {"lookahead": ahead}), ("one_block", {"one_block": True}),
                     ("lookahead + one_block", {"lookahead": ahead, "one_block": True})):
        b = step_bound(graph, **kw)
        variants[name] = dict(b.to_json(), products_on_path=[[n, list(w)] for n, w in products_on(graph, b.path)])
    presets = {}
    for preset in PRESETS:
        s = schedule_for(graph, (18, 18), preset=preset)
        presets[preset] = {"ii": s.ii, "estimated_period_ns": s.estimated_period_ns,
                           "estimated_step_ns": s.estimated_step_ns}
    # at 100 MHz every cycle pays the flip-flop overhead: what is left of 100 ns for logic
    logic_at_100mhz = round(100.0 - 10 * ECP5_SPEED6.overhead(), 2)
    return {"model": ECP5_SPEED6.name, "lookahead_tables": list(ahead), "variants": variants, "presets": presets,
            "logic_ns_in_100ns_at_100mhz": logic_at_100mhz}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default=str(REPO / "bench" / "out" / "step_bound.json"))
    args = ap.parse_args(argv)
    from pendc.atomic import write_atomic
    out = {"default arithmetic": bounds(), "short chain": bounds(short_chain=True)}
    Path(args.output).parent.mkdir(parents=True, exist_ok=True)
    write_atomic(args.output, json.dumps(out, indent=2) + "\n")
    for build, result in out.items():
        print(build)
        for name, v in result["variants"].items():
            print(f"  {name:24s} {v['bound_ns']:7.1f} ns  ends at {v['path'][-1][0]}")
        for preset, p in result["presets"].items():
            print(f"  preset {preset:8s} ii {p['ii']:3d}  {p['estimated_period_ns']:7.2f} ns x ii = "
                  f"{p['estimated_step_ns']:7.1f} ns")
    return 0


if __name__ == "__main__":
    sys.exit(main())
