"""The core under ``verilator --binary --timing`` without cocotb: the HIL plants' lockstep harness.

One harness serves every standalone simulation of the core: :mod:`pendc.hil.plants.rtl_harness`
(``step`` held high, one request line per input change, one answer line per request). Here
the input changes every CHUNK steps and each answer (the reported states, the encoder lines
and the overflow flag) is one row, so a run is one process and a few pipe round trips per
second of model time. The executable is built once per design and cached with the HIL
plants'. Used by bench/bench_verilator.py (throughput, accuracy against the float simulator)
and tests/test_sim.py (the acceptance bound on the chirp). Every name comes from the plant
interface of the model the HDL was built from.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from pendtb import CHUNK, core_ports_of, model_and_build, use_venv_tools
from tbconfig import sampling


def build(hdl_dir: Path, report: dict, core_ports, log=print) -> tuple[Path, float]:
    """The harness executable for the core in ``hdl_dir`` (cached per design) and the build time."""
    from pendc.backend.memory_files import read_design
    from pendc.hil.plants.rtl_harness import build_harness
    use_venv_tools()
    files = read_design(hdl_dir)      # the Verilog and the tables' .mem files
    t0 = time.time()
    binary = build_harness(files, core_ports, report["ports"], report["ii"], "verilator")
    return binary, time.time() - t0


def run(binary: Path, core_ports, u_chunks: np.ndarray, chunk: int = CHUNK) -> tuple[np.ndarray, float]:
    """Run the harness from reset with one input integer per chunk of ``chunk`` steps; rows
    (len(u_chunks)+1, outputs+1): the states, the encoder lines and the overflow flag at every
    chunk boundary; and the wall time."""
    from pendc.hil.plants.rtl_harness import HarnessLink
    link = HarnessLink(binary, "verilator", core_ports)
    try:
        t0 = time.perf_counter()
        answers = [link.answer()] + [link.request(f"0 {int(u)} {chunk}") for u in u_chunks]
        wall = time.perf_counter() - t0
    finally:
        link.close()
    rows = np.array([a.states + a.levels + (int(a.overflow),) for a in answers], dtype=np.int64)
    return rows, wall


def chirp_run(hdl_dir: Path, report: dict, work: Path, seconds: float = 2.0, log=print, model_path=None,
              build_=None) -> dict:
    """The chirp (``Stimuli(input).chirp()``) for ``seconds`` through the harness, against the
    golden model (bit-exact at every 1000th step) and the float simulator (per state an encoder
    reads: ``max_abs_<state>_error_<unit>`` and the time ``at_t_<state>_s`` of the worst error).
    The rows the harness answered are kept in ``work``/chirp_rows.txt for inspection."""
    from pendc import Simulator
    from pendc.golden import GoldenModel
    from pendc.sim.stimuli import Stimuli

    # the build the HDL came from (a preset's arithmetic differs from the default build's)
    model, build_ = (build_.model, build_) if build_ is not None else model_and_build(model_path)
    ports = core_ports_of(build_)
    dt = build_.options.dt
    chunk, fs = sampling(dt)
    t, u = Stimuli(model.interface.input).chirp(fs=fs)
    n = int(round(seconds * fs))
    t, u = t[:n + 1], u[:n + 1]
    golden = GoldenModel(build_.graph, dt)
    ints = golden.input_integers(t, u)
    u_chunks = ints.reshape(n, chunk)[:, 0]
    binary, build_s = build(hdl_dir, report, ports, log=log)
    rows, wall = run(binary, ports, u_chunks, chunk)
    Path(work).mkdir(parents=True, exist_ok=True)
    np.savetxt(Path(work) / "chirp_rows.txt", rows, fmt="%d", header=" ".join([*ports.outputs, "overflow"]))
    outputs = ports.outputs
    # golden (bit-exact) at the same boundaries
    gold = golden.run_steps(np.append(ints, ints[-1]), every=chunk)
    grows = np.stack([np.asarray(gold.outputs[p], dtype=np.int64) for p in outputs], axis=1)
    diff = np.flatnonzero(np.any(rows[:, :len(outputs)] != grows[:n + 1], axis=1))
    first_diff = None
    if diff.size:
        k = int(diff[0])
        first_diff = {"step": k * chunk, "ports": {p: [int(rows[k, i]), int(grows[k, i])]
                                                   for i, p in enumerate(outputs) if rows[k, i] != grows[k, i]}}
    # float simulator at the stimulus' sample times
    t_f = time.perf_counter()
    ref = Simulator(model, dt=dt)(t, u)
    float_s = time.perf_counter() - t_f
    iface = model.interface
    accuracy = {}
    for e in ports.encoders:
        col = ports.states.index(e.state)
        err = np.abs(rows[:, col] * 2.0 ** -report["ports"][e.state]["frac"] - ref[e.state])
        unit = iface.state(e.state).unit.replace("/", "_per_")
        accuracy[f"max_abs_{e.state}_error_{unit}"] = float(err.max())
        accuracy[f"at_t_{e.state}_s"] = float(t[int(np.argmax(err))])
    steps = n * chunk
    return {
        "stimulus": f"Stimuli(input).chirp() first {seconds:g} s ({fs:g} Hz samples held {chunk} steps of {dt:g} s)",
        "core": ports.module, "steps": steps, "simulated_s": steps * dt, "clock_cycles": steps * report["ii"],
        "build_s": round(build_s, 2), "wall_s": round(wall, 4),
        "steps_per_s": steps / wall, "cycles_per_s": steps * report["ii"] / wall, "real_time_factor": steps * dt / wall,
        **accuracy,
        "bit_exact_vs_golden_every_1000": first_diff is None, "first_golden_difference": first_diff,
        "overflow": bool(rows[-1, len(outputs)]), "float_simulator_s": round(float_s, 2),
    }
