"""Benchmark: synthesis of the default model's core per schedule preset, against the thesis.

For each preset (``fast``, ``default`` and ``small``; ``comb`` and ``fmax`` on request) the default model's
HDL is emitted into a temporary folder and ``pendc report synth`` (Yosys ``synth_ecp5`` +
nextpnr-ecp5, LFE5U-85F speed 6, out of context) runs on it. Results are cached by
design hash, so a second run costs nothing, and a preset whose design hash equals an earlier
preset's is not synthesised again. A cold run of the default preset (ii 6) measured
2026-11-23: Yosys 53 s CPU (340 s wall at load ~8 on 2 cores), nextpnr 111 s CPU (627 s wall);
``synth_ecp5 -noabc9`` gave the same netlist in the same CPU time, and nextpnr ``--router
router2`` saved 9 % CPU but routed 7 % slower (33.4 vs 35.9 MHz), so the flow keeps its
defaults. ``tool_cpu_s`` in the JSON is what this run cost the tools. Ratios: ours / thesis (spec §5: 24 MULT18,
12.9 MHz, 77.5 ns per step, 431 logic levels on a Virtex-II Pro), and the scheduler's
estimated period / step against the routed ones (its delay model, pendc.passes.delays).

    .venv/bin/python bench/bench_synth.py [-o bench/out/synth.json] [--presets fast,small]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tb"))
FREQ_MHZ = 100.0                                # nextpnr's clock goal (pendc report synth's default)


def synth_presets(presets, target: str = "ecp5-85k", log=print, jobs: int = 2) -> dict:
    """{preset: report synth JSON + ratios against the thesis}. Each preset's HDL comes from its own
    build (the step-time presets build the short-chain arithmetic); ``jobs`` designs are placed and
    routed at a time (the tools are single-threaded processes)."""
    import pendtb
    from pendc.codegen import cache_dir
    from pendc.synth import design_files, design_hash
    out, first_of, todo = {}, {}, []
    with tempfile.TemporaryDirectory(prefix="pendc-bench-synth-") as tmp:
        for preset in presets:
            t0 = time.time()
            request = {"preset": preset, "target": target}
            model, build = pendtb.model_and_build(request=request)
            hdl = Path(tmp) / preset
            pendtb.emit_hdl(model, build, hdl, "raptor", request)
            report, files = design_files(hdl)
            key = design_hash(files, target, report["top"], FREQ_MHZ)
            if key in first_of:                 # the same design as an earlier preset: one run serves both
                log(f"  {preset}: the same design as --preset {first_of[key]} (hash {key}), not synthesised again")
            else:
                first_of[key] = preset
                todo.append((preset, hdl, (cache_dir("synth") / f"synth_{key}.json").is_file(), time.time() - t0))
            out[preset] = key
        with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
            done = dict(zip([p for p, *_ in todo], pool.map(lambda item: _synth_one(*item, target, log), todo)))
    return {preset: done[preset] if first_of[key] == preset else
            dict(done[first_of[key]], preset=preset, same_design_as=first_of[key], cached=True)
            for preset, key in out.items()}


def _synth_one(preset: str, hdl: Path, cached: bool, prep_s: float, target: str, log) -> dict:
    """``pendc report synth`` of one preset's HDL, with its ratios against the thesis."""
    from pendc.synth import THESIS, synthesize
    t0 = time.time()
    r = synthesize(hdl, target, FREQ_MHZ, log=lambda text: log(f"  {preset}: {text}")).to_json()
    r["cached"] = cached                # seconds: the tool times of the run that filled the cache
    r["wall_s"] = round(prep_s + time.time() - t0, 1)
    r["preset"] = preset
    r["ratio_vs_thesis"] = {
        "dsp": round(r["dsp"] / THESIS["dsp"], 3),
        "step_time": round(r["step_ns"] / THESIS["step_ns"], 3) if r["step_ns"] else None,
        "fmax": round(r["fmax_mhz"] / THESIS["fmax_mhz"], 3) if r["fmax_mhz"] else None,
        "logic_depth": round(r["logic_depth"] / THESIS["logic_depth"], 3),
    }
    est = r.get("estimate", {})
    if r["fmax_mhz"] and est.get("estimated_period_ns"):
        r["model_vs_routed"] = {"period": round(est["estimated_period_ns"] * r["fmax_mhz"] / 1e3, 3),
                                "step": round(est["estimated_step_ns"] / r["step_ns"], 3)}
    if est.get("lut4_scheduled"):
        r["estimate_vs_synthesis"] = {"lut": round(est["lut4_scheduled"] / r["lut"], 3),
                                      "dsp": round(est.get("dsp_scheduled", est.get("dsp", 0)) / max(r["dsp"], 1), 3)}
    log(f"  {preset}: {r['dsp']} DSP, {r['lut']} LUT4, {r['ff']} FF, {r['bram']} BRAM, "
        f"Fmax {r['fmax_mhz']} MHz, ii {r['ii']}, step {r['step_ns']} ns ({r['wall_s']} s)")
    return r


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default="bench/out/synth.json")
    ap.add_argument("--presets", default="fast,default,small", help="comma-separated (comb and fmax too)")
    ap.add_argument("--target", default="ecp5-85k")
    ap.add_argument("--jobs", type=int, default=2, help="designs synthesised at a time (default 2: CI's cores)")
    args = ap.parse_args(argv)
    presets = synth_presets(args.presets.split(","), args.target, jobs=args.jobs)
    fresh = [r for r in presets.values() if not r.get("cached")]
    result = {"target": args.target, "presets": presets,
              # what this run cost the tools (cache hits cost nothing): CPU is what a quiet 2-core CI sees
              "tool_wall_s": round(sum(v for r in fresh for k, v in r["seconds"].items()
                                       if not k.endswith("_cpu")), 1),
              "tool_cpu_s": round(sum(v for r in fresh for k, v in r["seconds"].items() if k.endswith("_cpu")), 1)}
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"bench_synth: wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
