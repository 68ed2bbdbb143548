"""List scheduling of one model step onto clock cycles: pipelining and multiplier sharing.

The arithmetic of a step never changes, only *when* each node is evaluated, so the
golden model stays bit-exact with every schedule. Steps do not overlap (``ready`` is
low for ``ii`` cycles), hence every value is stable from the cycle it is computed in
until the state updates: a value used in a later cycle than its own is read from a
pipeline register loaded in its cycle.

The scheduler walks the graph in evaluation order (a list scheduler with chaining):
a node starts as soon as its inputs are valid and runs in the same cycle when its
estimated delay still fits the clock goal, else in the next one; a table's address is
read at the end of its cycle (synchronous ROM) and its interpolation runs in the next
(or, if the ROM's clock-to-out plus the interpolation would not fit, one cycle later
from a fabric register). With a DSP budget ``dsp`` that a multiplier per product would
exceed, there are ``dsp // (blocks of the widest product)`` multiplier units, and
products (GAIN, MUL and table interpolations) also wait for a cycle with a free unit;
products in different cycles share a unit, whose operands a phase-selected mux
chooses, so the core never needs more than ``dsp`` blocks. The states, FSMs and overflow flag update at the end of the last cycle.

The delay model (ns, ECP5 speed 6 including typical routing) is deliberately simple;
`pendc report synth` measures the real Fmax.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import PendcError
from ..ir.graph import Graph
from ..ir.nodes import Kind
from ..ir.qformat import QFormat
from .resources import dsp_for, product_widths

T_MULT = 5.0          # one MULT18X18D, combinational, with its routing
T_TILE_SUM = 1.5      # adding the partial products of a multi-block product
T_ROM = 4.0           # DP16KD clock-to-out and routing
T_MUX = 0.8
T_SETUP = 0.5
SOURCES = (Kind.CONST, Kind.INPUT, Kind.REGISTER, Kind.FSM)
PRESETS = {
    # name: (clock goal ns, DSP budget, description)
    "fast": (10.0, None, "shortest step: 100 MHz clock goal, a multiplier per product"),
    "default": (10.0, 24, "100 MHz clock goal within the thesis' 24 multipliers (shared only if needed)"),
    "small": (10.0, 4, "fewest DSP blocks: 4, shared across cycles, 100 MHz clock goal (>= 1 MHz step rate)"),
    "comb": (math.inf, None, "no pipelining: one combinational step between table reads (the thesis' structure)"),
}
DEFAULT_PRESET = "default"


def t_add(width: int) -> float:
    """A ripple-carry adder of ``width`` bits (CCU2C chain)."""
    return 1.0 + 0.045 * width


@dataclass(frozen=True)
class Unit:
    """A multiplier shared by products evaluated in different cycles."""

    name: str
    widths: tuple          # signed operand widths (a >= b)
    uses: tuple            # ((node, cycle), ...)

    def to_json(self) -> dict:
        return {"name": self.name, "widths": list(self.widths), "uses": [list(u) for u in self.uses]}


@dataclass(frozen=True)
class Schedule:
    """When every node runs. ``stage[node]``: the cycle its value is computed in (sources 0);
    ``lut_addr[lut]``: the cycle its ROM address is read; ``rom_reg``: tables whose ROM word is
    registered in the fabric; ``units``: shared multipliers (empty: one multiplier per product)."""

    ii: int
    clock_ns: float
    dsp_budget: int | None
    stage: dict
    lut_addr: dict
    rom_reg: tuple
    units: tuple
    preset: str = ""
    target: str = "ecp5-85k"

    def to_json(self) -> dict:
        return {"ii": self.ii, "preset": self.preset, "target": self.target,
                "clock_goal_ns": None if math.isinf(self.clock_ns) else self.clock_ns,
                "dsp_budget": self.dsp_budget, "rom_registered": list(self.rom_reg),
                "units": [u.to_json() for u in self.units],
                "cycles": {str(c): sorted(n for n, s in self.stage.items() if s == c) for c in range(self.ii)}}


def node_delay(graph: Graph, n) -> float:
    """Estimated combinational delay of a node's own logic (ns); tables: the address part."""
    k = n.kind
    w = n.qformat.width
    ins = [graph[i].qformat for i in n.inputs]
    rounds = any(q.frac > n.qformat.frac for q in ins) if ins else False
    requant = t_add(w) if rounds else 0.0
    if k in (Kind.GAIN, Kind.MUL):
        wa, wb = product_widths(graph, n)
        tiles = dsp_for(wa, wb, (18, 18))
        return T_MULT + (T_TILE_SUM + t_add(wa + wb) if tiles > 1 else 0.0) + requant
    if k in (Kind.ADD, Kind.SUB, Kind.NEG, Kind.COMPARE):
        return t_add(max(q.width for q in ins) + 1) + requant
    if k is Kind.CAST:
        return requant
    if k is Kind.MUX:
        return T_MUX * max(1, math.ceil(math.log2(max(2, len(n.inputs) - 1)))) + requant
    if k is Kind.LUT:
        return t_add(ins[0].width + 1) + (0.0 if n.param("periodic") else T_MUX)
    return 0.0


