"""Golden runs resumed from a state deposited into the core, by both golden engines.

A window that starts deep inside a stimulus (and the overflow scenario from a deposited state)
starts from the golden state at its first step, which the testbench deposits into the core's
registers (:func:`rtl_state`: the deposits). The compiled kernel resumed from that state gives
the window's rows (:func:`compiled_window`); the reference interpreter, an independent engine but
far slower, recomputes its first :data:`CHECK_STEPS` steps (:func:`interp_window`,
:func:`interp_windows`). Used by :mod:`golden_vectors`.
"""

from __future__ import annotations

import os

import numpy as np


def state_nodes(graph) -> list:
    """The graph's state elements (registers and FSMs), in graph order."""
    from pendc.ir.nodes import Kind
    return [n for n in graph.nodes if n.kind in (Kind.REGISTER, Kind.FSM)]


def rtl_state(graph, state: dict) -> dict:
    """Golden state (node -> integer) as RTL register deposits: name -> (value, width), the
    registers the HIL harnesses deposit into (:func:`pendc.hil.plants.rtl_plant.deposit_registers`)."""
    from pendc.hil.plants.rtl_plant import deposit_registers
    from pendc.ir.nodes import Kind
    out = {}
    for n, (reg, width) in zip(state_nodes(graph), deposit_registers(graph)):
        v = int(state[n.name])
        out[reg] = (v if n.kind is Kind.REGISTER else list(n.param("outputs")).index(v), width)
    return out


def ports_of(graph):
    """The core's port names (:class:`pendc.hil.plants.core_ports.CorePorts`) of the graph."""
    from pendc.hil.plants.core_ports import CorePorts
    return CorePorts.of_graph(graph)


def interp_window(graph, state: dict | None, u: np.ndarray) -> tuple[np.ndarray, dict]:
    """Rows 0..len(u) (outputs at the start of each step) from ``state`` with inputs ``u``."""
    from pendc.ir.interpret import FixedInterpreter
    from pendc.ir.nodes import Kind

    class Resumed(FixedInterpreter):
        """Starts from ``state``'s integers as they are (a real reset value would round a register
        wider than a float's 53 bits)."""

        def _reset_state(self):
            st = super()._reset_state()
            for name, v in (state or {}).items():
                n = self.graph[name]
                st[name] = int(v) if n.kind is Kind.REGISTER else list(n.params.outputs).index(int(v))
            return st

    ints = [int(v) for v in u] + [int(u[-1])]
    ports = ports_of(graph)
    tr = Resumed(graph).run({ports.input: ints}, every=1)
    return np.stack([np.asarray(tr.outputs[p], dtype=np.int64) for p in ports.outputs], axis=1), dict(tr.overflows)


def _window_job(args):
    graph, state, u = args
    return interp_window(graph, state, u)


def interp_windows(graph, runs: list) -> list:
    """:func:`interp_window` of each ``(state, u)`` of ``runs``, on two worker processes."""
    return _map(_window_job, [(graph, state, u) for state, u in runs])


# Steps at the start of every deep window that the reference interpreter recomputes: the window
# itself comes from the compiled kernel (resumed from the deposited state); the interpreter, an
# independent engine but far slower (most of the vectors' time when it computed every window),
# checks that start (registers and FSMs resumed, the first steps after), and the compiled run
# from the stimulus' start checks the window's last row.
CHECK_STEPS = 200


def compiled_window(stepper, state: dict, u: np.ndarray) -> tuple[np.ndarray, dict]:
    """As :func:`interp_window`, by the compiled kernel: ``stepper`` (a
    :class:`pendc.golden.GoldenStepper` of the graph) resumed from ``state`` (node -> integer,
    FSMs as their Moore output word), one kernel call per run of equal inputs."""
    from pendc.ir.nodes import Kind
    graph = stepper.graph
    stepper.reset()
    for p, i in enumerate(stepper.state_idx):
        n = graph.nodes[i]
        v = int(state[n.name])
        stepper.state[p] = list(n.param("outputs")).index(v) if n.kind is Kind.FSM else v
    cols = [stepper.ports.index(p) for p in ports_of(graph).outputs]
    u = np.asarray(u, np.int64)
    edges = np.flatnonzero(np.diff(u)) + 1
    parts = []
    for a, b in zip(np.concatenate([[0], edges]), np.concatenate([edges, [len(u)]])):
        out = stepper.advance(int(u[a]), int(b - a), every_step=True)
        parts.append(out[:-1, cols])
    parts.append(out[-1:, cols])
    return np.concatenate(parts), dict(stepper.overflows)


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


def port_rows(trace, ports) -> np.ndarray:
    """A golden trace's output ports as rows (one column per port, in ``ports.outputs`` order)."""
    return np.stack([np.asarray(trace.outputs[p], dtype=np.int64) for p in ports.outputs], axis=1)


def reset_integer(graph, name) -> int:
    """A state node's value after reset as its integer (FSMs: their Moore output word)."""
    from pendc.ir.nodes import Kind
    n = graph[name]
    if n.kind is Kind.REGISTER:
        return n.qformat.from_float(float(n.param("reset") or 0.0))
    return reset_word(graph, name)


def reset_word(graph, name):
    """An FSM's Moore output word after reset (0 for a register)."""
    n = graph[name]
    if n.param("states") is not None:
        return n.param("outputs")[list(n.param("states")).index(n.param("reset"))]
    return 0
