"""The testbench's overflow scenario (computed once per run with the golden vectors): the input's
full scale held from reset until a node overflows, or, for a plant whose full push stays in range,
a run deposited near the edge of a reported state's range that drifts out in the bus test's second
burst. Both golden engines (interpreter and compiled kernel) must agree on the first overflow."""

from __future__ import annotations

import numpy as np

from pendc.model.interface import with_unit
from resumed_runs import interp_window, port_rows, reset_integer, rtl_state


def full_push(full_scale: float, duration: float = 4.0, fs: float = 1000.0):
    """The input's full scale held (the plant interface's ``full_scale``), sampled at ``fs``: a
    plant without end stops runs past the range the build was trained for (the cart-pendulum's
    cart runs off the track; its periodic angle holds 256 turns and does not overflow)."""
    t = np.arange(int(round(duration * fs)) + 1) / fs
    return t, np.full_like(t, float(full_scale))


def golden_overflow(golden, graph, iface, ports, state_names, dt: float, chunk: int, fs: float) -> dict:
    """The full push from reset to the first overflow (both golden engines agreeing on its step
    and nodes), or, for a plant whose full push stays in range, the run from a format's edge.
    ``chunk``, ``fs``: the testbench's steps per stimulus sample and their rate
    (:func:`tbconfig.sampling`)."""
    t, u = full_push(iface.input.full_scale, fs=fs)
    ints = golden.input_integers(t, u)
    chunks = len(ints) // chunk
    tr = golden.run_steps(ints, every=chunk, record=tuple(state_names))
    if not tr.overflows:
        # a plant whose full push stays in range (its rates saturate, its angles wrap, it is slow):
        # start at the edge of a reported state's range instead, moving out
        return _overflow_from_edge(golden, graph, iface, ports, state_names, int(ints[0]), dt)
    k_star = min(tr.overflows.values())
    nodes = sorted(n for n, s in tr.overflows.items() if s == k_star)
    k0 = max(0, (k_star // chunk - 1) * chunk)
    n_win = k_star - k0 + 500
    state = {n: int(tr.outputs[n][k0 // chunk]) for n in state_names}
    u_win = ints[k0:k0 + n_win]
    rows, ovf_rel = interp_window(graph, state, u_win)
    first_rel = min(ovf_rel.values()) if ovf_rel else None
    rel_nodes = sorted(n for n, s in ovf_rel.items() if s == first_rel)
    if first_rel != k_star - k0 or rel_nodes != nodes:
        raise RuntimeError(f"golden engines disagree on the first overflow: compiled step {k_star} {nodes}, "
                           f"interpreter step {None if first_rel is None else k0 + first_rel} {rel_nodes}")
    return {
        "input": ints[:chunks * chunk].reshape(chunks, chunk)[:, 0].copy(),
        "coarse": port_rows(tr, ports)[: k0 // chunk + 1].copy(),
        "k_star": k_star, "nodes": nodes, "all": dict(tr.overflows), "from_reset": True,
        "k0": k0, "state": rtl_state(graph, state), "u_win": u_win.astype(np.int64), "rows": rows,
    }


EDGE_STEPS = 1500      # steps from the deposited edge state to the overflow (the bus test's second burst)
EDGE_RUN = EDGE_STEPS + 1000        # steps of the scenario's window from the deposited state
EDGE_HALVINGS = 8      # a position's rate starts at half its format's maximum, halved up to this many times
DRIFT_SLACK = 300      # a drift scenario's first overflow lies in EDGE_STEPS - DRIFT_SLACK .. EDGE_STEPS


def _overflow_from_edge(golden, graph, iface, ports, state_names, q_full: int, dt: float) -> dict:
    """The overflow scenario from a deposited state: a reported position that has a rate, its rate
    set to a constant-ish speed out of its range, the input at full scale, the other states at
    reset. The rate starts at half its format's maximum and halves (up to :data:`EDGE_HALVINGS`
    times) while no start works, above all while something overflows within EDGE_STEPS steps with
    the position at its reset value (the rate's own products: a pendubot's dq1^2 is sized for the
    trained rates, not for the format, and overflows at once at half the format);
    the position's start is then found by bisection (:func:`drift_start`, the compiled kernel) so
    that the first overflow lands EDGE_STEPS - DRIFT_SLACK .. EDGE_STEPS steps in, the bus test's
    second burst (the top of the position's range first, then its bottom moving down; the range
    is its register's format or the domain of a table it addresses, :func:`_edge_of`, and a
    periodic position's whole-turn counter, overflowing before the register's top, is found by
    the same bisection). Interpreter and compiled kernel must agree on the first overflow (step
    and nodes). A plant with no such position (states in state-equation form: levels,
    temperatures, currents), or none that leaves its range so, gets the drift scenario
    (:func:`_overflow_from_drift`)."""
    from pendc.golden import GoldenStepper, register_integers

    rate_of = {s.derivative_of: s.name for s in iface.states if s.derivative_of}
    positions = [p for p in ports.states if p in rate_of]
    if not positions:
        return _overflow_from_drift(golden, graph, iface, ports, state_names, q_full,
                                    "no reported state has a rate state")
    stepper = GoldenStepper(graph)
    tried = []
    for pos in positions:
        rate = rate_of[pos]
        vmax = graph[rate].qformat.max_value
        for side, edge, sign in (("top", _edge_of(graph, pos), 1.0), ("bottom", _bottom_of(graph, pos), -1.0)):
            why = None
            for halving in range(1, EDGE_HALVINGS + 1):
                v0 = sign * vmax / 2.0 ** halving
                value, found = drift_start(stepper, graph, pos, edge, q_full, extra={rate: v0})
                if value is not None:
                    break
                why = f"{rate} = {v0:g}: {found}"
            else:
                tried.append(f"{pos} toward the {side} of its range ({edge:g}), {rate} from {sign * vmax / 2:g} "
                             f"halved {EDGE_HALVINGS} times (last: {why})")
                continue
            start_real = {pos: value, rate: v0}
            start = {n: reset_integer(graph, n) for n in state_names}
            start.update(register_integers(graph, start_real))
            u_win = np.full(EDGE_RUN, q_full, dtype=np.int64)
            rows, ovf = interp_window(graph, start, u_win)
            k_star = min(ovf.values()) if ovf else None
            nodes = sorted(n for n, s in ovf.items() if s == k_star)
            stepper.reset(start_real)
            stepper.advance(q_full, len(u_win), every_step=False)
            first = min(stepper.overflows.values()) if stepper.overflows else None
            compiled_nodes = sorted(n for n, s in stepper.overflows.items() if s == first)
            if (first, compiled_nodes) != (k_star, nodes):
                raise RuntimeError(f"golden engines disagree on the first overflow from the edge of {pos}: interpreter "
                                   f"step {k_star} {nodes}, compiled step {first} {compiled_nodes}")
            return {"from_reset": False, "k_star": k_star, "nodes": nodes, "all": dict(ovf), "k0": 0,
                    "state": rtl_state(graph, start), "u_win": u_win, "rows": rows, "start": start_real,
                    "how": f"{pos} moving out of the {side} of its range from {value:.12g} with {rate} = {v0:g} "
                           f"(the full push stays in range)"}
    return _overflow_from_drift(golden, graph, iface, ports, state_names, q_full,
                                "no position with its rate set leaves its range in "
                                f"{EDGE_STEPS - DRIFT_SLACK}..{EDGE_STEPS} steps: " + "; ".join(tried))


def _input_levels(golden, iface, q_full: int) -> list:
    """The constant inputs a drift scenario tries: the full scale, then the ends of the input's
    range (as port integers, each once)."""
    inp = iface.input
    levels = [q_full]
    for value in (inp.hi, inp.lo):
        if value is not None:
            q = int(golden.quantize_input([float(value)])[0])
            if q not in levels:
                levels.append(q)
    return levels


def _first_overflow(stepper, start_real: dict, q: int, n: int):
    """The first step (from 0) at which a node overflows in ``n`` steps of input ``q`` from the
    compiled kernel's reset with ``start_real`` deposited, or None."""
    stepper.reset(start_real)
    stepper.advance(q, n, every_step=False)
    return min(stepper.overflows.values()) if stepper.overflows else None


def drift_start(stepper, graph, pos: str, edge: float, q: int, extra: dict | None = None):
    """``(value, step)``: where to start ``pos`` (the states in ``extra`` at their values, e.g. its
    rate, the other states at reset) so that its own drift under the constant input ``q`` takes
    the plant out of range (a first overflow, of any node) in EDGE_STEPS - DRIFT_SLACK ..
    EDGE_STEPS steps; ``(None, why)`` when it cannot.

    Found by bisection between ``pos``'s reset value (no overflow within EDGE_STEPS) and
    ``edge`` (an overflow within EDGE_STEPS): the first overflow step falls as the start nears
    the edge; the bisection ends one register LSB from the boundary, whose step lies just
    within EDGE_STEPS unless the overflow jumps there (then None: no gradual drift out)."""
    node = graph[pos]
    safe = float(node.param("reset") or 0.0)
    edge = _within_format(node.qformat, edge, safe)
    g_edge = _first_overflow(stepper, {**(extra or {}), pos: edge}, q, EDGE_STEPS + 1)
    if g_edge is None:
        return None, f"from {edge:g} it stays in range for {EDGE_STEPS} steps"
    if _first_overflow(stepper, {**(extra or {}), pos: safe}, q, EDGE_STEPS + 1) is not None:
        return None, f"from its reset value {safe:g} it leaves within {EDGE_STEPS} steps"
    lo, hi, g_hi = safe, edge, g_edge          # lo: no overflow within EDGE_STEPS; hi: an overflow
    lsb = node.qformat.lsb
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if abs(hi - lo) <= lsb or mid in (lo, hi):
            break
        g = _first_overflow(stepper, {**(extra or {}), pos: mid}, q, EDGE_STEPS + 1)
        if g is not None:
            hi, g_hi = mid, g
        else:
            lo = mid
    if g_hi < EDGE_STEPS - DRIFT_SLACK:
        return None, f"its first overflow jumps to step {g_hi} (no gradual drift out)"
    return hi, g_hi


def _within_format(fmt, value: float, toward: float) -> float:
    """``value``, or the nearest float toward ``toward`` whose rounding to ``fmt`` fits it: a
    format's top in a float rounds up past it when the format is wider than a float (a maglev's
    gap in FIX56_60 tops out at 2^-5 - 2^-60, which as a float is 2^-5)."""
    def fits(v):
        return fmt.contains(int(np.floor(np.ldexp(float(v), fmt.frac) + 0.5)))
    for _ in range(64):
        if fits(value):
            return value
        value = float(np.nextafter(value, toward))
    while not fits(value):
        value = 0.5 * (value + toward)
    return value


def _overflow_from_drift(golden, graph, iface, ports, state_names, q_full: int, before: str) -> dict:
    """The overflow scenario of a plant without a position whose rate can be set (states in
    state-equation form) and whose full push stays in range for the 4 s the vectors simulate (a
    water tank takes many seconds to fill): each reported state in turn, each end of its range
    (its format, or the domain of a table it addresses: :func:`_edge_of`, :func:`_bottom_of`) and
    each constant input (full scale, then the ends of the input's range), the state is deposited
    where its own dynamics carry it out of range in about EDGE_STEPS steps (:func:`drift_start`;
    the other states at reset). The first that works is the scenario; interpreter and compiled
    kernel must agree on its first overflow (step and nodes). When none works, the result says
    so (``"unreachable"``: what was tried) and the overflow tests are skipped with that reason."""
    from pendc.golden import GoldenStepper, register_integers
    from pendc.ir.nodes import Kind

    stepper = GoldenStepper(graph)
    levels = _input_levels(golden, iface, q_full)
    volts = {q: float(golden.u_format.to_float(q)) for q in levels}
    unit = iface.input.unit
    tried = []
    for pos in ports.states:
        if graph[pos].kind is not Kind.REGISTER:
            continue
        for side, edge in (("top", _edge_of(graph, pos)), ("bottom", _bottom_of(graph, pos))):
            for q in levels:
                value, found = drift_start(stepper, graph, pos, edge, q)
                if value is None:
                    tried.append(f"{pos} at the {side} of its register's format ({edge:g}) with {iface.input.name} = "
                                 f"{with_unit(f'{volts[q]:g}', unit)}: {found}")
                    continue
                start_real = {pos: value}
                start = {n: reset_integer(graph, n) for n in state_names}
                start.update(register_integers(graph, start_real))
                u_win = np.full(EDGE_RUN, q, dtype=np.int64)
                stepper.reset(start_real)
                stepper.advance(q, len(u_win), every_step=False)
                compiled = dict(stepper.overflows)
                rows, ovf = interp_window(graph, start, u_win)
                k_star = min(ovf.values()) if ovf else None
                nodes = sorted(n for n, s in ovf.items() if s == k_star)
                first = min(compiled.values())
                if (first, sorted(n for n, s in compiled.items() if s == first)) != (k_star, nodes):
                    raise RuntimeError(
                        f"golden engines disagree on the first overflow of {pos} drifting out from {value!r}: "
                        f"interpreter step {k_star} {nodes}, compiled step {first} "
                        f"{sorted(n for n, s in compiled.items() if s == first)}")
                return {"from_reset": False, "k_star": k_star, "nodes": nodes, "all": dict(ovf), "k0": 0,
                        "state": rtl_state(graph, start), "u_win": u_win, "rows": rows, "start": start_real,
                        "how": f"{pos} started at {value:.12g}, near the {side} of its register's format, with "
                               f"{iface.input.name} = {with_unit(f'{volts[q]:g}', unit)}, first overflowing "
                               f"{', '.join(nodes)} ({before}; the full push stays in range)"}
    return {"unreachable": f"no overflow can be provoked: the full push ({iface.input.name} = "
                           f"{with_unit(f'{volts[q_full]:g}', unit)} for 4 s from reset) stays in range, "
                           f"{before}, and no reported state leaves its range by its own drift under a constant "
                           "input: " + "; ".join(tried)}


def _edge_of(graph, pos: str) -> float:
    """The largest value ``pos`` may take before a node overflows by it alone: the top of its
    register's format, or lower, the top of the domain of a (non-periodic) table it addresses
    (through casts): beyond that the table's read is out of range at once."""
    return _limit_of(graph, pos, top=True)


def _bottom_of(graph, pos: str) -> float:
    """As :func:`_edge_of` at the other end: the bottom of ``pos``'s register format, or higher,
    the bottom of the domain of a (non-periodic) table it addresses."""
    return _limit_of(graph, pos, top=False)


def _limit_of(graph, pos: str, top: bool) -> float:
    from pendc.ir.nodes import Kind
    fmt = graph[pos].qformat
    edge = fmt.max_value if top else fmt.min_value
    for n in graph.nodes:
        if n.kind is not Kind.LUT or n.params.periodic:
            continue
        bound = n.params.hi if top else n.params.lo
        if bound is None:
            continue
        src = n.inputs[0]
        while graph[src].kind is Kind.CAST:
            src = graph[src].inputs[0]
        if src == pos:
            edge = min(edge, float(bound)) if top else max(edge, float(bound))
    return edge

