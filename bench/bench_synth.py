"""Benchmark: synthesis of the default model's core per schedule preset and FPGA target, against the thesis.

For each preset (``thesis``, ``fast``, ``default`` and ``small``; ``comb`` and ``fmax`` on request) the default
model's HDL is emitted into a temporary folder (what ``pendc build --preset P`` writes: the same
Verilog for every target) and ``pendc report synth`` runs on it for each target (``--targets``;
default ``ecp5-85k``: Yosys ``synth_ecp5`` + nextpnr-ecp5, LFE5U-85F speed 6, out of context;
``--targets all`` every target with an open place-and-route). Results are cached by design
hash, so a second run costs nothing, and a preset whose design hash equals an earlier preset's
is not synthesised again. A cold run of the default preset (ii 6) on ECP5-85k measured
2026-11-23: Yosys 53 s CPU (340 s wall at load ~8 on 2 cores), nextpnr 111 s CPU (627 s wall);
``synth_ecp5 -noabc9`` gave the same netlist in the same CPU time, and nextpnr ``--router
router2`` saved 9 % CPU but routed 7 % slower (33.4 vs 35.9 MHz), so the flow keeps its
defaults. ``tool_cpu_s`` in the JSON is what this run cost the tools. Ratios: ours / thesis (spec §5: 24 MULT18,
12.9 MHz, 77.5 ns per step, 431 logic levels on a Virtex-II Pro), and the scheduler's
estimated period / step against the routed ones (its delay model, pendc.passes.delays).
``rows`` has one line per target and preset (fits or the resource that does not, Fmax, ii,
step, real time at the model's dt) and ``smallest_real_time`` the part with the fewest logic
cells on which each preset fits and routes to a step within dt.

    .venv/bin/python bench/bench_synth.py [-o bench/out/synth.json] [--presets fast,small]
        [--targets ecp5-85k,gw2a-18,ice40-up5k:default|all] [--jobs 1]
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
    """{preset: report synth JSON + ratios against the thesis} on one target (see synth_targets)."""
    return synth_targets(presets, [target], log, jobs)[target]


def synth_targets(presets, targets, log=print, jobs: int = 2, only: dict | None = None) -> dict:
    """{target: {preset: report synth JSON + ratios against the thesis}}. Each preset's HDL comes from
    its own build (the step-time presets build the short-chain arithmetic), once for every target;
    ``jobs`` syntheses run at a time (the tools are single-threaded processes), presets in the order
    given, each preset on every target before the next preset; ``only``: {target: the presets it
    runs} for a target not worth every preset (a part that the tables alone overflow)."""
    import pendtb
    from pendc.codegen import cache_dir
    from pendc.synth.flow import design_files, design_hash
    keys, first_of, todo = {}, {}, []
    with tempfile.TemporaryDirectory(prefix="pendc-bench-synth-") as tmp:
        for preset in presets:
            t0 = time.time()
            request = {"preset": preset}
            model, build = pendtb.model_and_build(request=request)
            hdl = Path(tmp) / preset
            pendtb.emit_hdl(model, build, hdl, "raptor", request)
            report, files = design_files(hdl)
            prep = time.time() - t0
            for target in targets:
                if preset not in (only or {}).get(target, [preset]):
                    continue
                key = design_hash(files, target, report["top"], FREQ_MHZ)
                if key in first_of:             # the same design as an earlier preset: one run serves both
                    log(f"  {target} {preset}: the same design as --preset {first_of[key][1]} (hash {key})")
                else:
                    first_of[key] = (target, preset)
                    todo.append((preset, hdl, (cache_dir("synth") / f"synth_{key}.json").is_file(), prep, target))
                keys[target, preset] = key
        with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
            done = dict(zip([(t, p) for p, _, _, _, t in todo],
                            pool.map(lambda item: _synth_one(*item, log), todo)))
    out: dict = {t: {} for t in targets}
    for (target, preset), key in keys.items():
        first = first_of[key]
        out[target][preset] = done[first] if first == (target, preset) else \
            dict(done[first], preset=preset, same_design_as=first[1], cached=True)
    return out


def _synth_one(preset: str, hdl: Path, cached: bool, prep_s: float, target: str, log) -> dict:
    """``pendc report synth`` of one preset's HDL on one target, with its ratios against the thesis."""
    from pendc.synth.flow import THESIS, synthesize
    t0 = time.time()
    r = synthesize(hdl, target, FREQ_MHZ, log=lambda text: log(f"  {target} {preset}: {text}")).to_json()
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
    if est.get("lut4_scheduled") and r["lut"]:
        r["estimate_vs_synthesis"] = {"lut": round(est["lut4_scheduled"] / r["lut"], 3),
                                      "dsp": round(est.get("dsp_scheduled", est.get("dsp", 0)) / max(r["dsp"], 1), 3)}
    log(f"  {target} {preset}: {'fits' if r['fits'] is not False else 'does not fit'}, {r['dsp']} DSP, "
        f"{r['lut']} LUT, {r['ff']} FF, {r['bram']} BRAM, Fmax {r['fmax_mhz']} MHz, ii {r['ii']}, "
        f"step {r['step_ns']} ns ({r['wall_s']} s)")
    return r


