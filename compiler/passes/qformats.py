"""Q-format assignment by the thesis' rules (§4.2), plus the widening the error budget asks for.

Rules (thesis section 4.2, spec §5):
* every constant has at least 32 bits: integer bits from its own magnitude, the rest fraction;
* a variable of width n with simulated maximum max|v| gets i = ceil(log2(max|v|)) integer
  bits, one more because it is signed, and n - i fraction bits; ``margin_bits`` adds
  headroom above the simulated maximum (the thesis used none);
* flags (compare results, bit slices, FSM outputs) are unsigned integers of their width;
* a register has exactly the format of the value it stores.
Per-node overrides (``qformat`` from the model file) win over the rules, and
``widen`` (node -> extra fraction bits) is how :mod:`error_budget` buys precision for
accumulators. Multiplier operands wider than 32 bits get a CAST to 32 bits in front.
"""

from __future__ import annotations

from ..ir.fsm import output_width
from ..ir.graph import Graph
from ..ir.nodes import Kind, make
from ..ir.qformat import QFormat, bits_for
from .ranges import Ranges

CONST_BITS = 32
MULT_OPERAND_BITS = 32
MAX_WIDTH = 60   # an aligned sum of two such values still fits the 64-bit golden model


def thesis_format(max_abs: float, width: int = 32, margin_bits: int = 0) -> QFormat:
    """Signed format of ``width`` bits for a value whose maximum magnitude is ``max_abs``."""
    ib = bits_for(max_abs * 2.0**margin_bits, signed=True)
    return QFormat(True, width, width - ib)


def _fixed_format(node, graph) -> QFormat | None:
    if node.kind is Kind.COMPARE:
        return QFormat(False, 1, 0)
    if node.kind is Kind.SLICE:
        hi, lo = node.param("hi"), node.param("lo")
        return QFormat(False, 1 if hi == lo == -1 else hi - lo + 1, 0)
    if node.kind is Kind.FSM:
        return QFormat(False, output_width(node.param("outputs")), 0)
    if node.kind is Kind.CONST:
        return thesis_format(abs(node.param("value")), CONST_BITS)
    return None


def assign_qformats(graph: Graph, ranges: Ranges, width: int = 32, margin_bits: int = 0,
                    overrides: dict | None = None, widen: dict | None = None) -> Graph:
    """Type every node (see module docstring); returns a new graph."""
    overrides = {k: QFormat.parse(v) if isinstance(v, str) else v for k, v in (overrides or {}).items()}
    unknown = set(overrides) - set(graph.by_name)
    if unknown:
        raise ValueError(f"Q-format override for unknown node(s): {', '.join(sorted(unknown))}")
    widen = dict(widen or {})
    stored_by = {n.inputs[0]: n.name for n in graph.of_kind(Kind.REGISTER)}
    for reg in graph.of_kind(Kind.REGISTER):    # the whole accumulation path gets the guard bits
        for name in accumulator_chain(graph, reg.name):
            if reg.name in widen and name not in widen:
                widen[name] = widen[reg.name]

    def magnitude(node) -> float:
        m = ranges.max_abs.get(node.name, 0.0)
        if node.kind is Kind.LUT:
            m = max(m, node.param("fmax", 0.0))
        if node.kind is Kind.INPUT:
            m = max(m, node.param("max_abs", 0.0))
        if node.name in stored_by:       # a register's input and the register share one format
            m = max(m, ranges.max_abs.get(stored_by[node.name], 0.0))
        return m

    formats = {}
    for node in graph.nodes:
        fmt = _fixed_format(node, graph)
        if fmt is None and node.kind is not Kind.REGISTER:
            fmt = thesis_format(magnitude(node), width, margin_bits)
        if fmt is not None:
            extra = widen.get(node.name, 0) or widen.get(stored_by.get(node.name, ""), 0)
            if extra and node.kind not in (Kind.COMPARE, Kind.SLICE, Kind.FSM):
                extra = min(extra, MAX_WIDTH - fmt.width)
                fmt = QFormat(fmt.signed, fmt.width + extra, fmt.frac + extra)
        formats[node.name] = overrides.get(node.name, fmt)
    for node in graph.of_kind(Kind.REGISTER):
        formats[node.name] = overrides.get(node.name, formats[node.inputs[0]])
        if formats[node.name] != formats[node.inputs[0]]:
            formats[node.inputs[0]] = formats[node.name]

    def typed(node):
        n = node.typed(formats[node.name])
        if n.kind is Kind.GAIN:
            n = n.with_params(cfmt=str(thesis_format(abs(n.param("value")), CONST_BITS)))
        return n

    return _narrow_multiplier_operands(graph.map_nodes(typed))


def accumulator_chain(graph: Graph, register: str) -> list:
    """Nodes between a register's stored value and the sum that updates it: the register's
    input, then back through mux data inputs and casts (a clamp) to the ADD/SUB that reads
    the register. Widening only the register would round the sum before it is stored."""
    chain, todo = [], [graph[register].inputs[0]]
    while todo:
        name = todo.pop()
        node = graph[name]
        if name in chain or node.kind in (Kind.CONST, Kind.REGISTER):
            continue
        chain.append(name)
        if node.kind is Kind.MUX:
            todo.extend(node.inputs[1:])
        elif node.kind is Kind.CAST:
            todo.append(node.inputs[0])
    return chain


def _narrow_multiplier_operands(graph: Graph) -> Graph:
    """Insert a CAST to 32 bits in front of every multiplier operand that is wider."""
    casts, nodes = {}, []
    for node in graph.nodes:
        if node.kind in (Kind.GAIN, Kind.MUL):
            inputs = []
            for i in node.inputs:
                src = graph[i]
                if src.qformat.width > MULT_OPERAND_BITS:
                    if i not in casts:
                        fmt = src.qformat
                        narrow = QFormat(fmt.signed, MULT_OPERAND_BITS, fmt.frac - (fmt.width - MULT_OPERAND_BITS))
                        casts[i] = make(f"{i}_m", Kind.CAST, [i], qformat=narrow,
                                        meaning=f"{i} narrowed for a multiplier")
                    inputs.append(casts[i].name)
                else:
                    inputs.append(i)
            node = make(node.name, node.kind, inputs, node.meaning, node.qformat, node.rounding,
                        node.overflow, **dict(node.params))
        nodes.append(node)
    if not casts:
        return graph
    return graph.with_nodes(nodes + list(casts.values()))
