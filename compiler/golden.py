"""The golden model: the compiled core's exact integer behaviour, in physical units.

:class:`GoldenModel` runs the typed IR bit-accurately — through the numba kernel by
default, or the reference interpreter (``engine="interpreter"``, slow, for cross
checks) — on sampled inputs, and returns states at the sample times like the float
simulator does, so the two can be compared column by column. The Verilog must match
its integers bit for bit.

A run never wraps silently: a node that leaves its Q-format's range raises
:class:`OverflowStop` naming the node and the time, unless the caller asks to mark the
affected rows instead (``on_overflow="mark"``). :class:`GoldenStepper` continues a run
from its saved state (registers and FSM states), for plants that step in lockstep.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import PendcError
from .ir.compiled import CompiledGraph, record_buffer
from .ir.graph import Graph
from .ir.interpret import FixedInterpreter
from .ir.resumable import make_resumable, reset_state, state_indices  # noqa: F401  (make_resumable: its old home)
from .model.interface import require_interface
from .sim.signals import signals_of
from .sim.simulator import SimResult

OVERFLOW_CHOICES = ("error", "mark")
LONG_RUN_STEPS = 5_000_000   # beyond 5 s at 1 us, run sample by sample instead of one trace in memory


class OverflowStop(PendcError):
    """A node left its format's range: the hardware's sticky flag, as an error naming node and time."""

    def __init__(self, node: str, step: int, dt: float, overflows: dict | None = None, signals=None):
        self.node, self.step, self.time = node, int(step), step * dt
        rest = sorted((k for k in (overflows or {}) if k != node), key=lambda k: (overflows[k], k))
        # each is named: a range set by hand on the first alone left the next to fail on the next run
        others = (f" (also {', '.join(rest[:4])}" + (f" and {len(rest) - 4} more" if len(rest) > 4 else "")
                  + "; [hardware.ranges] sizes a node by hand)") if rest else ""
        super().__init__(f"node '{node}' left its Q-format range at t = {self.time:.6g} s (step {step}){others}; "
                         f"the fixed-point results from there on would be wrapped values"
                         + (overflow_hint(node, signals) if signals is not None else ""))


def overflow_hint(node: str, signals) -> str:
    """What to change when ``node`` is a periodic state's own register: its ``turns`` (a reaction
    wheel spinning for minutes passes the default 256 turns; the node's name alone did not say)."""
    for spec in sorted(signals.interface.states, key=lambda s: -len(s.name)):
        if spec.period and (node == spec.name or node.startswith(spec.name + "_")):
            return (f"; {spec.name} is periodic and its register holds {spec.turns} whole turns either way: a run "
                    f"that turns it further needs a larger `turns` in its plant file")
    return ""


def first_overflow(overflows: dict, graph=None) -> tuple[str, int] | None:
    """(node, step) of the earliest overflow, or None. Ties within a step go to the node the step
    computes first (``graph``'s topological order: the cause, not a sum that inherits its wrapped
    value; a Cramer numerator's partial sum, not the acceleration it feeds), else by name."""
    if not overflows:
        return None
    order = {n.name: i for i, n in enumerate(graph.nodes)} if graph is not None else {}
    return min(overflows.items(), key=lambda kv: (kv[1], order.get(kv[0], len(order)), kv[0]))


@dataclass(frozen=True)
class GoldenRun:
    """States at the sample times (``result``), raw integers of every output at every recorded
    step (``raw``: every gcd of the sample intervals), and the nodes that left their range with
    the first step they did (``overflows``)."""

    result: SimResult
    raw: dict
    overflows: dict
    rows: np.ndarray | None = None     # model step of each sample row

    def marked_rows(self) -> np.ndarray:
        """1 for every sample row whose state was computed at or after the first overflow (the
        sticky flag was up), else 0."""
        first = first_overflow(self.overflows)
        n = len(self.result.t)
        if first is None or self.rows is None:
            return np.zeros(n, dtype=np.int64)
        # the row at step k shows the state after k steps; step k's overflow affects rows > k
        return (self.rows > first[1]).astype(np.int64)


