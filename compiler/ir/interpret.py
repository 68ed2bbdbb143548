"""Reference interpreters of the IR: exact integers (bit-accurate) and real numbers (float).

This is the executable definition of the IR's semantics; the compiled golden model
and the Verilog must agree with :class:`FixedInterpreter` bit for bit. It is written
for clarity, not speed (about 10^4 steps per second on the pendulum graph).

A run takes one input value per step and returns a :class:`Trace`: row k holds the
graph's outputs at the *start* of step k (row 0 is the reset state), i.e. the state
at time k*dt, like the float simulator's rows.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import fsm as fsm_sem
from . import lut as lut_sem
from .graph import Graph
from .nodes import SOURCE_KINDS, Kind
from .qformat import requantize
from .visitor import NodeVisitor


@dataclass(frozen=True)
class Trace:
    """Outputs per step (``outputs[port]``), per-node max |value| if tracked, and overflow events.

    ``overflows`` maps node name -> first step at which it left its range (fixed mode).
    ``extremes`` maps node name -> (smallest, largest) value when the engine tracks them (the
    compiled float engine with ``track_max``), so a range needs no recording of every step.
    """

    outputs: dict
    max_abs: dict
    overflows: dict
    steps: int
    extremes: dict = field(default_factory=dict)


def _aligned(v: int, f_from: int, f_to: int) -> int:
    return v << (f_to - f_from)


class _Base(NodeVisitor, abstract=True, elsewhere=SOURCE_KINDS):
    """Shared run loop; subclasses evaluate one node per kind (``visit_<kind>``) and return
    (value, left its range). Sources and state elements are valued by the loop itself."""

    def __init__(self, graph: Graph):
        self.graph = graph
        self.index = {n.name: i for i, n in enumerate(graph.nodes)}

    def _inputs(self, inputs: dict, steps: int | None) -> tuple[dict, int]:
        ports = {n.params.port: n for n in self.graph.of_kind(Kind.INPUT)}
        missing = set(ports) - set(inputs)
        if missing:
            raise ValueError(f"no values for input port(s) {', '.join(sorted(missing))}")
        arrays = {p: np.asarray(inputs[p]) for p in ports}
        n = min(len(a) for a in arrays.values()) if arrays else (steps or 0)
        steps = n if steps is None else min(steps, n) if arrays else steps
        return arrays, steps

    def run(self, inputs: dict, steps: int | None = None, track_max: bool = False, every: int = 1) -> Trace:
        """Run ``steps`` steps (default: as many as input values); record every ``every``-th row."""
        arrays, steps = self._inputs(inputs, steps)
        nodes = self.graph.nodes
        idx = self.index
        vals = self._reset_values()
        state = self._reset_state()
        out_idx = [(p, idx[n]) for p, n in self.graph.outputs]
        rows = {p: [] for p, _ in out_idx}
        max_abs = np.zeros(len(nodes)) if track_max else None
        overflows: dict = {}
        input_nodes = [(i, n.params.port) for i, n in enumerate(nodes) if n.kind is Kind.INPUT]
        evaluated = [(i, node, self._dispatch[node.kind], [idx[x] for x in node.inputs])
                     for i, node in enumerate(nodes) if node.kind not in SOURCE_KINDS]
        for k in range(steps):
            for i, port in input_nodes:
                vals[i] = self._input_value(nodes[i], arrays[port][k])
            self._load_state(vals, state)
            for i, node, method, ins in evaluated:
                vals[i], ovf = method(self, node, vals, ins)
                if ovf and node.name not in overflows:
                    overflows[node.name] = k
            if k % every == 0:
                for p, i in out_idx:
                    rows[p].append(vals[i])
            if track_max:
                np.maximum(max_abs, np.abs(np.asarray(vals, dtype=np.float64)), out=max_abs)
            state = self._next_state(vals, state, overflows, k)
        outputs = {p: np.asarray(r) for p, r in rows.items()}
        maxima = {n.name: float(max_abs[i]) for i, n in enumerate(nodes)} if track_max else {}
        return Trace(outputs=outputs, max_abs=maxima, overflows=overflows, steps=steps)

    # state handling shared by both modes: registers hold values, FSMs hold state indices
    def _reset_state(self):
        state = {}
        for n in self.graph.nodes:
            if n.kind is Kind.REGISTER:
                state[n.name] = self._const(n, n.params.reset)
            elif n.kind is Kind.FSM:
                state[n.name] = n.params.reset_index
        return state

    def _load_state(self, vals, state):
        for name, s in state.items():
            node = self.graph[name]
            vals[self.index[name]] = node.params.outputs[s] if node.kind is Kind.FSM else s

    def _next_state(self, vals, state, overflows, k):
        new = {}
        for name, s in state.items():
            node = self.graph[name]
            src = vals[self.index[node.inputs[0]]]
            if node.kind is Kind.REGISTER:
                new[name] = src
            else:
                new[name], outside = self._fsm_step(node, s, src)
                if outside and name not in overflows:
                    overflows[name] = k
        return new

    def _reset_values(self):
        vals = [0] * len(self.graph.nodes)
        for i, n in enumerate(self.graph.nodes):
            if n.kind is Kind.CONST:
                vals[i] = self._const(n, n.params.value)
        return vals


class FloatInterpreter(_Base):
    """Real-number semantics: every node computes its exact real result (LUTs evaluate
    their expression, no quantisation). Used for range analysis and as the float twin
    of the bit-accurate model. Each ``visit_<kind>(node, vals, ins)`` reads its inputs'
    values ``vals[j]`` for ``j`` in ``ins``."""

    def _const(self, node, value):
        return float(value)

    def _input_value(self, node, v):
        return float(v)

    def _fsm_step(self, node, s, v):
        p = node.params
        return fsm_sem.next_state_float(s, v, p.states, p.transitions), not p.lo <= v <= p.hi

    def visit_gain(self, node, vals, ins):
        return vals[ins[0]] * node.params.value, False

    def visit_add(self, node, vals, ins):
        return vals[ins[0]] + vals[ins[1]], False

    def visit_sub(self, node, vals, ins):
        return vals[ins[0]] - vals[ins[1]], False

    def visit_neg(self, node, vals, ins):
        return -vals[ins[0]], False

    def visit_mul(self, node, vals, ins):
        return vals[ins[0]] * vals[ins[1]], False

    def visit_cast(self, node, vals, ins):
        return vals[ins[0]], False

    def visit_compare(self, node, vals, ins):
        return float(node.params.op.apply(vals[ins[0]], vals[ins[1]])), False

    def visit_mux(self, node, vals, ins):
        # a select beyond the data inputs picks the last one
        return vals[ins[1 + min(int(vals[ins[0]]), len(ins) - 2)]], False

    def visit_slice(self, node, vals, ins):
        p, a = node.params, vals[ins[0]]
        if p.sign_bit:
            return float(a < 0), False
        return float((int(a) >> p.lo) & ((1 << p.width) - 1)), False

    def visit_lut(self, node, vals, ins):
        p, v = node.params, vals[ins[0]]
        outside = False
        if p.periodic:
            v = p.lo + (v - p.lo) % (p.hi - p.lo)
        elif p.lo is not None and not p.lo <= v <= p.hi:  # no domain yet: before tabulation
            outside, v = True, min(max(v, p.lo), p.hi)
        return float(lut_sem.evaluate(p.expr, v)), outside


class FixedInterpreter(_Base):
    """Bit-accurate semantics on Python integers, exactly as documented in pendc.ir.nodes.
    Each ``visit_<kind>(node, vals, ins)`` returns (integer in the node's format, overflowed)."""

    def __init__(self, graph: Graph):
        untyped = [n.name for n in graph.nodes if n.qformat is None]
        if untyped:
            raise ValueError(f"graph is not typed (no Q-format): {', '.join(untyped[:5])}")
        super().__init__(graph)
        self.fmt = [n.qformat for n in graph.nodes]

    def _const(self, node, value):
        return node.qformat.from_float(float(value))

    def _input_value(self, node, v):
        if isinstance(v, (int, np.integer)):
            return int(v)
        return node.qformat.from_float(float(v))

    def _fsm_step(self, node, s, v):
        fin = self.graph[node.inputs[0]].qformat
        p = node.params
        nxt = fsm_sem.next_state(s, v, fin, p.states, p.transitions)
        return nxt, not fsm_sem.threshold_int(p.lo, fin) <= v <= fsm_sem.threshold_int(p.hi, fin)

    def _requant(self, node, exact: int, frac: int):
        return requantize(exact, frac, node.qformat, node.rounding, node.overflow)

    def _pair(self, vals, ins) -> tuple:
        """Both operands aligned to the larger fraction, and that fraction."""
        fa, fb = self.fmt[ins[0]].frac, self.fmt[ins[1]].frac
        frac = max(fa, fb)
        return _aligned(vals[ins[0]], fa, frac), _aligned(vals[ins[1]], fb, frac), frac

    def visit_gain(self, node, vals, ins):
        p = node.params
        return self._requant(node, vals[ins[0]] * p.constant, self.fmt[ins[0]].frac + p.cfmt.frac)

    def visit_add(self, node, vals, ins):
        x, y, frac = self._pair(vals, ins)
        return self._requant(node, x + y, frac)

    def visit_sub(self, node, vals, ins):
        x, y, frac = self._pair(vals, ins)
        return self._requant(node, x - y, frac)

    def visit_neg(self, node, vals, ins):
        return self._requant(node, -vals[ins[0]], self.fmt[ins[0]].frac)

    def visit_mul(self, node, vals, ins):
        return self._requant(node, vals[ins[0]] * vals[ins[1]], self.fmt[ins[0]].frac + self.fmt[ins[1]].frac)

    def visit_cast(self, node, vals, ins):
        return self._requant(node, vals[ins[0]], self.fmt[ins[0]].frac)

    def visit_compare(self, node, vals, ins):
        x, y, _ = self._pair(vals, ins)
        return int(node.params.op.apply(x, y)), False

    def visit_mux(self, node, vals, ins):
        # a select beyond the data inputs picks the last one
        j = ins[1 + min(vals[ins[0]], len(ins) - 2)]
        return self._requant(node, vals[j], self.fmt[j].frac)

    def visit_slice(self, node, vals, ins):
        hi, lo = node.params.bits(self.fmt[ins[0]].width)
        return (vals[ins[0]] >> lo) & ((1 << (hi - lo + 1)) - 1), False

    def visit_lut(self, node, vals, ins):
        p = node.params
        return lut_sem.lookup(vals[ins[0]], self.fmt[ins[0]], node.qformat, p.lo, p.addr_bits, p.shift, p.table,
                              p.interpolate, p.periodic, node.rounding)
