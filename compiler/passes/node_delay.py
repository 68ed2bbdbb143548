"""Estimated routed delay of one node's logic under a :class:`~pendc.passes.delays.DelayModel`
(one visitor method per kind), and of a table's interpolation: what the scheduler
(:mod:`pendc.passes.schedule`) chains into cycles and :mod:`pendc.passes.step_bound` sums."""

from __future__ import annotations

from ..ir.graph import Graph
from ..ir.nodes import Kind
from ..ir.qformat import QFormat, Rounding
from ..ir.visitor import NodeVisitor
from .delays import ECP5_SPEED6, DelayModel
from .resources import dsp_for, product_widths


class NodeDelay(NodeVisitor):
    """Estimated routed delay of a node's own logic (ns), one method per kind; tables: the
    address part. Built for one graph, delay model and multiplier shape."""

    def __init__(self, graph: Graph, model: DelayModel = ECP5_SPEED6, shape: tuple = (18, 18)):
        self.graph, self.model, self.shape = graph, model, shape

    def _inputs(self, n) -> list:
        return [self.graph[i].qformat for i in n.inputs]

    def _requant(self, n) -> float:
        """The rounding adder of a node whose inputs carry more fraction bits than its output."""
        ins = self._inputs(n)
        rounds = any(q.frac > n.qformat.frac for q in ins)
        return self.model.add(max(q.width for q in ins)) if rounds else 0.0

    def _product(self, n, coefficient_frac: int) -> float:
        wa, wb = product_widths(self.graph, n)
        # the rounding constant is added to the full product before it is cut to the output format
        frac = self._inputs(n)[0].frac + coefficient_frac
        return (self.model.product(wa, wb, dsp_for(wa, wb, self.shape))
                + (self.model.add(wa + wb) if frac > n.qformat.frac else 0.0))

    def _adder(self, n) -> float:
        return self.model.add(max(q.width for q in self._inputs(n)) + 1) + self._requant(n)

    def _source(self, n) -> float:
        return 0.0

    visit_const = visit_input = visit_register = visit_fsm = visit_slice = _source
    visit_add = visit_sub = visit_neg = _adder

    def visit_gain(self, n) -> float:
        return self._product(n, QFormat.parse(n.param("cfmt")).frac)

    def visit_mul(self, n) -> float:
        return self._product(n, self._inputs(n)[1].frac)

    def visit_compare(self, n) -> float:
        # a comparison's flag is never rounded (pendc.backend.viewmodel.visit_compare aligns its inputs)
        return self.model.add(max(q.width for q in self._inputs(n)) + 1)

    def visit_cast(self, n) -> float:
        return self._requant(n)

    def visit_mux(self, n) -> float:
        return self.model.mux(len(n.inputs) - 1) + self._requant(n)

    def visit_lut(self, n) -> float:
        # address: offset subtraction, then a clamp unless the table wraps
        return self.model.add(self._inputs(n)[0].width + 1) + (0.0 if n.param("periodic") else self.model.mux(3))


def node_delay(graph: Graph, n, model: DelayModel = ECP5_SPEED6, shape: tuple = (18, 18)) -> float:
    """Estimated routed delay of a node's own logic (ns); tables: the address part (:class:`NodeDelay`)."""
    return NodeDelay(graph, model, shape).visit(n)


def interp_delay(graph: Graph, n, model: DelayModel = ECP5_SPEED6, shape: tuple = (18, 18)) -> float:
    """A table's slope x fraction product, its rounding and the sum with the entry."""
    widths = product_widths(graph, n)
    if widths is None:
        return 0.0
    wa, wb = widths
    return model.product(wa, wb, dsp_for(wa, wb, shape)) + model.add(wa + wb) + model.add(n.qformat.width + 1)


def requant_can_overflow(q: QFormat, out: QFormat, rounding: Rounding) -> bool:
    """Whether a value of format ``q`` fitted into ``out`` can leave it, as
    :func:`pendc.backend.arith.requantize` decides when it emits an overflow term."""
    width = q.width + (0 if q.signed else 1)
    sh = q.frac - out.frac
    if sh > 0:
        rw = max(width, sh) + 1 if rounding is Rounding.NEAREST else width
        width = rw - sh if sh < rw else 1
    elif sh < 0:
        width -= sh
    return width > out.width if out.signed else (width > out.width or q.signed)


def overflow_term(graph: Graph, n) -> bool:
    """Whether ``n`` carries an overflow term (a LUT level after it into the sticky flag, see
    pendc.backend.timing): not sources, compares and bit slices; a select or a cast only if one
    of its inputs can leave the output's format (a clamp's muxes of one format cannot);
    every other kind is assumed to."""
    if n.kind in (Kind.CONST, Kind.INPUT, Kind.REGISTER, Kind.FSM, Kind.COMPARE, Kind.SLICE):
        return False
    if n.kind in (Kind.MUX, Kind.CAST) and n.qformat is not None:
        data = n.inputs[1:] if n.kind is Kind.MUX else n.inputs
        return any(requant_can_overflow(graph[i].qformat, n.qformat, n.rounding) for i in data)
    return True
