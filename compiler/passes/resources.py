"""Resource estimate of a typed graph: what an FPGA engineer asks before synthesis.

Counts multipliers by operand width and their cost in 18x18 DSP blocks, table bits
and 36-kbit block RAMs, register bits, adders, muxes and comparators, and the longest
combinational path (in nodes, with the path itself, since it sets Fmax at one step
per clock). These are estimates from the graph; the backend's synthesis check gives
the real numbers.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass

from ..ir.graph import Graph
from ..ir.nodes import Kind
from ..ir.qformat import QFormat
from ..ir.visitor import NodeVisitor

BRAM_BITS = 36 * 1024
# ECP5 DP16KD aspect ratios (depth, width): a table word (entry and stored slope) in the cheapest
DP16KD = ((16384, 1), (8192, 2), (4096, 4), (2048, 9), (1024, 18), (512, 36))


@dataclass(frozen=True)
class Resources:
    multipliers: dict          # "WxW" -> count (operand widths, wider first)
    dsp18: int                 # estimated 18x18 DSP blocks
    lut_bits: int              # ROM bits of all tables
    brams: int                 # 36-kbit block RAMs if each table gets its own
    register_bits: int         # state registers + FSM state registers
    adders: int                # add/sub/neg (each a carry chain)
    adder_bits: int
    muxes: int
    comparators: int
    luts: int                  # number of tables
    logic_depth: int           # nodes on the longest combinational path
    critical_path: tuple       # that path, source first
    dsp: int = 0               # DSP blocks of the target's shape
    dsp_shape: str = "18x18"   # signed operand widths of one block
    products: tuple = ()       # per product: node, kind, operand widths, DSP blocks
    lut4_est: int = 0          # fabric LUT4s of the arithmetic (fabric_estimate)
    carry_est: int = 0         # 2-bit carry cells
    bram16: int = 0            # 16-kbit block RAMs (ECP5 DP16KD), the table word in its cheapest shape

    def to_json(self) -> dict:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.__dict__.items()}


def dsp18_for(wa: int, wb: int) -> int:
    """18x18 signed DSP blocks for a wa x wb signed product (17-bit partial products)."""
    return dsp_for(wa, wb, (18, 18))


def dsp_for(wa: int, wb: int, shape: tuple) -> int:
    """DSP blocks of signed operand widths ``shape`` for a wa x wb signed product: the
    operands split into (width - 1)-bit partial products, in the cheaper orientation."""
    a, b = shape

    def tiles(x, y):
        return math.ceil(max(x - 1, 1) / (a - 1)) * math.ceil(max(y - 1, 1) / (b - 1))

    return min(tiles(wa, wb), tiles(wb, wa))


def product_widths(graph: Graph, n) -> tuple | None:
    """Signed operand widths (wider first) of the multiplier a node needs, or None.
    A LUT's is its interpolation: slope (entry difference) x fraction (plus a zero sign bit).
    Worked out once per graph (``graph.memo``) for the graph's own nodes."""
    if graph.by_name.get(n.name) is not n:
        return _product_widths(graph, n)
    widths = graph.memo.setdefault("product_widths", {})
    if n.name not in widths:
        widths[n.name] = _product_widths(graph, n)
    return widths[n.name]


def _product_widths(graph: Graph, n) -> tuple | None:
    def signed_width(name):   # an unsigned operand enters a signed multiplier with a zero sign bit
        f = graph[name].qformat
        return f.width + (0 if f.signed else 1)

    if n.kind is Kind.GAIN:
        wa, wb = signed_width(n.inputs[0]), QFormat.parse(n.param("cfmt")).width
    elif n.kind is Kind.MUL:
        wa, wb = signed_width(n.inputs[0]), signed_width(n.inputs[1])
    elif n.kind is Kind.LUT and n.param("interpolate") and n.param("shift") and n.param("table"):
        wa, wb = slope_bits(n.param("table")), n.param("shift") + 1
    else:
        return None
    return max(wa, wb), min(wa, wb)


def slope_bits(table) -> int:
    """Signed bits of the largest difference between neighbouring entries (the stored slope)."""
    diffs = [b - a for a, b in zip(table, table[1:])] or [0]
    lo, hi = min(diffs), max(diffs)
    return max(2, max(hi.bit_length(), (-lo - 1).bit_length() if lo < 0 else 0) + 1)


