"""Benchmark of the closed HIL loop: wall seconds per simulated second for each plant, and the
socket loop's round trips per second.

Usage: .venv/bin/python bench/bench_hil.py [-o bench/out/hil.json] [--plants float,golden,verilator,icarus]
Each plant runs the builtin controller (swing-up + LQR, 1 ms period, 1 us model step) from
rest for a plant-dependent simulated time; a plant that cannot be built here (no Verilator,
no Icarus) is reported with its error instead of a figure. The socket figures use a Python
client on the loopback answering at once: against a plant that does nothing (the protocol's
own cost) and against the float plant (a real closed loop).
"""

import argparse
import json
import os
import socket
import sys
import threading
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

SIM_SECONDS = {"float": 5.0, "golden": 5.0, "verilator": 1.0, "icarus": 0.02}


def bench_plant(kind: str, model, seconds: float) -> dict:
    """Build the plant (timed apart), then run the builtin controller for ``seconds``."""
    from pendc.errors import PendcError
    from pendc.hil.controllers.controller_spec import make_controller
    from pendc.hil.loop import run_closed_loop
    from pendc.hil.plants.plant import make_plant

    t0 = time.perf_counter()
    try:
        plant = make_plant(kind, model)
        plant.reset()
        plant.step(5.0, 10)                    # load / compile the kernel or the simulator
    except (PendcError, ImportError, OSError) as exc:
        return {"available": False, "error": f"{type(exc).__name__}: {exc}"}
    setup = time.perf_counter() - t0
    controller = make_controller("builtin", model)
    run = run_closed_loop(plant, controller, seconds, plant_name=kind)
    close = getattr(plant, "close", None)
    if callable(close):
        close()
    return {"available": True, "simulated_s": seconds, "wall_s": run.wall_s, "setup_s": setup,
            "wall_s_per_simulated_s": run.wall_s / seconds, "periods_per_s": run.t.size / run.wall_s,
            "model_steps_per_s": (run.t.size - 1) * 1000 / run.wall_s, "completed": run.stopped is None,
            "upright_at_s": run.summary()["upright_at_s"]}


class IdlePlant:
    """A plant that never moves: what is left of a period is the protocol's round trip. It has
    the core's names (``ports``) of ``model``, as every plant has."""

    dt = 1e-6

    def __init__(self, model):
        from pendc.hil.plants.core_ports import CorePorts
        self.ports = CorePorts.of_interface(model.interface)

    def reset(self):
        from pendc.hil.plants.plant import PlantState
        self.state = PlantState.at_rest(self.ports)
        return self.state

    def step(self, u, n):
        return self.state


def bench_socket(plant, seconds: float) -> dict:
    """Round trips per second of serve_loop with a client that answers 5.3 V at once."""
    from pendc.hil.server import serve_loop

    ready, port = threading.Event(), []

    def announce(text):
        port.append(int(text.split("127.0.0.1:")[1].split(",")[0]))
        ready.set()

    result = {}
    server = threading.Thread(target=lambda: result.setdefault(
        "run", serve_loop(plant, ("127.0.0.1", 0), seconds, timeout=30.0, announce=announce)), daemon=True)
    server.start()
    if not ready.wait(60):
        return {"error": "the server did not start"}
    with socket.create_connection(("127.0.0.1", port[0]), timeout=30) as conn:
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        f = conn.makefile("rw")
        f.readline()                               # greeting
        for line in f:
            if not line.startswith("S "):
                break
            f.write("5.3\n")
            f.flush()
    server.join(60)
    run = result["run"]
    return {"round_trips": int(run.t.size), "wall_s": run.wall_s, "round_trips_per_s": run.t.size / run.wall_s,
            "completed": run.stopped is None}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default="bench/out/hil.json")
    ap.add_argument("--plants", default="float,golden,verilator,icarus")
    args = ap.parse_args()
    from pendc import load_model
    from pendc.hil.plants.plant import make_plant

    model = load_model()
    plants = {}
    for kind in args.plants.split(","):
        plants[kind] = bench_plant(kind, model, SIM_SECONDS.get(kind, 1.0))
        print(f"{kind}: {plants[kind]}", file=sys.stderr)
    float_plant = make_plant("float", model)
    sockets = {"idle_plant": bench_socket(IdlePlant(model), 5.0), "float_plant": bench_socket(float_plant, 5.0)}
    result = {"benchmark": "hil", "period_s": 1e-3, "model_step_s": 1e-6, "plants": plants, "socket": sockets}
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