def interp_delay(graph: Graph, n) -> float:
    """A table's slope x fraction product and the sum with the entry."""
    widths = product_widths(graph, n)
    if widths is None:
        return 0.0
    return T_MULT + 2 * t_add(n.qformat.width + 1)


def _is_product(graph: Graph, n) -> bool:
    return product_widths(graph, n) is not None


def schedule_graph(graph: Graph, clock_ns: float = math.inf, dsp: int | None = None,
                   shape: tuple = (18, 18), preset: str = "", target: str = "ecp5-85k") -> Schedule:
    """List-schedule ``graph`` (typed) for a clock goal and an optional DSP budget (see module doc)."""
    period = clock_ns
    stage, finish, lut_addr, rom_reg = {}, {}, {}, []
    usage: dict = {}
    budget = dsp

    def cost(n) -> int:
        wa, wb = product_widths(graph, n)
        return dsp_for(wa, wb, shape)

    costs = [cost(n) for n in graph.nodes if _is_product(graph, n)]
    if dsp is not None and sum(costs) <= dsp:
        dsp = None        # a multiplier per product already fits the budget: nothing to share
    slots = None
    if dsp is not None:   # units wide enough for any product: the budget holds whatever they serve
        slots = dsp // max(costs)
        if slots < 1:
            raise PendcError(f"the widest product needs {max(costs)} DSP blocks, more than the budget --dsp {dsp}")

    def place(c: int, offset: float, d: float, n=None) -> tuple[int, float]:
        """First (cycle, start) at or after (c, offset) where ``d`` fits and, for a product, DSPs are free."""
        if offset > 0 and offset + d > period:
            c, offset = c + 1, 0.0
        if n is not None and slots is not None:
            while usage.get(c, 0) >= slots:
                c, offset = c + 1, 0.0
            usage[c] = usage.get(c, 0) + 1
        return c, offset

    def ready(inputs) -> tuple[int, float]:
        c = max((stage[i] for i in inputs), default=0)
        return c, max((finish[i] for i in inputs if stage[i] == c), default=0.0)

    for n in graph.nodes:
        if n.kind in SOURCES:
            stage[n.name], finish[n.name] = 0, 0.0
            continue
        c, o = ready(n.inputs)
        d = node_delay(graph, n)
        if n.kind is Kind.LUT:
            c, o = place(c, o, d + T_SETUP)
            lut_addr[n.name] = c
            di = interp_delay(graph, n)
            c, o = c + 1, T_ROM
            if o + di > period:
                rom_reg.append(n.name)
                c, o = c + 1, 0.0
            if di:
                c, o = place(c, o, di, n)
            stage[n.name], finish[n.name] = c, o + di
            continue
        c, o = place(c, o, d, n if _is_product(graph, n) else None)
        stage[n.name], finish[n.name] = c, o + d
    last = 0
    for n in graph.of_kind(Kind.REGISTER, Kind.FSM):
        i = n.inputs[0]
        tail = T_SETUP + (t_add(graph[i].qformat.width + 1) if n.kind is Kind.FSM else 0.0)
        c = stage[i] + (1 if finish[i] > 0 and finish[i] + tail > period else 0)
        last = max(last, c)
    last = max([last] + list(stage.values()))
    ii = last + 1
    units = _share(graph, stage, shape, cost) if dsp is not None and ii > 1 else ()
    return Schedule(ii=ii, clock_ns=clock_ns, dsp_budget=budget, stage=stage, lut_addr=lut_addr,
                    rom_reg=tuple(rom_reg), units=units, preset=preset, target=target)