def estimate_resources(graph: Graph, shape: tuple = (18, 18)) -> Resources:
    """Count resources of a typed graph (every node has a Q-format); DSP blocks of ``shape``."""
    mults: Counter = Counter()
    products = []
    tally: Counter = Counter()
    counter = _ResourceCount()
    for n in graph.nodes:
        widths = product_widths(graph, n)
        if widths is not None:
            wa, wb = widths
            mults[f"{wa}x{wb}"] += 1
            tally["dsp"] += dsp_for(wa, wb, shape)
            tally["dsp18"] += dsp18_for(wa, wb)
            products.append({"node": n.name, "kind": n.kind.value, "widths": f"{wa}x{wb}",
                             "dsp": dsp_for(wa, wb, shape)})
        tally.update(counter.visit(n))
    depth, path = longest_path(graph)
    fabric = fabric_estimate(graph)
    return Resources(multipliers=dict(sorted(mults.items())), dsp18=tally["dsp18"], lut_bits=tally["lut_bits"],
                     brams=tally["brams"], register_bits=tally["register_bits"], adders=tally["adders"],
                     adder_bits=tally["adder_bits"], muxes=tally["muxes"], comparators=tally["comparators"],
                     luts=tally["luts"], logic_depth=depth, critical_path=path,
                     dsp=tally["dsp"], dsp_shape=f"{shape[0]}x{shape[1]}", products=tuple(products),
                     lut4_est=fabric["lut4"], carry_est=fabric["carry"], bram16=tally["bram16"])


class _ResourceCount(NodeVisitor):
    """Per kind, what one typed node adds to the tally of :func:`estimate_resources` (its
    multiplier, counted from :func:`product_widths` for every kind, aside)."""

    def _nothing(self, n) -> dict:
        return {}

    # products are counted by product_widths; constants, inputs, slices and casts are wiring
    visit_const = visit_input = visit_gain = visit_mul = visit_slice = visit_cast = _nothing

    def visit_lut(self, n) -> dict:
        w = n.qformat.width
        table = n.param("table")
        bits = len(table) * w
        word = w + (slope_bits(table) if n.param("interpolate") else 0)
        entries = len(table)
        if entries & (entries - 1) and entries - (1 << (entries.bit_length() - 1)) <= 32:
            entries = 1 << (entries.bit_length() - 1)   # Yosys keeps the interpolation's extra entry in logic
        return {"lut_bits": bits, "brams": math.ceil(bits / BRAM_BITS), "luts": 1,
                "bram16": min(math.ceil(entries / d) * math.ceil(word / wd) for d, wd in DP16KD)}

    def visit_register(self, n) -> dict:
        return {"register_bits": n.qformat.width}

    def visit_fsm(self, n) -> dict:
        return {"register_bits": max(1, (len(n.param("states")) - 1).bit_length())}

    def _adder(self, n) -> dict:
        return {"adders": 1, "adder_bits": n.qformat.width}

    visit_add = visit_sub = visit_neg = _adder

    def visit_mux(self, n) -> dict:
        return {"muxes": 1}

    def visit_compare(self, n) -> dict:
        return {"comparators": 1}


class _PathCost(NodeVisitor):
    """Per kind, a node's length on a combinational path: None for a state element or source
    (a path starts there), 0 for wiring (slices and casts), 1 for logic."""

    def _source(self, n):
        return None

    def _wiring(self, n):
        return 0

    def _logic(self, n):
        return 1

    visit_const = visit_input = visit_register = visit_fsm = _source
    visit_slice = visit_cast = _wiring
    visit_gain = visit_add = visit_sub = visit_neg = visit_mul = visit_lut = visit_mux = visit_compare = _logic


def longest_path(graph: Graph) -> tuple[int, tuple]:
    """Longest chain of logic nodes between state elements (slices and casts are wiring)."""
    depth: dict = {}
    prev: dict = {}
    cost = _PathCost()
    for n in graph.nodes:                       # evaluation order is topological
        length = cost.visit(n)
        if length is None:
            depth[n.name], prev[n.name] = 0, None
            continue
        best = max(n.inputs, key=lambda i: depth[i])
        depth[n.name] = depth[best] + length
        prev[n.name] = best
    end = max(depth, key=lambda k: (depth[k], k)) if depth else None
    path = []
    while end is not None:
        path.append(end)
        end = prev[end]
    return (depth[path[0]] if path else 0), tuple(reversed(path))


def _carry_cells(width: int) -> int:
    """2-bit carry cells (ECP5 CCU2C) of a ripple adder of ``width`` bits."""
    return (width + 2) // 2