def steps_per_sample(t: np.ndarray, dt: float) -> np.ndarray:
    steps = np.round(np.diff(t) / dt).astype(np.int64)
    if np.any(steps < 1) or not np.allclose(steps * dt, np.diff(t), rtol=1e-6, atol=1e-12):
        raise PendcError(f"sample times must be whole multiples of the model step dt = {dt:g} s")
    return steps


class GoldenModel:
    """Bit-accurate runs of a typed graph (``BuildResult.graph``) with step ``dt``."""

    def __init__(self, graph: Graph, dt: float, engine: str = "compiled"):
        self.graph = graph
        self.dt = dt
        self.engine = engine
        iface = require_interface(graph)           # the plant's input port and reported states
        self.input, self.states = iface.input.name, iface.outputs
        self.signals = signals_of(iface)           # a result's columns are this plant's
        self.u_format = graph[self.input].qformat
        self._run = CompiledGraph(graph, "fixed").run if engine == "compiled" else FixedInterpreter(graph).run

    def quantize_input(self, u) -> np.ndarray:
        """Input voltages as the core's input-port integers (nearest, saturating)."""
        f = self.u_format
        scaled = np.floor(np.ldexp(np.asarray(u, dtype=np.float64), f.frac) + 0.5)
        return np.clip(scaled, f.min_int, f.max_int).astype(np.int64)

    def input_integers(self, t, u) -> np.ndarray:
        """The input-port integer at every step of the zero-order-hold samples ``u`` at times
        ``t`` (the last sample is held for no step): each sample quantised once, then held, the
        same integers as quantising every step's value at a fraction of the work (seconds of
        stimulus are millions of steps)."""
        t = np.asarray(t, dtype=np.float64)
        return np.repeat(self.quantize_input(np.asarray(u, dtype=np.float64)[:-1]), steps_per_sample(t, self.dt))

    def run_steps(self, u_per_step, every: int = 1, record: tuple = ()):
        """Raw trace for one input integer (or voltage) per step."""
        u = np.asarray(u_per_step)
        ints = u if np.issubdtype(u.dtype, np.integer) else self.quantize_input(u)
        if self.engine == "compiled":
            return self._run({self.input: ints}, every=every, record=record)
        return self._run({self.input: [int(v) for v in ints]}, every=every)

    def __call__(self, t, u, on_overflow: str = "error", initial: tuple | None = None) -> GoldenRun:
        """States at the sample times ``t`` for ZOH input samples ``u`` (from reset, t[0] = 0 state).

        A node leaving its range raises :class:`OverflowStop`; with ``on_overflow="mark"`` the run
        completes and :meth:`GoldenRun.marked_rows` tells which sample rows come after the flag.
        ``initial`` (the reported states in the interface's order, each position then its rate) starts the state registers there instead of at reset
        (the encoder FSMs start as at power-on)."""
        if on_overflow not in OVERFLOW_CHOICES:
            raise PendcError(f"on_overflow must be one of {', '.join(OVERFLOW_CHOICES)}, got {on_overflow!r}")
        t = np.asarray(t, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        steps = steps_per_sample(t, self.dt)
        if initial is not None or int(steps.sum()) > LONG_RUN_STEPS:
            return self._from_state(t, u, steps, initial, on_overflow)
        per_step = self.input_integers(t, u)
        total = int(steps.sum())
        # record only every gcd(steps)-th step: a minute at 1 us would be 6e7 rows otherwise
        every = int(np.gcd.reduce(steps)) if total else 1
        trace = self.run_steps(np.append(per_step, per_step[-1:] if total else self.quantize_input(u[:1])),
                               every=every)
        rows = np.concatenate([[0], np.cumsum(steps)])
        states = {s: np.asarray(trace.outputs[s], dtype=np.float64)[rows // every] * self.graph.output(s).qformat.lsb
                  for s in self.states}
        result = SimResult(t=t, u=u, states=states, signals=self.signals)
        first = first_overflow(trace.overflows, self.graph)
        if first is not None and on_overflow == "error":
            raise OverflowStop(first[0], first[1], self.dt, trace.overflows, self.signals)
        return GoldenRun(result=result, raw={k: np.asarray(v) for k, v in trace.outputs.items()},
                         overflows=dict(trace.overflows), rows=rows)

    def _from_state(self, t, u, steps, initial, on_overflow) -> GoldenRun:
        """Sample by sample through the resumable kernel (memory independent of the run's length),
        from reset or from the registers at ``initial``."""
        if self.engine != "compiled":
            raise PendcError("a run from an initial state or a long run needs the compiled engine")
        start = dict(zip(self.states, initial)) if initial is not None else None
        stepper = GoldenStepper(self.graph)
        stepper.reset(start)
        cols = [stepper.ports.index(s) for s in self.states]
        ints = self.quantize_input(u)
        rows = np.empty((len(t), len(self.states)), np.int64)
        rows[0] = stepper.advance(int(ints[0]), 1)[0, cols]
        stepper.reset(start)
        for i, n in enumerate(steps):
            rows[i + 1] = stepper.advance(int(ints[i]), int(n), every_step=False)[-1, cols]
        first = first_overflow(stepper.overflows, self.graph)
        if first is not None and on_overflow == "error":
            raise OverflowStop(first[0], first[1], self.dt, stepper.overflows, self.signals)
        states = {s: rows[:, j] * self.graph.output(s).qformat.lsb for j, s in enumerate(self.states)}
        return GoldenRun(result=SimResult(t=t, u=u, states=states, signals=self.signals), raw={s: rows[:, j] for j, s in enumerate(self.states)},
                         overflows=dict(stepper.overflows), rows=np.concatenate([[0], np.cumsum(steps)]))


def register_integers(graph: Graph, registers: dict) -> dict:
    """{register name: integer} for real start values (name -> value) of registers of ``graph``.

    The integers the golden stepper starts from and the RTL plants deposit into the core's
    state registers; a name that is not a register, or a value outside the register's
    format, raises :class:`PendcError`."""
    from .ir.nodes import Kind

    out = {}
    for name, value in registers.items():
        node = next((n for n in graph.nodes if n.name == name and n.kind is Kind.REGISTER), None)
        if node is None:
            raise PendcError(f"no register named '{name}' in the core")
        if not node.qformat.contains(int(np.floor(np.ldexp(float(value), node.qformat.frac) + 0.5))):
            raise PendcError(f"initial {name} = {value} does not fit its format {node.qformat}")
        out[name] = node.qformat.from_float(float(value))
    out.update(_turn_integers(graph, registers, out))
    out.update(_read_ahead_integers(graph, registers, out))
    return out


def _turn_integers(graph: Graph, registers: dict, given: dict) -> dict:
    """The whole-turn registers of the periodic states in ``registers``
    (:func:`pendc.passes.lower_turns.turn_registers`): a run started at an angle holds its nearest
    whole turns, as one that had turned there would, so the phase its tables read starts within
    half a period (reset at zero turns, a start beyond half a period would put the phase outside
    its format in the first step)."""
    from .ir.nodes import Kind
    from .model.interface import graph_interface
    from .passes.lower_turns import nearest_turns, turn_registers

    iface = graph_interface(graph)
    out = {}
    for spec in (iface.periodic if iface is not None else ()):
        if spec.name not in registers:
            continue
        turns = nearest_turns(float(registers[spec.name]), spec.period)
        for name, value in zip(turn_registers(spec.name), (turns, turns * spec.period)):
            node = next((n for n in graph.nodes if n.name == name and n.kind is Kind.REGISTER), None)
            if node is None or name in given:
                continue
            if not node.qformat.contains(int(np.floor(np.ldexp(float(value), node.qformat.frac) + 0.5))):
                raise PendcError(f"initial {spec.name} = {registers[spec.name]} is {turns} whole turns, "
                                 f"more than its core counts ({spec.turns})")
            out[name] = node.qformat.from_float(float(value))
    return out


def _read_ahead_integers(graph: Graph, registers: dict, given: dict) -> dict:
    """The registers of tables read a step ahead (``lower_model(lookahead=True)``) for a run
    started at the periodic states in ``registers``: each holds its table's value at the state's
    phase, as a run that had arrived there would (their reset holds the value at phase 0)."""
    from .ir import lut as lut_sem
    from .passes.lower import READ_AHEAD_KEY

    out = {}
    for name, state, period in dict(graph.info).get(READ_AHEAD_KEY, ()):
        if state not in registers or name in given or name not in graph.by_name:
            continue
        table = graph[graph[name].inputs[0]]
        p, fin = table.params, graph[table.inputs[0]].qformat
        turns = (float(registers[state]) / period) % 1.0
        y, _ = lut_sem.lookup(fin.from_float(turns), fin, table.qformat, p.lo, p.addr_bits, p.shift, p.table,
                              p.interpolate, p.periodic, table.rounding)
        out[name] = graph[name].qformat.from_float(y * table.qformat.lsb)
    return out


class GoldenStepper:
    """The compiled golden kernel, continued from its saved state call after call.

    ``advance(u_int, n)`` runs n steps with the input port held at the integer ``u_int`` and
    returns the output ports' integers at the start of every step and after the last one
    ((n + 1) x ports); ``overflows`` accumulates {node: first step since reset}. The kernel is
    :class:`~pendc.ir.compiled.CompiledGraph`'s own (every fixed-point kernel is resumable), so a
    model that was run or compiled already steps without another compile; ``like`` (an earlier
    typing of the graph) shares machine code as CompiledGraph's ``like`` does."""

    def __init__(self, graph: Graph, like: Graph | None = None):
        from .ir.nodes import Kind

        self.graph = graph
        inputs = [n for n in graph.nodes if n.kind is Kind.INPUT]
        if len(inputs) != 1:
            raise PendcError(f"a stepping golden model needs exactly one input port, the graph has {len(inputs)}")
        self.compiled = CompiledGraph(graph, "fixed", like=like)
        self.state_idx = state_indices(graph)
        self.ports = [p for p, _ in graph.outputs]
        index = {n.name: i for i, n in enumerate(graph.nodes)}
        self._sel = np.array([index[node] for _, node in graph.outputs], dtype=np.int64)
        self._reset_state = reset_state(graph)
        self.reset()

    def reset(self, registers: dict | None = None) -> None:
        """Back to reset; ``registers`` (name -> real value) start some registers elsewhere."""
        self.state = self._reset_state.copy()
        names = [self.graph.nodes[i].name for i in self.state_idx]
        for name, q in register_integers(self.graph, registers or {}).items():
            self.state[names.index(name)] = q
        self.k = 0
        self.overflows: dict = {}

    def advance(self, u_int: int, n: int, every_step: bool = True) -> np.ndarray:
        """Run ``n`` steps at input integer ``u_int``; output integers at every step and after the
        last (n + 1 rows), or with ``every_step=False`` only before and after (2 rows, faster:
        recording every step copies every node's value)."""
        ins = np.full((1, n + 1), int(u_int), dtype=np.int64)
        rows = n + 1 if every_step else 2
        out = record_buffer(len(self._sel), rows, np.int64)  # the kernel writes out[column, row]
        last = np.empty((len(self._sel), 1), np.int64)       # its own array: a slice would be another layout
        ov = np.full(len(self.graph.nodes), -1, np.int64)
        self.compiled.call(ins, n, 1 if every_step else n, self._sel, out, ov, self.state, self.k)
        after_n = self.state.copy()
        # the last row comes from one more step whose update is discarded (the state saved after
        # step n is put back): its outputs are the state after n steps
        self.compiled.call(ins[:, n:], 1, 1, self._sel, last, np.full(len(self.graph.nodes), -1, np.int64),
                           self.state, self.k + n)
        out[:, rows - 1] = last[:, 0]
        out = out[:, :rows]
        self.state = after_n
        for i in np.flatnonzero(ov >= 0):
            self.overflows.setdefault(self.graph.nodes[int(i)].name, int(ov[i]))
        self.k += n
        return out.T
