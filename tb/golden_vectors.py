"""Golden expectations for the cocotb modules: stimuli, the x4 decoder, every-step windows
from deposited states, long runs and the overflow scenario (computed once per run)."""

from __future__ import annotations

import os
import re
import time

import numpy as np

from pendc.backend.hdl import port_formats
from tbconfig import (BUS_LEVELS, BUS_STEPS, CHUNK, LONG_CHUNKS, PERIOD_NS, PORTS, VERSION, WINDOW, WINDOW_POINTS, WINDOW_STIMULI)


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


def full_push(duration: float = 4.0):
    """Full-scale input held: the cart of a model without end stops runs off the track, past the
    range the build was trained for (the pendulum no longer overflows: theta holds 256 turns)."""
    t = np.arange(int(round(duration * 1000)) + 1) / 1000.0
    return t, np.full_like(t, 10.0)


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
    from pendc.backend.hdl import schedule_of
    from pendc.backend.viewmodel import build_view
    from pendc.golden import GoldenModel
    from pendc.sim.encoders import THETA_COUNT, X_COUNT

    graph = build.graph
    dt = build.options.dt
    golden = GoldenModel(graph, dt)
    view = build_view(graph, schedule=schedule_of(graph, (report.get("schedule") or {}).get("request")))
    state_names = [n.name for n in _state_nodes(graph)]
    regs_in_rtl = {name for name, *_ in view.registers} | {f["state"] for f in view.fsms}
    missing = set(_rtl_state(graph, {n: _reset_word(graph, n) for n in state_names})) - regs_in_rtl
    if missing:
        raise RuntimeError(f"state registers not found in the emitted core: {sorted(missing)}")
    vec = {
        "version": VERSION, "ii": view.ii, "period_ns": PERIOD_NS, "chunk": CHUNK, "dt": dt,
        "ports": port_formats(graph), "report": report, "x_count": X_COUNT, "theta_count": THETA_COUNT,
        "ovf_wires": list(view.net.overflow), "ovf_stages": view.dp.overflow_stages(),
        "state_regs": sorted(regs_in_rtl),
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

    # -- overflow: full-scale input held drives the cart beyond its trained range
    t0 = time.time()
    t, u = full_push()
    ints = golden.quantize_input(steps_of(t, u, dt))
    chunks = len(ints) // CHUNK
    tr = golden.run_steps(ints, every=CHUNK, record=tuple(state_names))
    if not tr.overflows:
        vec["overflow"] = {"error": "the golden model does not overflow on the full-scale push"}
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
