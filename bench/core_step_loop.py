"""The core alone under Verilator with the whole step loop in C++: issue 10's 1 M steps/s check.

A plain C++ ``main`` (``verilator --cc --exe --build``, no ``--timing``, no trace, no per-cycle
Python or pipe round trip) resets the core like the HIL harnesses (``rst`` high for three
rising edges, ``step`` low), then holds ``step`` high and applies one input integer per chunk
of ``chunk`` model steps read from stdin, running ``chunk * ii`` clock cycles per chunk. It
records the reported states at every chunk boundary and times the loop itself with the
process CPU clock (``std::clock``: the rate on one core, whatever else the shared machine
runs) and a steady wall clock. Only a rising edge calls ``eval()``; the falling edge resets
Verilator's edge detector where the model exposes it (as :mod:`pendc.hil.plants.rtl_cpp` does), so
each clock cycle costs one evaluation of the core.

:func:`run_step_loop` checks the rows bit for bit against the golden model
(:class:`pendc.golden.GoldenModel`, an independent code path), so a fast figure is one of a
correct simulation. :data:`FLAG_SETS` names the C++ flag sets measured (side by side when several).
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from pendc.backend.memory_files import read_design, verilog_names
from pendc.hil.plants.rtl_cpp import CPP_PORT_HELPERS, cpp_int_type

REPO = Path(__file__).resolve().parents[1]
EXECUTABLE = "pendc_bench_step_loop"
# C++ flags per build: the HIL plant's (-O2 for the model rather than verilated.mk's -Os). Measured
# 2026-11-23 on the default build (ii 6, 2 M chirp steps, load ~8 on 2 cores): -O2 768 k steps per
# CPU second; -O3 -march=native for every object 544 k (and a 65 % longer C++ build), so -O2 it is
FLAG_SETS = {
    "hil_flags": "OPT_FAST=-O2 OPT_GLOBAL=-O2",
}
VERILATOR_FLAGS = ("-O3", "--x-assign", "fast", "--x-initial", "fast", "--noassert", "-Wno-fatal", "-Wno-lint")


def main_source(module: str, input_port: str, states: tuple, ports: dict, ii: int) -> str:
    """The C++ main: stdin ``chunks chunk`` then one input integer per chunk; stdout one row of
    state integers per chunk boundary (reset first), then ``TIME cpu_s wall_s``."""
    uw = ports[input_port]["width"]
    too_wide = [p for p in (input_port,) + states if ports[p]["width"] > 64]
    if too_wide:
        raise ValueError(f"ports wider than 64 bits: {too_wide}")
    value = [f"sext(core.{p}, {ports[p]['width']})" if ports[p]["signed"] else f"(long long)(uint64_t)core.{p}"
             for p in states]
    fmt = " ".join(["%lld"] * len(states))
    return f"""// pendc bench: the core's step loop in C++ (bench/core_step_loop.py)
#include "V{module}.h"
#include "V{module}___024root.h"
#include "verilated.h"
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <type_traits>
#include <utility>
#include <vector>

{CPP_PORT_HELPERS}
// the falling edge triggers nothing: reset the edge detector where the model exposes it, else eval()
template <typename M>
static inline void cycle(M& core) {{
    core.clk = 1;
    core.eval();
    core.clk = 0;
    if constexpr (HasClkPrev<std::remove_reference_t<decltype(*core.rootp)>>::value)
        core.rootp->__Vtrigprevexpr___TOP__clk__0 = 0;
    else core.eval();
}}

