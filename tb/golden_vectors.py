"""Golden expectations for the cocotb modules: stimuli, the x4 decoder, every-step windows
from deposited states, long runs and the overflow scenario (computed once per run; how it is
found is :mod:`overflow_runs`). How each golden engine resumes from a deposited state is
:mod:`resumed_runs`."""

from __future__ import annotations

import time

import numpy as np

from pendc.backend.hdl import port_formats
from overflow_runs import golden_overflow
from resumed_runs import (CHECK_STEPS, compiled_window, interp_windows, port_rows, ports_of, reset_word, rtl_state,
                          state_nodes)
from tbconfig import (BUS_LEVELS, BUS_STEPS, LONG_CHUNKS, PERIOD_NS, QUICK_LONG_CHUNKS, VERSION, WINDOW,
                      WINDOW_POINTS, WINDOW_STIMULI, sampling)


# ---------------------------------------------------------------- stimuli

def window_stimuli(inp, dt: float = 1e-6) -> dict:
    """name -> (t, u, trained) on the input ``inp`` (an InputSpec) for a core stepping ``dt``:
    the training set plus two inputs it never saw, sampled at :func:`tbconfig.sampling`'s rate."""
    from pendc.sim.stimuli import Stimuli
    stimuli = Stimuli(inp)
    chunk, fs = sampling(dt)
    out = {name: (t, u, True) for name, (t, u) in stimuli.named(fs=fs).items()}
    # a multisine with another seed sampled at every model step (1 MHz at the default 1 us), so u
    # changes on every step
    t, u = stimuli.multisine(duration=2.0, seed=7, amplitude=1.5, fs=chunk * fs)
    out["multisine_seed7_1MHz"] = (t, u, False)
    t, u = stimuli.steps(duration=4.0, levels=(1.1, -0.5, 2.0, -2.2, 0.4), fs=fs)
    out["steps_other_levels"] = (t, u, False)
    if tuple(out) != WINDOW_STIMULI:
        raise RuntimeError(f"window stimuli {tuple(out)} differ from WINDOW_STIMULI {WINDOW_STIMULI}")
    return out


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


def _decoded(rows: np.ndarray, ports) -> np.ndarray:
    """x4 counts of every encoder after every row (one column per encoder)."""
    first = len(ports.states)
    cols = [decode_x4(rows[:, first + 2 * i], rows[:, first + 2 * i + 1])[0] for i in range(len(ports.encoders))]
    return np.stack(cols, axis=1) if cols else np.zeros((len(rows), 0), np.int64)


def _decode_errors(rows: np.ndarray, ports) -> int:
    first = len(ports.states)
    return sum(decode_x4(rows[:, first + 2 * i], rows[:, first + 2 * i + 1])[1] for i in range(len(ports.encoders)))


def codes_start(rows: np.ndarray, ports, mid: int, chunks: int = QUICK_LONG_CHUNKS) -> int:
    """Where the quick profile's converter test starts in a long run (``rows``: one per chunk): at
    ``mid`` when every converter's code takes two values or more in the ``chunks`` chunks from
    there (the plants this was written for: a ball on a beam), else at the chunk (from 1 on) where
    the most converters' codes change, then where the converter whose code changes least changes
    most, nearest to ``mid`` (a slow plant, a tank's level, moves a code only now and then; a
    maglev's ball lying on its post holds its gap's code for the whole run). ``mid`` when the
    plant has no converter."""
    cols = [ports.outputs.index(a.port) for a in ports.adcs]
    if not cols:
        return mid

    def values(k: int) -> list:
        return [len(np.unique(rows[k:k + chunks + 1, c])) for c in cols]

    if min(values(mid)) >= 2:
        return mid
    starts = range(1, len(rows) - chunks)
    return max(starts, key=lambda k: (sum(n >= 2 for n in values(k)), min(values(k)), -abs(k - mid)), default=mid)


def codes_static(rows: np.ndarray, ports) -> list:
    """The converters whose code takes one value only over a whole golden run (``rows``: every
    row, or one per chunk): a converter test cannot see them change."""
    return [a.name for a in ports.adcs if len(np.unique(rows[:, ports.outputs.index(a.port)])) < 2]


def encoders_start(cnt: np.ndarray, chunks: int = QUICK_LONG_CHUNKS, least: int = 2) -> int:
    """Where the quick profile's encoder test starts in a long run (``cnt``: the decoded x4 counts,
    one row per chunk, a column per encoder): at reset (0) when an encoder moves ``least`` counts
    or more in the ``chunks`` chunks from there, else at the chunk where an encoder moves most
    (the earliest of those): a slow plant (a pendubot under 1 N m) turns its encoders by a count
    or so in the first 10 ms. 0 for a plant without encoders."""
    if cnt.size == 0:
        return 0

    def moved(k: int) -> int:
        part = cnt[k:k + chunks + 1]
        return int((part.max(axis=0) - part.min(axis=0)).max())

    if moved(0) >= least:
        return 0
    return max(range(len(cnt) - chunks), key=lambda k: (moved(k), -k))


