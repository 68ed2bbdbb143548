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
    A LUT's is its interpolation: slope (entry difference) x fraction (plus a zero sign bit)."""
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
    dsp = dsp18 = lut_bits = brams = bram16 = reg_bits = adders = adder_bits = muxes = cmps = luts = 0
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
            word = w + (slope_bits(n.param("table")) if n.param("interpolate") else 0)
            entries = len(n.param("table"))
            if entries & (entries - 1) and entries - (1 << (entries.bit_length() - 1)) <= 32:
                entries = 1 << (entries.bit_length() - 1)   # Yosys keeps the interpolation's extra entry in logic
            bram16 += min(math.ceil(entries / d) * math.ceil(word / wd) for d, wd in DP16KD)
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
    fabric = fabric_estimate(graph)
    return Resources(multipliers=dict(sorted(mults.items())), dsp18=dsp18, lut_bits=lut_bits, brams=brams,
                     register_bits=reg_bits, adders=adders, adder_bits=adder_bits, muxes=muxes,
                     comparators=cmps, luts=luts, logic_depth=depth, critical_path=path,
                     dsp=dsp, dsp_shape=f"{shape[0]}x{shape[1]}", products=tuple(products),
                     lut4_est=fabric["lut4"], carry_est=fabric["carry"], bram16=bram16)


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


def fabric_estimate(graph: Graph) -> dict:
    """LUT4s and 2-bit carry cells (ECP5 CCU2C) of a typed graph's adders, roundings, muxes,
    compares and overflow checks, the way ``pendc.backend`` spells them: a ripple adder of w
    bits is ceil(w/2) carry cells, a 2:1 mux one LUT4 per bit, a range check about one LUT4
    per 3 dropped bits; products spread over several DSP blocks add their partial products
    in the fabric. Pipeline registers and shared-multiplier muxes of a schedule are not in
    the graph: ``pendc report synth`` counts those."""
    carry = lut4 = 0

    def add(width: int) -> int:
        return (width + 2) // 2

    for n in graph.nodes:
        ins = [graph[i].qformat for i in n.inputs]
        out = n.qformat
        k = n.kind
        if k in (Kind.ADD, Kind.SUB, Kind.COMPARE):
            frac = max(q.frac for q in ins)
            width = max(q.width - q.frac for q in ins) + frac + 1
            carry += add(width)
            if k is not Kind.COMPARE:
                carry += add(width + 1) if frac > out.frac else 0
                lut4 += (width - out.width + 2) // 3 if width > out.width else 0
        elif k is Kind.NEG:
            carry += add(out.width + 1)
        elif k is Kind.CAST:
            if ins[0].frac > out.frac:
                carry += add(ins[0].width + 1)
            dropped = (ins[0].width - ins[0].frac) - (out.width - out.frac)
            lut4 += (dropped + 2) // 3 if dropped > 0 else 0
        elif k in (Kind.GAIN, Kind.MUL):
            wa, wb = product_widths(graph, n)
            tiles = dsp18_for(wa, wb)
            carry += (tiles - 1) * add(wa + wb) // 2 + add(wa + wb)
            lut4 += (wa + wb - out.width + 2) // 3 if wa + wb > out.width else 0
        elif k is Kind.MUX:
            lut4 += out.width * (len(n.inputs) - 2)
        elif k is Kind.LUT:
            fin = ins[0]
            carry += add(fin.width + 1)
            if not n.param("periodic"):
                lut4 += 3 * n.param("addr_bits")
            widths = product_widths(graph, n)
            if widths is not None:
                carry += add(sum(widths) + 1) + add(out.width + 1)
        elif k is Kind.FSM:
            carry += len(n.param("transitions")) * add(ins[0].width + 1)
            lut4 += 4 * len(n.param("states"))
    return {"lut4": lut4, "carry": carry}


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
