"""The shortest step any schedule of a graph can reach under the delay model: its critical chain.

Steps do not overlap (``ready`` is low for ``ii`` cycles), so a step lasts at least as long
as the longest register-to-register path through one step's arithmetic: the launching
flip-flop's clock-to-out, every node's routed delay (:func:`pendc.passes.node_delay.node_delay`),
a table read's address, the capturing block RAM's setup and its clock-to-out, the
interpolation, and the setup of the state register at the end. A schedule only adds to that
(a flip-flop per cycle boundary, cycles that end early because the next operation does
not fit), so ``step_bound(graph) <= schedule.estimated_step_ns`` for every schedule: the
bound says how much a better schedule could still win and which chain blocks the rest.

Two what-ifs price changes that no schedule can make, to tell what would be needed:

* ``lookahead``: tables whose value for step n+1 is read during step n from the next state
  (a retiming of the table across the state register); they start the step as registers,
  and their own path (the next state, the address chain again, the read) must fit the step;
* ``one_block``: every product priced as a single DSP block (narrower operands; the
  error budget, not the schedule, decides whether that is allowed).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..ir.graph import Graph
from ..ir.nodes import Kind
from .delays import ECP5_SPEED6, DelayModel
from .resources import product_widths
from .node_delay import interp_delay, node_delay
from .schedule import SOURCES


@dataclass(frozen=True)
class StepBound:
    """``bound_ns``: the longest path of one step (model ns); ``path``: its nodes, source first,
    each with the model time its value is ready (ns after the step's clock edge)."""

    bound_ns: float
    path: tuple            # ((node, ready ns), ...)
    ends: dict             # state register -> model ns at which its next value is ready

    def to_json(self) -> dict:
        return {"bound_ns": self.bound_ns, "path": [list(p) for p in self.path], "ends": self.ends}


def table_cone(graph: Graph, lut: str) -> set:
    """The state registers a table's address is computed from."""
    seen, todo, regs = set(), [graph[lut].inputs[0]], set()
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        node = graph[name]
        if node.kind in (Kind.REGISTER, Kind.FSM):
            regs.add(name)
        elif node.kind not in SOURCES:
            todo.extend(node.inputs)
    return regs


def step_bound(graph: Graph, model: DelayModel = ECP5_SPEED6, shape: tuple = (18, 18),
               lookahead: tuple = (), one_block: bool = False) -> StepBound:
    """The critical chain of one step of a typed ``graph`` (see the module doc)."""
    if one_block:
        model = replace(model, mul_two=model.mul_one, mul_four=model.mul_one)
    ready, pred, ends = _times(graph, model, shape, frozenset())
    if lookahead:
        # the read for the next step: the latest next state of the table's address cone, then the
        # table's own chain from the registers again, into the table's register
        own = {f"{name} (next step)": round(max((ends[r] - model.setup for r in table_cone(graph, name)),
                                                default=model.clk_to_q) - model.clk_to_q + ready[name]
                                            + model.setup, 2) for name in lookahead}
        ready, pred, ends = _times(graph, model, shape, frozenset(lookahead))
        ends = {**ends, **own}
    worst = max(ends, key=lambda r: (ends[r], r))
    if worst not in graph:
        return StepBound(ends[worst], ((worst, ends[worst]),), ends)
    path, x = [], graph[worst].inputs[0]
    while x is not None:
        path.append((x, round(ready[x], 2)))
        x = pred[x]
    return StepBound(ends[worst], tuple(reversed(path)), ends)


def _times(graph: Graph, model: DelayModel, shape: tuple, registered: frozenset) -> tuple:
    """(ready, pred, ends): when every node's value is ready (model ns after the clock edge),
    the input its longest path comes through, and when each state's next value is captured;
    the nodes of ``registered`` start the step as registers."""
    ready, pred = {}, {}
    for n in graph.nodes:
        if n.kind in SOURCES or n.name in registered:
            ready[n.name], pred[n.name] = (0.0 if n.kind is Kind.CONST else model.clk_to_q), None
            continue
        src = max(n.inputs, key=lambda i: ready[i]) if n.inputs else None
        d = node_delay(graph, n, model, shape)
        if n.kind is Kind.LUT:      # address, block RAM setup and clock-to-out, interpolation
            d += model.setup + model.rom_clk_to_out + interp_delay(graph, n, model, shape)
        ready[n.name], pred[n.name] = (ready[src] if src is not None else 0.0) + d, src
    ends = {r.name: round(ready[r.inputs[0]] + model.setup, 2) for r in graph.of_kind(Kind.REGISTER, Kind.FSM)}
    return ready, pred, ends


def periodic_tables(graph: Graph) -> tuple:
    """Tables of periodic states (their address never depends on this step's accelerations):
    the candidates of a lookahead read; a table already read a step ahead (into a register,
    the short chain's ``lookahead``) is not one."""
    ahead = {r.inputs[0] for r in graph.of_kind(Kind.REGISTER)}
    return tuple(n.name for n in graph.of_kind(Kind.LUT) if n.param("periodic") and n.name not in ahead)


def products_on(graph: Graph, path: tuple) -> list:
    """The products (with their operand widths) on a path of :class:`StepBound`."""
    return [(name, product_widths(graph, graph[name])) for name, _ in path
            if product_widths(graph, graph[name]) is not None]