int main(int argc, char** argv) {{
    long long chunks = 0, chunk = 0;
    if (std::scanf("%lld %lld", &chunks, &chunk) != 2 || chunks < 1 || chunk < 1) return 2;
    std::vector<long long> u(chunks);
    for (auto& v : u) if (std::scanf("%lld", &v) != 1) return 2;
    std::vector<long long> rows((chunks + 1) * {len(states)});
    VerilatedContext ctx;
    ctx.commandArgs(argc, argv);
    V{module} core(&ctx);
    core.clk = 0; core.rst = 1; core.step = 0; core.{input_port} = 0;
    core.eval();
    for (int i = 0; i < 3; ++i) cycle(core);
    core.rst = 0;
    core.eval();
    long long* row = rows.data();
    {" ".join(f"*row++ = {v};" for v in value)}
    const std::clock_t c0 = std::clock();
    const auto t0 = std::chrono::steady_clock::now();
    core.step = 1;
    for (long long k = 0; k < chunks; ++k) {{
        core.{input_port} = ({cpp_int_type(uw)})((uint64_t)u[k] & {hex((1 << uw) - 1)}ULL);
        core.eval();
        for (long long c = chunk * {ii}LL; c > 0; --c) cycle(core);
        {" ".join(f"*row++ = {v};" for v in value)}
    }}
    const std::clock_t c1 = std::clock();
    const auto t1 = std::chrono::steady_clock::now();
    for (long long k = 0; k <= chunks; ++k) {{
        const long long* r = rows.data() + k * {len(states)};
        std::printf("{fmt}\\n", {", ".join(f"r[{i}]" for i in range(len(states)))});
    }}
    std::printf("TIME %.6f %.6f\\n", double(c1 - c0) / CLOCKS_PER_SEC,
                std::chrono::duration<double>(t1 - t0).count());
    core.final();
    return 0;
}}
"""


def build(hdl_files: dict, main_cpp: str, module: str, make_vars: str, work: Path) -> tuple[Path, float]:
    """The executable for these Verilog and .mem files and this main, built under ``work`` (reused
    when the same sources and flags were built there before; the .mem files lie beside the
    sources, where it runs); and the build's wall time."""
    from pendc.hil.plants.rtl_build import VERILATOR_MAKE_VARS, find_tool
    digest = hashlib.sha256(make_vars.encode() + main_cpp.encode())
    for name in sorted(hdl_files):
        digest.update(name.encode() + b"\0" + hdl_files[name].encode())
    folder = Path(work) / f"step_loop-{digest.hexdigest()[:16]}"
    exe = folder / "obj_dir" / EXECUTABLE
    if exe.exists():
        return exe, 0.0
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "main.cpp").write_text(main_cpp)
    sources = [folder / "main.cpp"]
    for name, text in sorted(hdl_files.items()):
        (folder / name).write_text(text)
    sources += [folder / name for name in verilog_names(hdl_files)]
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")
    cmd = [find_tool("verilator"), "--cc", "--exe", "--build", "-j", "2", "--top-module", module,
           "-Mdir", str(folder / "obj_dir"), "-o", EXECUTABLE, *VERILATOR_FLAGS,
           "-MAKEFLAGS", f"{VERILATOR_MAKE_VARS} {make_vars}", *map(str, sources)]
    t0 = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=folder, env=env)
    if r.returncode != 0 or not exe.exists():
        tail = (r.stderr or r.stdout).strip().splitlines()[-5:]
        raise RuntimeError("verilator build of the step loop failed: " + " | ".join(tail))
    return exe, time.time() - t0


def run_step_loop(hdl_dir: Path, report: dict, build_, u_ints: np.ndarray, chunk: int, work: Path,
                  flags: str = "hil_flags") -> dict:
    """Run the core in ``hdl_dir`` (built from ``build_``, report.json ``report``) through the
    C++ step loop on one input integer per ``chunk`` steps; rates per CPU and wall second,
    the real-time factor at the build's dt, and the bit-exact check against the golden model."""
    from pendc.golden import GoldenModel
    from pendc.hil.plants.core_ports import CorePorts

    core = CorePorts.of_graph(build_.graph)
    files = {name: text for name, text in read_design(hdl_dir).items() if name.startswith(core.module)}
    ii = int(report["ii"])
    main_cpp = main_source(core.module, core.input, tuple(core.states), report["ports"], ii)
    exe, build_s = build(files, main_cpp, core.module, FLAG_SETS[flags], work)
    stdin = f"{len(u_ints)} {chunk}\n" + "\n".join(str(int(v)) for v in u_ints) + "\n"
    r = subprocess.run([str(exe)], input=stdin, capture_output=True, text=True, cwd=exe.parent.parent)  # the .mem files
    if r.returncode != 0:
        raise RuntimeError(f"step loop exited with status {r.returncode}: {r.stderr.strip()[-300:]}")
    lines = r.stdout.strip().splitlines()
    cpu_s, wall_s = (float(v) for v in lines[-1].split()[1:])
    rows = np.array([[int(v) for v in ln.split()] for ln in lines[:-1]], dtype=np.int64)
    steps = len(u_ints) * chunk
    golden = GoldenModel(build_.graph, build_.options.dt)
    held = np.repeat(np.asarray(u_ints, dtype=np.int64), chunk)
    gold = golden.run_steps(np.append(held, held[-1]), every=chunk)
    grows = np.stack([np.asarray(gold.outputs[p], dtype=np.int64) for p in core.states], axis=1)[:len(rows)]
    diff = np.flatnonzero(np.any(rows != grows, axis=1))
    dt = build_.options.dt
    return {"harness": "C++ step loop (bench/core_step_loop.py): verilator --cc " + " ".join(VERILATOR_FLAGS),
            "cxx_flags": FLAG_SETS[flags], "ii": ii, "steps": steps, "clock_cycles": steps * ii,
            "build_s": round(build_s, 1), "cpu_s": round(cpu_s, 4), "wall_s": round(wall_s, 4),
            "steps_per_cpu_s": round(steps / cpu_s) if cpu_s > 0 else None,
            "steps_per_wall_s": round(steps / wall_s) if wall_s > 0 else None,
            "real_time_factor_cpu": round(steps * dt / cpu_s, 3) if cpu_s > 0 else None,
            "bit_exact_vs_golden": diff.size == 0,
            "first_golden_difference_at_step": int(diff[0]) * chunk if diff.size else None}
