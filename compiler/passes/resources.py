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

    def to_json(self) -> dict:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.__dict__.items()}


def dsp18_for(wa: int, wb: int) -> int:
    """18x18 signed DSP blocks for a wa x wb signed product (17-bit partial products)."""
    return math.ceil(max(wa - 1, 1) / 17) * math.ceil(max(wb - 1, 1) / 17)


def estimate_resources(graph: Graph) -> Resources:
    """Count resources of a typed graph (every node has a Q-format)."""
    mults: Counter = Counter()
    dsp = lut_bits = brams = reg_bits = adders = adder_bits = muxes = cmps = luts = 0
    for n in graph.nodes:
        w = n.qformat.width
        if n.kind in (Kind.MUL, Kind.GAIN):
            wa = graph[n.inputs[0]].qformat.width
            wb = graph[n.inputs[1]].qformat.width if n.kind is Kind.MUL else QFormat.parse(n.param("cfmt")).width
            wa, wb = max(wa, wb), min(wa, wb)
            mults[f"{wa}x{wb}"] += 1
            dsp += dsp18_for(wa, wb)
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
    return Resources(multipliers=dict(sorted(mults.items())), dsp18=dsp, lut_bits=lut_bits, brams=brams,
                     register_bits=reg_bits, adders=adders, adder_bits=adder_bits, muxes=muxes,
                     comparators=cmps, luts=luts, logic_depth=depth, critical_path=path)


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
