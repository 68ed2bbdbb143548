"""Reference interpreters of the IR: exact integers (bit-accurate) and real numbers (float).

This is the executable definition of the IR's semantics; the compiled golden model
and the Verilog must agree with :class:`FixedInterpreter` bit for bit. It is written
for clarity, not speed (about 10^4 steps per second on the pendulum graph).

A run takes one input value per step and returns a :class:`Trace`: row k holds the
graph's outputs at the *start* of step k (row 0 is the reset state), i.e. the state
at time k*dt, like the float simulator's rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import fsm as fsm_sem
from . import lut as lut_sem
from .graph import Graph
from .nodes import Kind, Node
from .qformat import QFormat, requantize


@dataclass(frozen=True)
class Trace:
    """Outputs per step (``outputs[port]``), per-node max |value| if tracked, and overflow events.

    ``overflows`` maps node name -> first step at which it left its range (fixed mode).
    """

    outputs: dict
    max_abs: dict
    overflows: dict
    steps: int


def _aligned(v: int, f_from: int, f_to: int) -> int:
    return v << (f_to - f_from)


class _Base:
    def __init__(self, graph: Graph):
        self.graph = graph
        self.index = {n.name: i for i, n in enumerate(graph.nodes)}

    def _inputs(self, inputs: dict, steps: int | None) -> tuple[dict, int]:
        ports = {n.param("port"): n for n in self.graph.of_kind(Kind.INPUT)}
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
        input_nodes = [(i, n.param("port")) for i, n in enumerate(nodes) if n.kind is Kind.INPUT]
        for k in range(steps):
            for i, port in input_nodes:
                vals[i] = self._input_value(nodes[i], arrays[port][k])
            self._load_state(vals, state)
            for i, node in enumerate(nodes):
                if node.kind in _SOURCES:
                    continue
                vals[i], ovf = self._eval(node, vals)
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
                state[n.name] = self._const(n, n.param("reset", 0.0))
            elif n.kind is Kind.FSM:
                state[n.name] = n.param("states").index(n.param("reset"))
        return state

    def _load_state(self, vals, state):
        for name, s in state.items():
            node = self.graph[name]
            vals[self.index[name]] = node.param("outputs")[s] if node.kind is Kind.FSM else s

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
                vals[i] = self._const(n, n.param("value"))
        return vals


_SOURCES = (Kind.CONST, Kind.INPUT, Kind.REGISTER, Kind.FSM)


class FloatInterpreter(_Base):
    """Real-number semantics: every node computes its exact real result (LUTs evaluate
    their expression, no quantisation). Used for range analysis and as the float twin
    of the bit-accurate model."""

    def _const(self, node, value):
        return float(value)

    def _input_value(self, node, v):
        return float(v)

    def _fsm_step(self, node, s, v):
        nxt = fsm_sem.next_state_float(s, v, node.param("states"), node.param("transitions"))
        return nxt, not node.param("lo") <= v <= node.param("hi")

    def _eval(self, node: Node, vals):
        a = [vals[self.index[i]] for i in node.inputs]
        k = node.kind
        if k is Kind.GAIN:
            return a[0] * node.param("value"), False
        if k is Kind.ADD:
            return a[0] + a[1], False
        if k is Kind.SUB:
            return a[0] - a[1], False
        if k is Kind.NEG:
            return -a[0], False
        if k is Kind.MUL:
            return a[0] * a[1], False
        if k is Kind.CAST:
            return a[0], False
        if k is Kind.COMPARE:
            return float(_CMP[node.param("op")](a[0], a[1])), False
        if k is Kind.MUX:       # a select beyond the data inputs picks the last one
            return a[1 + min(int(a[0]), len(a) - 2)], False
        if k is Kind.SLICE:
            hi, lo = node.param("hi"), node.param("lo")
            if hi == lo == -1:
                return float(a[0] < 0), False
            return float((int(a[0]) >> lo) & ((1 << (hi - lo + 1)) - 1)), False
        if k is Kind.LUT:
            v = a[0]
            lo, hi = node.param("lo"), node.param("hi")
            outside = False
            if node.param("periodic"):
                v = lo + (v - lo) % (hi - lo)
            elif lo is not None and not lo <= v <= hi:  # no domain yet: before tabulation
                outside, v = True, min(max(v, lo), hi)
            return float(lut_sem.evaluate(node.param("expr"), v)), outside
        raise ValueError(f"cannot evaluate node kind {k}")


_CMP = {
    "lt": lambda a, b: a < b, "le": lambda a, b: a <= b, "gt": lambda a, b: a > b,
    "ge": lambda a, b: a >= b, "eq": lambda a, b: a == b, "ne": lambda a, b: a != b,
}


class FixedInterpreter(_Base):
    """Bit-accurate semantics on Python integers, exactly as documented in pendc.ir.nodes."""

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
        nxt = fsm_sem.next_state(s, v, fin, node.param("states"), node.param("transitions"))
        lo, hi = fsm_sem.threshold_int(node.param("lo"), fin), fsm_sem.threshold_int(node.param("hi"), fin)
        return nxt, not lo <= v <= hi

    def _eval(self, node: Node, vals):
        ins = [self.index[i] for i in node.inputs]
        a = [vals[i] for i in ins]
        f = [self.fmt[i].frac for i in ins]
        out: QFormat = node.qformat
        k = node.kind
        if k is Kind.GAIN:
            cfmt = QFormat.parse(node.param("cfmt"))
            exact, frac = a[0] * cfmt.from_float(node.param("value")), f[0] + cfmt.frac
        elif k in (Kind.ADD, Kind.SUB):
            frac = max(f)
            x, y = _aligned(a[0], f[0], frac), _aligned(a[1], f[1], frac)
            exact = x + y if k is Kind.ADD else x - y
        elif k is Kind.NEG:
            exact, frac = -a[0], f[0]
        elif k is Kind.MUL:
            exact, frac = a[0] * a[1], f[0] + f[1]
        elif k is Kind.CAST:
            exact, frac = a[0], f[0]
        elif k is Kind.COMPARE:
            frac = max(f)
            x, y = _aligned(a[0], f[0], frac), _aligned(a[1], f[1], frac)
            return int(_CMP[node.param("op")](x, y)), False
        elif k is Kind.MUX:     # a select beyond the data inputs picks the last one
            j = 1 + min(a[0], len(a) - 2)
            exact, frac = a[j], f[j]
        elif k is Kind.SLICE:
            hi, lo = node.param("hi"), node.param("lo")
            width = self.fmt[ins[0]].width
            hi, lo = (width - 1, width - 1) if hi == lo == -1 else (hi, lo)
            return (a[0] >> lo) & ((1 << (hi - lo + 1)) - 1), False
        elif k is Kind.LUT:
            p = dict(node.params)
            return lut_sem.lookup(a[0], self.fmt[ins[0]], out, p["lo"], p["addr_bits"], p["shift"], p["table"],
                                  p["interpolate"], p["periodic"], node.rounding)
        else:
            raise ValueError(f"cannot evaluate node kind {k}")
        return requantize(exact, frac, out, node.rounding, node.overflow)
