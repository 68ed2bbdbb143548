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

BRAM_BITS = 36 * 1024


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
    A LUT's is its interpolation: slope (entry difference) x fraction (plus a zero sign bit)."""
    if n.kind is Kind.GAIN:
        wa, wb = graph[n.inputs[0]].qformat.width, QFormat.parse(n.param("cfmt")).width
    elif n.kind is Kind.MUL:
        wa, wb = graph[n.inputs[0]].qformat.width, graph[n.inputs[1]].qformat.width
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
    dsp = dsp18 = lut_bits = brams = reg_bits = adders = adder_bits = muxes = cmps = luts = 0
    for n in graph.nodes:
        w = n.qformat.width
        widths = product_widths(graph, n)
        if widths is not None:
            wa, wb = widths
            mults[f"{wa}x{wb}"] += 1
            dsp += dsp_for(wa, wb, shape)
            dsp18 += dsp18_for(wa, wb)
            products.append({"node": n.name, "kind": n.kind.value, "widths": f"{wa}x{wb}",
                             "dsp": dsp_for(wa, wb, shape)})
        if n.kind in (Kind.MUL, Kind.GAIN):
            pass
        elif n.kind is Kind.LUT:
            bits = len(n.param("table")) * w
            lut_bits += bits
            brams += math.ceil(bits / BRAM_BITS)
            luts += 1
        elif n.kind is Kind.REGISTER:
            reg_bits += w
        elif n.kind is Kind.FSM:
            reg_bits += max(1, (len(n.param("states")) - 1).bit_length())
        elif n.kind in (Kind.ADD, Kind.SUB, Kind.NEG):
            adders += 1
            adder_bits += w
        elif n.kind is Kind.MUX:
            muxes += 1
        elif n.kind is Kind.COMPARE:
            cmps += 1
    depth, path = longest_path(graph)
    return Resources(multipliers=dict(sorted(mults.items())), dsp18=dsp18, lut_bits=lut_bits, brams=brams,
                     register_bits=reg_bits, adders=adders, adder_bits=adder_bits, muxes=muxes,
                     comparators=cmps, luts=luts, logic_depth=depth, critical_path=path,
                     dsp=dsp, dsp_shape=f"{shape[0]}x{shape[1]}", products=tuple(products))


_FREE = (Kind.CONST, Kind.INPUT, Kind.REGISTER, Kind.FSM, Kind.SLICE, Kind.CAST)


def longest_path(graph: Graph) -> tuple[int, tuple]:
    """Longest chain of logic nodes between state elements (slices and casts are wiring)."""
    depth: dict = {}
    prev: dict = {}
    for n in graph.nodes:                       # evaluation order is topological
        if n.kind in (Kind.CONST, Kind.INPUT, Kind.REGISTER, Kind.FSM):
            depth[n.name], prev[n.name] = 0, None
            continue
        best = max(n.inputs, key=lambda i: depth[i])
        depth[n.name] = depth[best] + (0 if n.kind in _FREE else 1)
        prev[n.name] = best
    end = max(depth, key=lambda k: (depth[k], k)) if depth else None
    path = []
    while end is not None:
        path.append(end)
        end = prev[end]
    return (depth[path[0]] if path else 0), tuple(reversed(path))