class _FabricCost(NodeVisitor):
    """Per kind, ``{"lut4": n, "carry": n}`` of one typed node in the fabric, as
    :func:`fabric_estimate` describes."""

    def _free(self, n, graph) -> dict:
        return {}

    # sources, state registers' flip-flops and bit selections cost no LUT4 or carry cell
    visit_const = visit_input = visit_register = visit_slice = _free

    @staticmethod
    def _aligned(n, graph) -> tuple:
        """(fraction bits, width) of the inputs of a sum or compare aligned on their binary point."""
        ins = [graph[i].qformat for i in n.inputs]
        frac = max(q.frac for q in ins)
        return frac, max(q.width - q.frac for q in ins) + frac + 1

    def visit_compare(self, n, graph) -> dict:
        return {"carry": _carry_cells(self._aligned(n, graph)[1])}

    def _sum(self, n, graph) -> dict:
        # the sum's carry chain, then its rounding to the output's fraction and its range check
        frac, width = self._aligned(n, graph)
        out = n.qformat
        return {"lut4": (width - out.width + 2) // 3 if width > out.width else 0,
                "carry": _carry_cells(width) + (_carry_cells(width + 1) if frac > out.frac else 0)}

    visit_add = visit_sub = _sum

    def visit_neg(self, n, graph) -> dict:
        return {"carry": _carry_cells(n.qformat.width + 1)}

    def visit_cast(self, n, graph) -> dict:
        fin, out = graph[n.inputs[0]].qformat, n.qformat
        carry = _carry_cells(fin.width + 1) if fin.frac > out.frac else 0
        dropped = (fin.width - fin.frac) - (out.width - out.frac)
        return {"lut4": (dropped + 2) // 3 if dropped > 0 else 0, "carry": carry}

    def _product(self, n, graph) -> dict:
        wa, wb = product_widths(graph, n)
        tiles = dsp18_for(wa, wb)
        return {"lut4": (wa + wb - n.qformat.width + 2) // 3 if wa + wb > n.qformat.width else 0,
                "carry": (tiles - 1) * _carry_cells(wa + wb) // 2 + _carry_cells(wa + wb)}

    visit_gain = visit_mul = _product

    def visit_mux(self, n, graph) -> dict:
        return {"lut4": n.qformat.width * (len(n.inputs) - 2)}

    def visit_lut(self, n, graph) -> dict:
        carry = _carry_cells(graph[n.inputs[0]].qformat.width + 1)
        lut4 = 0 if n.param("periodic") else 3 * n.param("addr_bits")
        widths = product_widths(graph, n)
        if widths is not None:
            carry += _carry_cells(sum(widths) + 1) + _carry_cells(n.qformat.width + 1)
        return {"lut4": lut4, "carry": carry}

    def visit_fsm(self, n, graph) -> dict:
        return {"lut4": 4 * len(n.param("states")),
                "carry": len(n.param("transitions")) * _carry_cells(graph[n.inputs[0]].qformat.width + 1)}


def fabric_estimate(graph: Graph) -> dict:
    """LUT4s and 2-bit carry cells (ECP5 CCU2C) of a typed graph's adders, roundings, muxes,
    compares and overflow checks, the way ``pendc.backend`` spells them: a ripple adder of w
    bits is ceil(w/2) carry cells, a 2:1 mux one LUT4 per bit, a range check about one LUT4
    per 3 dropped bits; products spread over several DSP blocks add their partial products
    in the fabric. Pipeline registers and shared-multiplier muxes of a schedule are not in
    the graph: ``pendc report synth`` counts those."""
    total: Counter = Counter({"lut4": 0, "carry": 0})
    cost = _FabricCost()
    for n in graph.nodes:
        total.update(cost.visit(n, graph))
    return {"lut4": total["lut4"], "carry": total["carry"]}


def schedule_lut4(schedule: dict) -> dict:
    """LUT4s a schedule (``Schedule.to_json()``, as in report.json) adds to the graph's
    arithmetic: the phase-selected operand muxes of shared multipliers (a unit serving k
    products is a (k-1)-deep 2:1 mux chain per operand bit, one LUT4 per bit and level, as
    Yosys maps the nested ``?:``) and the phase counter and decoders. Pipeline registers cost
    flip-flops only (their load enable is the flip-flop's CE)."""
    units = schedule.get("units") or []
    mux = sum((len(u["uses"]) - 1) * sum(u["widths"]) for u in units)
    ii = int(schedule.get("ii") or 1)
    phase = 0 if ii < 2 else 3 * max(1, (ii - 1).bit_length()) + ii
    return {"unit_mux": mux, "phase": phase, "lut4": mux + phase}
