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
accumulators; a state whose format cannot resolve its own increment gets guard bits first
(:func:`increment_guard_bits`). Multiplier operands wider than 32 bits get a CAST to 32 bits in front, and an
operand of a sum whose fraction would take the aligned sum past 64 bits a CAST that drops it.

Fitting the multipliers (``shape``, the target's signed DSP operand widths, e.g. 18x18 on
ECP5): a product at *level* 0 gets operands (and a GAIN its coefficient) of exactly one
DSP block, a table its output and interpolation fraction such that slope x fraction is
one DSP block too; level 1 widens one side (the coefficient of a GAIN, the first operand
of a MUL, a table's entries back to the thesis' 32 bits) and level 2 both, to 32 bits.
Every product starts at level 0; :mod:`error_budget` raises levels only where the
budget is missed, so the error budget, not a fixed rule, decides the widths.
"""

from __future__ import annotations

from dataclasses import replace

from ..ir.fsm import output_width
from ..ir.graph import Graph
from ..ir.limits import EXACT_BITS, MULT_OPERAND_BITS
from ..ir.nodes import Kind, make
from ..ir.qformat import QFormat, bits_for
from ..ir.visitor import NodeVisitor
from .ranges import Ranges

__all__ = ["CONST_BITS", "INCREMENT_GUARD_BITS", "MAX_LEVEL", "MAX_WIDTH", "MULT_OPERAND_BITS", "MULT_SHAPES",
           "accumulator_chain", "assign_qformats", "increment_guard_bits", "operand_bits", "product_kinds",
           "thesis_format"]

CONST_BITS = 32  # the thesis' rule: every constant has at least 32 bits
MAX_WIDTH = 60   # an aligned sum of two such values still fits the 64-bit golden model
MAX_LEVEL = 2
# signed operand widths of one DSP block: ECP5 MULT18X18D, iCE40 SB_MAC16, Xilinx DSP48E1, DSP48E2
MULT_SHAPES = {"ecp5-85k": (18, 18), "ice40-up5k": (16, 16), "xc7": (25, 18), "xcu": (27, 18)}


def product_kinds():
    """Node kinds that need a multiplier (a LUT's linear interpolation is slope x fraction)."""
    return (Kind.GAIN, Kind.MUL, Kind.LUT)


def operand_bits(node, shape: tuple | None, level: int) -> tuple:
    """(first, second) operand width limits of a product at ``level`` (None: 32-bit rule).
    GAIN: (operand, coefficient); MUL: (a, b); LUT: (output, fraction + sign)."""
    if shape is None or level >= MAX_LEVEL:
        return (MULT_OPERAND_BITS, MULT_OPERAND_BITS)
    big, small = max(shape), min(shape)
    if level == 0:
        return (big, small) if node.kind is not Kind.GAIN else (small, big)
    if node.kind is Kind.GAIN:        # coefficients are systematic errors: widen them first
        return (small, MULT_OPERAND_BITS)
    return (MULT_OPERAND_BITS, small)       # a table: the 32-bit entry, still a one-block fraction


def thesis_format(max_abs: float, width: int = 32, margin_bits: int = 0) -> QFormat:
    """Signed format of ``width`` bits for a value whose maximum magnitude is ``max_abs``."""
    ib = bits_for(max_abs * 2.0**margin_bits, signed=True)
    return QFormat(True, width, width - ib)


class _KindFormat(NodeVisitor):
    """The format a kind fixes by itself (flags, constants), or None where ranges decide."""

    def _ranged(self, node):
        return None

    visit_input = visit_gain = visit_add = visit_sub = visit_neg = visit_mul = _ranged
    visit_register = visit_lut = visit_mux = visit_cast = _ranged

    def visit_compare(self, node):
        return QFormat(False, 1, 0)

    def visit_slice(self, node):
        return QFormat(False, node.params.width, 0)

    def visit_fsm(self, node):
        return QFormat(False, output_width(node.params.outputs), 0)

    def visit_const(self, node):
        return thesis_format(abs(node.params.value), CONST_BITS)


_KIND_FORMAT = _KindFormat()


def assign_qformats(graph: Graph, ranges: Ranges, width: int = 32, margin_bits: int = 0,
                    overrides: dict | None = None, widen: dict | None = None, shape: tuple | None = None,
                    levels: dict | None = None, lsb_ceiling: dict | None = None) -> Graph:
    """Type every node (see module docstring); returns a new graph. ``shape`` (DSP operand
    widths) and ``levels`` (product -> level, default 0) fit products to the multipliers."""
    levels = dict(levels or {})

    def limits(node) -> tuple:
        return operand_bits(node, shape, levels.get(node.name, 0))

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
    for reg, extra in increment_guard_bits(graph, ranges, width, margin_bits, lsb_ceiling).items():
        for name in (reg, *accumulator_chain(graph, reg)):
            widen[name] = max(widen.get(name, 0), extra)

    def magnitude(node) -> float:
        m = ranges.max_abs.get(node.name, 0.0)
        if node.kind is Kind.LUT and node.params.fmax is not None:
            m = max(m, node.params.fmax)
        if node.kind is Kind.INPUT and node.params.max_abs is not None:
            m = max(m, node.params.max_abs)
        if node.name in stored_by:       # a register's input and the register share one format
            m = max(m, ranges.max_abs.get(stored_by[node.name], 0.0))
        return m

    formats = {}
    for node in graph.nodes:
        fmt = _KIND_FORMAT.visit(node)
        if fmt is None and node.kind is not Kind.REGISTER:
            w = min(width, limits(node)[0]) if node.kind is Kind.LUT else width
            fmt = thesis_format(magnitude(node), w, margin_bits)
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
            n = n.with_params(cfmt=thesis_format(abs(n.params.value), min(CONST_BITS, limits(n)[1])))
        return n

    return _fit_aligned_sums(_narrow_multiplier_operands(graph.map_nodes(typed), limits, set(overrides)))


INCREMENT_GUARD_BITS = 8


def increment_guard_bits(graph: Graph, ranges: Ranges, width: int = 32, margin_bits: int = 0,
                         lsb_ceiling: dict | None = None) -> dict:
    """Register -> fraction bits to add so that its LSB is at most 2^-INCREMENT_GUARD_BITS of the
    largest increment its accumulating sum adds (the increment's range): a state whose increment
    per step is about one LSB of its rule's format (a thermal mass at 296 K in FIX32_22, LSB
    2.4e-7 K, heated 5e-7 K a step) rounds every increment to 0 or 1 LSB, a bias that the two
    seconds of the error budget's check runs hide and a minute of heating turns into 4 K. With
    256 LSBs to the largest increment the rounding is at most 0.2 % of the state's motion per
    step at full rate. The shipped plants' states hold their increments in 671 LSBs or more.
    ``lsb_ceiling`` (register -> largest LSB, from ``[hardware] hold_seconds``) adds what a state
    needs for increments far below its largest: a tank near its equilibrium."""
    import math
    out = {}
    for reg in graph.of_kind(Kind.REGISTER):
        chain = set(accumulator_chain(graph, reg.name))
        increments = [i for n in chain if graph[n].kind in (Kind.ADD, Kind.SUB) and reg.name in graph[n].inputs
                      for i in graph[n].inputs if i != reg.name]
        step = max((ranges.max_abs.get(i, 0.0) for i in increments), default=0.0)
        ceiling = (lsb_ceiling or {}).get(reg.name)
        if (step <= 0.0 or not math.isfinite(step)) and ceiling is None:
            continue
        rule = thesis_format(ranges.max_abs.get(reg.name, 0.0), width, margin_bits)
        need = math.ceil(INCREMENT_GUARD_BITS - math.log2(step)) if step > 0.0 and math.isfinite(step) else 0
        if ceiling is not None and ceiling > 0.0:
            need = max(need, math.ceil(-math.log2(ceiling)))
        if need > rule.frac:
            out[reg.name] = min(need - rule.frac, MAX_WIDTH - rule.width)
    return out


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


def _narrow_multiplier_operands(graph: Graph, limits, keep: set = frozenset()) -> Graph:
    """Insert a CAST in front of every multiplier operand wider than its limit (dropping
    fraction bits), and in front of a table input whose interpolation fraction would be. An
    operand whose Q-format the file sets (``keep``: [hardware.qformats]) goes in whole up to a
    multiplier's 32 bits, the multiplier as wide as it (a CSTR's rate table set to FIX32_20 was
    cut back to the DSP word, FIX18_6).

    The plant's input is held for a control period, so rounding it once is an offset over the
    hold that the integrators turn into a drift (issue 23: a held step parted x from its float
    twin by 24 um in 2 s through the 18-bit input operand of the drive force). A narrowed signed
    input therefore carries its rounding residue into the next step's narrowing (error
    feedback): the narrowed values average to the exact input, for a register and two adders
    instead of a wider product. In real arithmetic the residue is zero."""
    from ..ir import lut as lut_sem
    casts, nodes = {}, []

    def narrowed(i: str, bits: int) -> str:
        fmt = graph[i].qformat
        if i in keep:                 # as wide as a multiplier takes (32 bits), not the DSP word
            bits = max(bits, MULT_OPERAND_BITS)
        if fmt.width <= bits:
            return i
        key = (i, bits)
        if key not in casts:
            narrow = QFormat(fmt.signed, bits, fmt.frac - (fmt.width - bits))
            name = f"{i}_m" if bits == MULT_OPERAND_BITS else f"{i}_m{bits}"
            held = graph[i].kind is Kind.INPUT and fmt.signed
            source = _error_feedback(i, name, fmt, narrow, feedback) if held else i
            casts[key] = make(name, Kind.CAST, [source], qformat=narrow,
                              meaning=f"{i} narrowed to {bits} bits for a multiplier"
                              + (" (its rounding residue fed back)" if held else ""))
        return casts[key].name

    feedback = []

    for node in graph.nodes:
        if node.kind in (Kind.GAIN, Kind.MUL):
            lim = limits(node)
            inputs = [narrowed(i, lim[j]) for j, i in enumerate(node.inputs)]
            node = replace(node, inputs=tuple(inputs))
        elif node.kind is Kind.LUT and node.params.interpolate:
            frac_bits = limits(node)[1] - 1           # unsigned fraction beside a sign bit
            fin = graph[node.inputs[0]].qformat
            p = node.params
            shift = lut_sem.grid_shift(p.lo, p.hi, p.addr_bits, fin)
            if shift > frac_bits and fin.width - (shift - frac_bits) >= 2:
                node = replace(node, inputs=(narrowed(node.inputs[0], fin.width - (shift - frac_bits)),))
        nodes.append(node)
    if not casts:
        return graph
    return graph.with_nodes(nodes + feedback + list(casts.values()))


def _fit_aligned_sums(graph: Graph) -> Graph:
    """Insert a CAST that drops fraction bits in front of a sum's (or comparison's) operand whose
    fraction would take the aligned sum past ``EXACT_BITS``: a slow state far from zero (a
    thermal mass at 296 K, whose per-step increment is 1e-9 K) has an increment typed 2^-60 by
    its own range, 71 bits when aligned to the 11 integer bits of the state. The bits dropped
    lie below the sum's own LSB (its width is at most MAX_WIDTH), so the sum loses nothing it
    could hold, bar the rounding of its last bit."""
    casts, nodes = {}, []

    def fitted(i: str, frac: int) -> str:
        fmt = graph[i].qformat
        if fmt.frac <= frac:
            return i
        key = (i, frac)
        if key not in casts:
            narrow = QFormat(fmt.signed, max(2, fmt.width - (fmt.frac - frac)), frac)
            casts[key] = make(f"{i}_f{frac}", Kind.CAST, [i], qformat=narrow,
                              meaning=f"{i} to 2^-{frac}: the sums it enters fit {EXACT_BITS} bits")
        return casts[key].name

    for node in graph.nodes:
        if node.kind in (Kind.ADD, Kind.SUB, Kind.COMPARE):
            fin = [graph[i].qformat for i in node.inputs]
            whole = max(f.width + (0 if f.signed else 1) - f.frac for f in fin)
            frac = EXACT_BITS - 1 - whole           # one bit for the carry
            if max(f.frac for f in fin) > frac:
                node = replace(node, inputs=tuple(fitted(i, frac) for i in node.inputs))
        nodes.append(node)
    if not casts:
        return graph
    return graph.with_nodes(nodes + list(casts.values()))


def _error_feedback(source: str, cast: str, fmt: QFormat, narrow: QFormat, out: list) -> str:
    """Nodes (appended to ``out``) that add the last step's rounding residue of ``cast`` (the
    narrowing of ``source``, format ``fmt``, to ``narrow``) to ``source``; returns the sum's
    name, what ``cast`` narrows. The residue is within half an LSB of ``narrow``; its format
    holds twice that."""
    residue = QFormat(True, fmt.frac - narrow.frac + 2, fmt.frac)
    fed, res = f"{cast}_fed", f"{cast}_res"
    out += [make(fed, Kind.ADD, [source, res], qformat=QFormat(True, fmt.width + 1, fmt.frac),
                 meaning=f"{source} plus the last step's rounding residue of {cast}"),
            make(f"{res}_next", Kind.SUB, [fed, cast], qformat=residue),
            make(res, Kind.REGISTER, [f"{res}_next"], qformat=residue, reset=0.0,
                 meaning=f"rounding residue of {cast}, carried to the next step")]
    return fed