def rows(results: dict) -> list:
    """One summary line per target and preset: what the README's and docs' tables show."""
    out = []
    for target, presets in results.items():
        for preset, r in presets.items():
            out.append({"target": target, "preset": preset, "fits": r["fits"], "misfit": r["misfit"],
                        "lut": r["lut"], "carry": r["carry"], "ff": r["ff"], "dsp": r["dsp"], "bram": r["bram"],
                        "fmax_mhz": r["fmax_mhz"], "fmax_bound": r["fmax_bound"], "ii": r["ii"],
                        "step_ns": r["step_ns"], "dt_ns": r["dt_ns"], "real_time": r["real_time"]})
    return out


def smallest_real_time(results: dict) -> dict:
    """{preset: the target with the fewest logic cells (its capacity's first entry) on which that
    preset fits and a routed step is within dt}; None where no target does."""
    from pendc.synth.flow import TARGETS

    def size(target):
        return next(iter(TARGETS[target].capacity.values()))[0] if TARGETS[target].capacity else float("inf")
    presets = {p for ps in results.values() for p in ps}
    return {p: min((t for t, ps in results.items() if p in ps and ps[p]["real_time"]), key=size, default=None)
            for p in sorted(presets)}


def main(argv=None) -> int:
    from pendc.synth.flow import TARGETS
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default="bench/out/synth.json")
    ap.add_argument("--presets", default="thesis,fast,default,small", help="comma-separated (comb and fmax too)")
    ap.add_argument("--target", help="one target (the same as --targets NAME)")
    ap.add_argument("--targets", default="ecp5-85k", help="comma-separated targets (TARGET:P1+P2 runs only those "
                    "presets on it), or 'all': every target with an open place-and-route "
                    f"({', '.join(t for t in TARGETS if TARGETS[t].pnr)})")
    ap.add_argument("--jobs", type=int, default=2, help="designs synthesised at a time (default 2: CI's cores)")
    args = ap.parse_args(argv)
    targets = ([args.target] if args.target else
               [t for t in TARGETS if TARGETS[t].pnr] if args.targets == "all" else args.targets.split(","))
    unknown = [t for t in targets if t.split(":")[0] not in TARGETS]
    if unknown:
        ap.error(f"unknown target '{unknown[0]}' (known: {', '.join(TARGETS)})")
    only = {t.split(":")[0]: t.split(":")[1].split("+") for t in targets if ":" in t}
    targets = [t.split(":")[0] for t in targets]
    results = synth_targets(args.presets.split(","), targets, jobs=args.jobs, only=only)
    fresh = [r for ps in results.values() for r in ps.values() if not r.get("cached")]
    result = {"target": targets[0], "presets": results[targets[0]],      # the first target, as before
              "targets": results, "rows": rows(results), "smallest_real_time": smallest_real_time(results),
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