def _share(graph: Graph, stage: dict, shape: tuple, cost) -> tuple:
    """Assign the products of each cycle, largest first, to units 0, 1, ...: a unit serves
    one product per cycle and is as wide as the widest it serves."""
    per_cycle: dict = {}
    for n in graph.nodes:
        if n.kind not in SOURCES and _is_product(graph, n):
            per_cycle.setdefault(stage[n.name], []).append(n)
    slots: list = []
    for c in sorted(per_cycle):
        ranked = sorted(per_cycle[c], key=lambda n: (-cost(n), -sum(product_widths(graph, n)), n.name))
        for j, n in enumerate(ranked):
            if j == len(slots):
                slots.append([])
            slots[j].append((n.name, c))
    units = []
    for j, uses in enumerate(slots):
        ws = [product_widths(graph, graph[name]) for name, _ in uses]
        units.append(Unit(name=f"mul{j}", widths=(max(w[0] for w in ws), max(w[1] for w in ws)), uses=tuple(uses)))
    return tuple(units)


def schedule_for(graph: Graph, shape: tuple, ii: int | None = None, dsp: int | None = None,
                 preset: str | None = None, target: str = "ecp5-85k") -> Schedule:
    """The schedule a build asks for: a preset, or ``--ii``/``--dsp``. With ``ii`` the clock goal
    is the shortest (bisection) whose schedule needs no more than ``ii`` cycles."""
    if preset is not None:
        if preset not in PRESETS:
            raise PendcError(f"unknown preset '{preset}' (known: {', '.join(PRESETS)})")
        clock, budget, _ = PRESETS[preset]
        return schedule_graph(graph, clock, dsp if dsp is not None else budget, shape, preset, target)
    if ii is None:
        return schedule_for(graph, shape, dsp=dsp, preset=DEFAULT_PRESET, target=target)
    if ii < 1:
        raise PendcError(f"--ii must be at least 1, got {ii}")
    slowest = schedule_graph(graph, math.inf, dsp, shape, "", target)
    if slowest.ii > ii:
        raise PendcError(f"no schedule in {ii} cycle(s): at least {slowest.ii} needed "
                         f"(table reads{' and the DSP budget' if dsp is not None else ''})")
    lo, hi = 1.0, 1000.0
    best = slowest if slowest.ii == ii else None
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        s = schedule_graph(graph, mid, dsp, shape, "", target)
        if s.ii <= ii:
            hi, best = mid, s
        else:
            lo = mid
    if best is None or best.ii > ii:
        best = slowest
    if best.ii < ii:        # fill to exactly ii cycles: the last cycle(s) only update the state
        best = Schedule(ii=ii, clock_ns=best.clock_ns, dsp_budget=dsp, stage=best.stage, lut_addr=best.lut_addr,
                        rom_reg=best.rom_reg, units=best.units, preset="", target=target)
    return best


def width_of(fmt: QFormat) -> int:
    return fmt.width
