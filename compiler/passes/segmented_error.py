"""The error of a fixed-point graph against its float twin where the plant is discontinuous.

A plant with a discontinuity (stick-slip or Coulomb friction: a force that jumps where the
velocity changes sign) turns a tiny error into a large one: if the fixed-point run crosses the
jump a few steps after its float twin, the two get different forces for those steps and their
positions part for good, by an amount that depends on how slowly the velocity crossed, not on
the arithmetic. The plain max |fixed - float| over a horizon then measures the plant's
sensitivity, and no number of bits meets a budget on it.

The *segmented* error restarts the comparison there. A decision is the select of a MUX that
the budget states are computed from (their registers' fan-in, turn counters left out: a wrap
one step apart changes no state, the periodic tables read the same phase) and that is not
continuous by construction (a clamp, min or max whose compare reads its own two data inputs;
an absolute value selected by its operand's sign). Where such a decision differs between the
runs and its MUX is live in either of them (every MUX below it selects its branch), the fixed
run restarts from the float twin's registers at that step; the figure is the largest
|fixed - float| within a segment. A difference that persists right after a restart (the
arithmetic itself decides differently from the same state) is not restarted again. A plant
without decisions has one segment: the plain max error.

The runs go in pieces of up to :data:`CHUNK` steps through the resumable kernels
(:mod:`pendc.ir.resumable`), so memory does not grow with the horizon: the float twin once
(recording the registers a restart loads), the fixed run that restarts (a restart re-runs the
piece from its start to the decision), and a fixed run that never does, for the plain error.
A cart that the thesis' exact zero test sticks chatters about zero velocity (a swinging
pendulum pushes it off zero every step, friction pushes it back across): its friction's sign
flips every few steps in both runs, not in step, and restarts come by the hundred.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..ir.compiled import CompiledGraph, record_buffer, run_side_by_side
from ..ir.graph import Graph
from ..ir.nodes import Kind
from ..ir.resumable import state_indices
from ..model.interface import graph_interface
from .lower_turns import turn_registers
from .ranges import per_step, per_step_integers
from .twin import BudgetError, budget_states, float_twin

CHUNK = 1 << 14      # steps per kernel call: a restart re-runs at most this many
FIRST_PIECE = 256    # steps of the segmented run's first call after a restart (doubling up to CHUNK)
# the form in one line, as the report prints it
FORM = ("segmented: the largest |fixed - float| between restarts, the fixed run restarting from the float twin's "
        "registers where a discontinuous decision the states read (sticking, a friction's sign) starts to differ, "
        "because a decision a step apart parts the runs by the plant's jump, not by the arithmetic's error "
        "(no such decision: the plain max)")


@dataclass(frozen=True)
class SegmentedRun:
    """One stimulus: per state the plain and the segmented max |fixed - float|, and the steps at
    which the fixed run was restarted (the first few: ``restart_steps``; their number: ``restarts``)."""

    plain: dict | None
    segmented: dict
    restarts: int
    restart_steps: tuple
    steps: int
    stopped_at: int | None = None   # the step a ``stop_above`` ended the run at (its errors: lower bounds)


class Decisions:
    """What the segmented comparison of ``graph`` records and how it reads it."""

    MAX_TERMS = 32          # a MUX reached along more guarded paths than this counts as always live

    def __init__(self, graph: Graph):
        self.graph = graph
        self.states = budget_states(graph)
        iface = graph_interface(graph)
        skip = {name for s in (iface.periodic if iface is not None else ()) for name in turn_registers(s.name)}
        roots = [graph.output(s).name for s in self.states if graph.output(s).kind is Kind.REGISTER]
        cone, todo = set(), list(roots)
        self.registers = []                       # registers the states are computed from
        while todo:
            name = todo.pop()
            if name in cone or name in skip:
                continue
            cone.add(name)
            node = graph[name]
            if node.kind is Kind.REGISTER:
                self.registers.append(name)
            todo.extend(node.inputs)
        self.registers.sort()
        consumers = {n: [] for n in cone}
        for name in cone:
            for i in graph[name].inputs:
                if i in cone and name not in consumers[i]:
                    consumers[i].append(name)
        muxes = sorted(n for n in cone if graph[n].kind is Kind.MUX)
        self.decisions = tuple(m for m in muxes if not _continuous(graph, graph[m]))
        memo: dict = {}
        self.guards = {m: self._guards(m, consumers, memo) for m in self.decisions}
        self.muxes = tuple(sorted(set(self.decisions) | {c for terms in self.guards.values() for t in terms
                                                          for c, _ in t}))      # the MUXes a verdict reads
        self.selects = tuple(sorted({graph[m].inputs[0] for m in self.muxes}))
        # per MUX a verdict reads: its select and the last data input a select beyond them picks
        self._select = {m: (graph[m].inputs[0], len(graph[m].inputs) - 2) for m in self.muxes}
        # per decision: the MUXes its verdict reads (itself and those of its guards)
        self._reads = {m: {m} | {c for t in self.guards[m] for c, _ in t} for m in self.decisions}

    def _guards(self, name: str, consumers: dict, memo: dict) -> frozenset:
        """When ``name``'s value reaches a register: a set of terms, each a tuple of (MUX, data
        inputs it must select); the empty term: always."""
        if name in memo:
            return memo[name]
        memo[name] = frozenset()                  # a cycle closes only through a register
        always = frozenset({()})
        terms = set()
        for c in consumers[name]:
            node = self.graph[c]
            if node.kind is Kind.REGISTER:
                terms = set(always)
                break
            below = self._guards(c, consumers, memo)
            if node.kind is Kind.MUX and name != node.inputs[0]:
                picks = frozenset(j for j, i in enumerate(node.inputs[1:]) if i == name)
                terms |= {tuple(sorted(t + ((c, picks),))) for t in below}
            else:
                terms |= below
            if () in terms or len(terms) > self.MAX_TERMS:
                terms = set(always)
                break
        memo[name] = frozenset(terms)
        return memo[name]

    def _choices(self, sel: dict, muxes) -> dict:
        """MUX -> the data input it selects per step (a select beyond them picks the last), for ``muxes``."""
        out = {}
        for m in muxes:
            name, last = self._select[m]
            out[m] = np.minimum(sel[name].astype(np.int64), last)
        return out

    def _live(self, choice: dict, mux: str, n: int) -> np.ndarray:
        out = np.zeros(n, bool)
        for term in self.guards[mux]:
            ok = np.ones(n, bool)
            for c, picks in term:            # a MUX's data input is mostly one of its inputs: compare
                ok &= (choice[c] == next(iter(picks))) if len(picks) == 1 else np.isin(choice[c], list(picks))
            out |= ok
        return out

    def differ(self, fixed_sel: dict, float_sel: dict, n: int) -> np.ndarray:
        """Per step: some decision differs between the runs where its MUX is live in either
        (``*_sel``: select node -> its values over the ``n`` steps)."""
        out = np.zeros(n, bool)
        # equal select values are equal choices: only a decision whose select values differ
        # somewhere needs the choices, and only of the MUXes its verdict reads
        split = [m for m in self.decisions if (fixed_sel[self._select[m][0]] != float_sel[self._select[m][0]]).any()]
        if not split:
            return out
        reads = set().union(*(self._reads[m] for m in split))
        a, b = self._choices(fixed_sel, reads), self._choices(float_sel, reads)
        for m in split:
            differs = a[m] != b[m]
            if differs.any():
                out |= differs & (self._live(a, m, n) | self._live(b, m, n))
        return out


def _source(graph: Graph, name: str) -> str:
    while graph[name].kind is Kind.CAST:
        name = graph[name].inputs[0]
    return name


def _continuous(graph: Graph, mux) -> bool:
    """A clamp/min/max (its select compares its own two data inputs, or a value and a bound when
    the other input is an inner min/max of that value) or an absolute value (the sign of a value
    selects it or its negation): the output does not jump where the select flips."""
    sel, data = graph[mux.inputs[0]], {_source(graph, i) for i in mux.inputs[1:]}
    if len(mux.inputs) != 3:
        return False
    if sel.kind is Kind.COMPARE:
        compared = {_source(graph, i) for i in sel.inputs}
        if compared == data:
            return True
        # clamp(a, lo, hi) = max(min(a, hi), lo): at a = lo the inner min is a itself
        inner = [i for i in data - compared if graph[i].kind is Kind.MUX and _continuous(graph, graph[i])]
        value = compared - data
        return len(data & compared) == 1 and len(value) == 1 and len(inner) == 1 and \
            value <= {_source(graph, j) for j in graph[inner[0]].inputs[1:]}
    if sel.kind is Kind.SLICE and sel.params.sign_bit:
        a = _source(graph, sel.inputs[0])
        negs = {n for n in data if graph[n].kind is Kind.NEG and _source(graph, graph[n].inputs[0]) == a}
        return a in data and len(negs) == 1
    return False


class _Lane:
    """One kernel run continued piece by piece: its state, the columns it records, its overflows."""

    def __init__(self, compiled: CompiledGraph, ins: np.ndarray, columns: tuple):
        self.c, self.ins, self.columns = compiled, ins, columns
        self.sel = np.array([compiled.index[n] for n in columns], np.int64)
        self.st = compiled.start.copy()
        self.ov = np.full(len(compiled.graph.nodes), -1, np.int64)

    def run(self, k: int, n: int, record: bool = True) -> dict | None:
        """Steps ``k .. k + n - 1``; their recorded columns (None: nothing recorded)."""
        ins = np.ascontiguousarray(self.ins[:, k:k + n])
        out = record_buffer(len(self.columns), n if record else 1, self.ins.dtype)
        self.c.call(ins, n, 1 if record else n, self.sel, out, self.ov, self.st, k)
        return {c: out[j, :n] for j, c in enumerate(self.columns)} if record else None


def compare_segmented(graph: Graph, stimuli: dict, dt: float, like: Graph | None = None,
                      chunk: int = CHUNK, plain: bool = True, stop_above: dict | None = None) -> dict:
    """Stimulus name -> :class:`SegmentedRun` of ``graph`` against its float twin on ``stimuli``
    (name -> (t, u) on the graph's one input), side by side on the machine's cores; ``plain``
    False leaves the plain error out (None: a run less). An overflow of the fixed run is a
    BudgetError. ``stop_above`` (state -> error) ends every stimulus' run once a state's segmented
    error exceeds it in one of them (``SegmentedRun.stopped_at``; the errors are then lower
    bounds): enough for whoever asks only whether a budget holds."""
    d = Decisions(graph)
    twin, alias = float_twin(graph)
    fixed, flt = CompiledGraph(graph, "fixed", like=like), CompiledGraph(twin, "float")
    fixed_pos = {graph.nodes[i].name: p for p, i in enumerate(state_indices(graph))}
    # the states seen over ``stop_above`` by any run; once one is, every run stops at its next piece
    halt = _Halt(dict(stop_above or {}))
    calls = [lambda t=t, u=u, name=name: _compare_one(d, fixed, flt, alias, fixed_pos, name, t, u, dt, chunk, plain,
                                                      halt)
             for name, (t, u) in stimuli.items()]
    return dict(zip(stimuli, run_side_by_side(calls)))


class _Halt:
    """What the runs of one comparison share: the states any of them found over ``limits``."""

    def __init__(self, limits: dict):
        self.limits, self.over = limits, set()

    def update(self, worst: dict) -> bool:
        """Note the states of ``worst`` (a run's errors so far) over their limits; whether to stop."""
        self.over |= {s for s, limit in self.limits.items() if worst.get(s, 0.0) > limit}
        return bool(self.over)


def _compare_one(d: Decisions, fixed, flt, alias, fixed_pos, name, t, u, dt, chunk, with_plain,
                 halt: _Halt) -> SegmentedRun:
    graph = fixed.graph
    u, t = np.asarray(u, float), np.asarray(t, float)
    u_steps = per_step(u, t, dt)
    n_steps = len(u_steps)
    outs = {s: graph.output(s).name for s in d.states}
    lsb = {s: graph[outs[s]].qformat.lsb for s in d.states}
    cols = tuple(outs.values())
    fixed_ins = per_step_integers(u, t, dt, next(n.qformat for n in graph.of_kind(Kind.INPUT)))[None, :]
    plain = _Lane(fixed, fixed_ins, cols) if with_plain else None
    seg = _Lane(fixed, fixed_ins, cols + d.selects)
    # the float twin is never restarted: one run, recording what a restart loads too
    ref = _Lane(flt, u_steps[None, :], tuple(dict.fromkeys(
        tuple(alias.get(c, c) for c in cols) + d.selects + tuple(alias.get(r, r) for r in d.registers))))
    worst_plain, worst_seg = dict.fromkeys(d.states, 0.0), dict.fromkeys(d.states, 0.0)
    registers = [(fixed_pos[r], alias.get(r, r), graph[r].qformat) for r in d.registers]   # what a restart loads
    restarts, was_differing, piece = [], False, chunk
    stopped = None
    for k in range(0, n_steps, chunk):
        if stopped is not None:
            break
        n = min(chunk, n_steps - k)
        b = ref.run(k, n)
        truth = {s: b[alias.get(outs[s], outs[s])] for s in d.states}
        if plain is not None:
            p = plain.run(k, n)
            for s in d.states:
                worst_plain[s] = max(worst_plain[s], float(np.max(np.abs(p[outs[s]] * lsb[s] - truth[s]))))
        at = 0                     # the segmented run's position within this chunk
        while at < n:
            m = min(piece, n - at)
            saved, saved_ov = seg.st.copy(), seg.ov.copy()
            a = seg.run(k + at, m)
            differ = d.differ({c: a[c] for c in d.selects}, {c: b[c][at:at + m] for c in d.selects}, m)
            onset = differ & ~np.concatenate(([was_differing], differ[:-1]))
            hits = np.flatnonzero(onset)
            # the decision's row still holds the state before it acts: it ends this segment
            end = int(hits[0]) if hits.size else m
            rows = end + 1 if hits.size else end
            for s in d.states:
                err = np.abs(a[outs[s]][:rows] * lsb[s] - truth[s][at:at + rows])
                worst_seg[s] = max(worst_seg[s], float(np.max(err)))
            if halt.limits and halt.update(worst_seg):
                stopped = k + at + rows
                break
            if not hits.size:
                at, was_differing, piece = at + m, bool(differ[-1]), min(2 * piece, chunk)
                continue
            # to the decision's step, and on from the float twin's registers there; a difference
            # that persists from that same state is the arithmetic's own decision: no new restart
            seg.st[:], seg.ov[:] = saved, saved_ov
            if end:
                seg.run(k + at, end, record=False)
            for pos, twin_name, fmt in registers:
                seg.st[pos] = fmt.from_float(float(b[twin_name][at + end]))
            restarts.append(k + at + end)
            # decisions that differed once tend to again soon (a cart chattering about zero
            # velocity): the next pieces are short, so a restart re-runs little
            at, was_differing, piece = at + end, True, FIRST_PIECE
        _check_overflow(graph, name, *(lane for lane in (plain, seg) if lane is not None))
    return SegmentedRun(plain=worst_plain if with_plain else None, segmented=worst_seg, restarts=len(restarts),
                        restart_steps=tuple(restarts[:5]), steps=n_steps, stopped_at=stopped)


def _check_overflow(graph: Graph, stimulus: str, *lanes) -> None:
    for lane in lanes:
        hit = {graph.nodes[int(i)].name: int(lane.ov[i]) for i in np.flatnonzero(lane.ov >= 0)}
        if hit:
            node, step = min(hit.items(), key=lambda kv: (kv[1], kv[0]))
            raise BudgetError(f"node '{node}' left its range at step {step} of stimulus '{stimulus}': the "
                              f"training ranges do not cover it (raise margin_bits or override its range)")