def make_vectors(build, report: dict, log=print, stimuli_names=None, window: int = WINDOW,
                 long_chunks: dict | None = None, overflow: bool = True, bus: bool = True) -> dict:
    """Every golden expectation of the core and bus tests.

    The plant's names (input, states, encoders, register names) come from the plant interface
    the build's graph carries; they travel in the vectors (``core_ports``, ``register_names``).
    ``stimuli_names`` (default: every window stimulus), ``window`` (steps per every-step window)
    and ``long_chunks`` (default :data:`LONG_CHUNKS`) shorten a run; ``overflow`` and ``bus``
    False leave the overflow scenario and the bus runs out (for tests that do not read them)."""
    from pendc.backend.hdl import schedule_of
    from pendc.backend.viewmodel import build_view
    from pendc.golden import GoldenModel
    from pendc.model.interface import require_interface

    graph = build.graph
    ports = ports_of(graph)
    iface = require_interface(graph)
    long_chunks = dict(LONG_CHUNKS if long_chunks is None else long_chunks)
    dt = build.options.dt
    chunk, fs = sampling(dt)
    golden = GoldenModel(graph, dt)
    view = build_view(graph, schedule=schedule_of(graph, (report.get("schedule") or {}).get("request")))
    state_names = [n.name for n in state_nodes(graph)]
    regs_in_rtl = {name for name, *_ in view.registers} | {f["state"] for f in view.fsms}
    missing = set(rtl_state(graph, {n: reset_word(graph, n) for n in state_names})) - regs_in_rtl
    if missing:
        raise RuntimeError(f"state registers not found in the emitted core: {sorted(missing)}")
    vec = {
        "version": VERSION, "ii": view.ii, "period_ns": PERIOD_NS, "chunk": chunk, "dt": dt,
        "ports": port_formats(graph), "report": report, "core_ports": ports,
        "register_names": iface.register_names(), "window": window,
        "ovf_wires": list(view.net.overflow), "ovf_stages": view.dp.overflow_stages(),
        "state_regs": sorted(regs_in_rtl),
        "windows": [], "long": {}, "overflow": None, "bus": {},
    }
    if vec["ii"] != report.get("ii", vec["ii"]):
        raise RuntimeError(f"report.json says ii = {report.get('ii')}, the view-model {vec['ii']}")

    # -- every-step windows: from reset and from three states deep inside each stimulus
    t0 = time.time()
    jobs, done = [], {}
    stimuli_ints = {name: golden.input_integers(t, u) for name, (t, u, _) in window_stimuli(iface.input, dt).items()
                    if stimuli_names is None or name in stimuli_names}
    # a core slower than 1 ms a step (a slow plant's) has fewer steps in a stimulus than a window
    window = min([window] + [(len(ints) - 1) // 2 for ints in stimuli_ints.values()])
    vec["window"] = window
    for name, (t, u, trained) in window_stimuli(iface.input, dt).items():
        if name not in stimuli_ints:
            continue
        ints = stimuli_ints[name]
        total = len(ints)
        starts = [0] + sorted({int(round(f * total / window)) * window for f in WINDOW_POINTS})
        starts = [k for k in starts if k + window < total]
        end = max(starts) + window + 1
        tr = golden.run_steps(ints[:end], every=window, record=tuple(state_names))
        for k0 in starts:
            row = k0 // window
            state = {n: int(tr.outputs[n][row]) for n in state_names}
            jobs.append((name, trained, k0, state, ints[k0:k0 + window].astype(np.int64),
                         np.array([tr.outputs[p][row + 1] for p in ports.outputs], dtype=np.int64),
                         any(s < k0 for s in tr.overflows.values())))
        if 0 in starts:   # from reset: the compiled kernel gives every row directly
            first = port_rows(golden.run_steps(np.append(ints[:window], ints[window - 1]), every=1), ports)
            done[(name, 0)] = (first, {})
    # windows from a state deep inside a stimulus: the compiled kernel resumed from the state, its
    # first CHECK_STEPS steps recomputed by the reference interpreter (two processes)
    from pendc.golden import GoldenStepper
    todo = [j for j in jobs if (j[0], j[2]) not in done]
    stepper = GoldenStepper(graph) if todo else None
    checks = interp_windows(graph, [(j[3], j[4][:CHECK_STEPS]) for j in todo])
    for j, (ref_rows, ref_ovf) in zip(todo, checks):
        rows, ovf = compiled_window(stepper, j[3], j[4])
        n = len(ref_rows) - 1
        early = ({k: s for k, s in ovf.items() if s < n}, {k: s for k, s in ref_ovf.items() if s < n})
        if not np.array_equal(rows[:n + 1], ref_rows) or early[0] != early[1]:
            bad = int(np.flatnonzero((rows[:n + 1] != ref_rows).any(axis=1))[0]) if early[0] == early[1] else None
            raise RuntimeError(f"golden engines disagree on {j[0]} from step {j[2]}: "
                               + (f"at window step {bad}: compiled {rows[bad].tolist()} vs interpreter "
                                  f"{ref_rows[bad].tolist()}" if bad is not None else
                                  f"overflows compiled {early[0]} vs interpreter {early[1]}"))
        done[(j[0], j[2])] = (rows, ovf)
    for name, trained, k0, state, u_win, compiled_end, ovf_before in jobs:
        rows, ovf_rel = done[(name, k0)]
        if not np.array_equal(rows[-1], compiled_end):
            raise RuntimeError(f"golden engines disagree on {name} at step {k0 + window}: resumed from step {k0} "
                               f"{rows[-1].tolist()} vs from the start {compiled_end.tolist()}")
        vec["windows"].append({
            "stim": name, "trained": trained, "k0": k0, "input": u_win, "rows": rows,
            "state": rtl_state(graph, state), "ovf_before": ovf_before,
            "ovf_first": min(ovf_rel.values()) if ovf_rel else None,
        })
    log(f"pendtb: {len(vec['windows'])} every-step windows of {window} steps ({time.time() - t0:.1f} s)")

    # -- long runs from reset, input changing every chunk steps, compared every chunk steps
    t0 = time.time()
    from pendc.sim.stimuli import Stimuli
    stimuli = Stimuli(iface.input)
    sources = {"chirp": stimuli.chirp(fs=fs), "random": stimuli.random_levels(fs=fs)}
    for name, chunks in long_chunks.items():
        t, u = sources[name]
        ints = golden.input_integers(t, u)
        chunks = min(chunks, len(ints) // chunk - 1)     # a slow core's 1 s of random levels is fewer samples
        ints = ints[:chunks * chunk]
        per_chunk = ints.reshape(chunks, chunk)
        if not np.all(per_chunk == per_chunk[:, :1]):
            raise RuntimeError(f"stimulus {name} does not hold the input for {chunk} steps")
        tr = golden.run_steps(np.append(ints, ints[-1]), every=1)
        rows = port_rows(tr, ports)
        cnt = _decoded(rows, ports)
        mid = chunks // 2          # a state deep in the run, for simulators too slow to get there
        at_mid = golden.run_steps(ints[:mid * chunk + 1], every=mid * chunk, record=tuple(state_names))
        vec["long"][name] = {
            "input": per_chunk[:, 0].copy(), "rows": rows[::chunk].copy(),
            "cnt": cnt[::chunk].copy(), "decode_errors": _decode_errors(rows, ports),
            "overflows": dict(tr.overflows), "mid": mid,
            "mid_state": rtl_state(graph, {n: int(at_mid.outputs[n][1]) for n in state_names}),
        }
        if name == "chirp":
            # the converters whose code the whole chirp leaves on one value (tb/test_core.py converters_code)
            vec["long"][name]["codes_static"] = codes_static(rows, ports)
        at = codes_start(rows[::chunk], ports, mid) if name == "chirp" else mid
        if at != mid:     # the quick profile's converter test starts there (tb/test_core.py converters_code)
            at_codes = golden.run_steps(ints[:at * chunk + 1], every=at * chunk, record=tuple(state_names))
            vec["long"][name].update(codes_at=at, codes_state=rtl_state(
                graph, {n: int(at_codes.outputs[n][1]) for n in state_names}))
        at = encoders_start(cnt[::chunk]) if name == "random" else 0
        if at:            # the quick profile's encoder test starts there (tb/test_core.py encoders_decode)
            at_enc = golden.run_steps(ints[:at * chunk + 1], every=at * chunk, record=tuple(state_names))
            vec["long"][name].update(enc_at=at, enc_state=rtl_state(
                graph, {n: int(at_enc.outputs[n][1]) for n in state_names}))
        del tr, rows
    log(f"pendtb: long runs {long_chunks} chunks ({time.time() - t0:.1f} s)")

    # -- overflow: the input's full scale held drives the plant beyond its trained range
    if overflow:
        t0 = time.time()
        vec["overflow"] = o = golden_overflow(golden, graph, iface, ports, state_names, dt, chunk, fs)
        what = ("none, the overflow tests will be skipped: " + o["unreachable"] if "unreachable" in o else
                o.get("error") or o.get("how") or ("from reset" if o["from_reset"] else "from the edge of a format"))
        log(f"pendtb: overflow scenario ({time.time() - t0:.1f} s): {what}")

    # -- bus: runs from reset with a constant U (lockstep bursts, free run)
    for name, level in (BUS_LEVELS.items() if bus else ()):
        q = int(golden.quantize_input([stimuli.on_input(level)])[0])
        tr = golden.run_steps(np.full(BUS_STEPS + 1, q, dtype=np.int64), every=1)
        rows = port_rows(tr, ports)
        vec["bus"][name] = {"input": q, "rows": rows, "cnt": _decoded(rows, ports), "overflows": dict(tr.overflows)}
    return vec
