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

A product whose operands are registers may itself end a cycle: registered whole before its
rounding (``product_reg``) or, when its two multiplier blocks with their partial-product sum
do not fit the goal, as its two one-block partial products (``partial_reg``; the sum and the
rounding run in the next cycle), so a 10 ns goal holds every product (``--preset fmax``).

The delay model (pendc.passes.delays) is calibrated against nextpnr-ecp5's routed timing
(routing included, flip-flop clock-to-out and setup charged to every cycle). The ``fast``
preset tries clock goals of 5-30 ns and keeps the schedule whose *estimated* step
(``ii`` x the estimated period of its slowest cycle) is shortest; `pendc report synth`
measures the real Fmax.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from ..errors import PendcError
from ..ir.graph import Graph
from ..ir.nodes import Kind
from .delays import DelayModel, model_for, operand_mux_delay
from .node_delay import interp_delay, node_delay, overflow_term
from .resources import dsp_for, product_widths

SOURCES = (Kind.CONST, Kind.INPUT, Kind.REGISTER, Kind.FSM)
# nodes that carry an overflow term (pendc.backend.timing; node_delay.overflow_term): a LUT level
# detects it after the node, into a pipeline register; in the step's last cycle the OR of the
# terms into the sticky flag (two more levels) must fit too
PRESETS = {
    # name: (longest clock goal searched ns, DSP budget, description); every preset but comb keeps the
    # goal of FAST_GOALS (up to its longest) with the shortest estimated step
    # the point: >= 100 MHz and <= 100 ns per step, so the step-time preset keeps a 100 MHz
    # goal (a longer one gives a shorter estimated step at a lower clock: 3 x 29.5 ns, short chain),
    # less the ~1 ns of routing into chained carry chains the model misses in the full core (the
    # 10 ns goal's last cycle, dx_inc -> dx_sum -> clamp, routed 10.99 ns; docs/hardware.md)
    "fast": (9.5, None, "shortest estimated step (ii x estimated period) over clock goals of 5-9.5 ns "
                        "(100 MHz with a margin), a multiplier per product"),
    "default": (30.0, 24, "shortest estimated step within the thesis' 24 multipliers (shared only if needed)"),
    "small": (30.0, 4, "fewest DSP blocks: 4, shared across cycles, shortest estimated step (>= 1 MHz step rate)"),
    "comb": (math.inf, None, "no pipelining: one combinational step between table reads (the thesis' structure)"),
    # every cycle within 10 ns: two-block products are registered at their partial products (routed
    # 103.9 MHz, ii 21, 202 ns per step, 2026-11-23; docs/hardware.md)
    "fmax": (10.0, None, "the shortest estimated step at a 100 MHz clock goal, a multiplier per product"),
    # issue 23: the thesis' core did a step in 77.5 ns with 24 MULT18; a few long cycles (ii 3 at
    # about 24 ns) with products narrowed by the error budget, and only the products that afford an
    # operand mux sharing a unit (pendc.passes.share), docs/hardware.md
    "thesis": (25.0, 24, "shortest estimated step within the thesis' 24 multipliers, clock goals up to 25 ns; "
                         "only products off the critical chain share a multiplier"),
}
DEFAULT_PRESET = "default"
# presets whose clock goal is the one given, not the best of the goals up to it (a tighter goal
# may tie on the estimated step with a different, unmeasured schedule)
FIXED_GOAL = ("fmax",)
# presets that charge a node's overflow term (a LUT level after it, and in the last cycle the OR
# into the sticky flag) only where the backend emits one (node_delay.overflow_term: a clamp's muxes
# carry none): the step-time presets of the short chain; the others charge every node but
# MAY_OVERFLOW_NOT, as before (docs/hardware.md: counted exactly, the default preset's schedule,
# and so hdl_out/, would change)
EXACT_OVERFLOW_TERMS = ("fast", "fmax", "thesis")
MAY_OVERFLOW_NOT = SOURCES + (Kind.COMPARE, Kind.SLICE)
# presets that search their goals loosest first: a tighter goal must be strictly shorter on the
# estimate to be kept (ties: the loosest goal, fast's 10 ns, as routed; docs/hardware.md)
LOOSEST_FIRST = ("fast",)
# presets whose DSP budget is met by sharing only products that afford the operand mux
# (pendc.passes.share), not by every product behind a mux
SELECTIVE_SHARING = ("thesis",)


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
    estimated_period_ns: float = 0.0     # the slowest cycle under the delay model (pendc.passes.delays)
    product_reg: dict = field(default_factory=dict)   # product -> the cycle whose end registers it (rounded next)
    # two-block products registered as their two one-block partial products (summed and rounded next)
    partial_reg: dict = field(default_factory=dict)

    @property
    def estimated_step_ns(self) -> float:
        """``ii`` x the estimated period: the model's prediction of a step's duration."""
        return round(self.ii * self.estimated_period_ns, 2)

    def to_json(self) -> dict:
        return {"ii": self.ii, "preset": self.preset, "target": self.target,
                "clock_goal_ns": None if math.isinf(self.clock_ns) else self.clock_ns,
                "estimated_period_ns": self.estimated_period_ns, "estimated_step_ns": self.estimated_step_ns,
                "dsp_budget": self.dsp_budget, "rom_registered": list(self.rom_reg),
                "products_registered": dict(sorted(self.product_reg.items())),
                "partial_products_registered": dict(sorted(self.partial_reg.items())),
                "units": [u.to_json() for u in self.units],
                "cycles": {str(c): sorted(n for n, s in self.stage.items() if s == c) for c in range(self.ii)}}


def _is_product(graph: Graph, n) -> bool:
    return product_widths(graph, n) is not None


def schedule_graph(graph: Graph, clock_ns: float = math.inf, dsp: int | None = None,
                   shape: tuple = (18, 18), preset: str = "", target: str = "ecp5-85k",
                   muxed: dict | None = None) -> Schedule:
    """List-schedule ``graph`` (typed) for a clock goal and an optional DSP budget (see module doc).
    ``muxed``: product -> the delay of the operand mux in front of the unit it shares
    (pendc.passes.share picks them), charged to that product alone, which is then never
    registered at its product or partial products (its unit's product holds only in its cycle)."""
    muxed = muxed or {}
    model = model_for(target)
    # offsets are logic time after the launching flip-flop's clock-to-out; a cycle holds
    # ``budget`` of it before the capturing flip-flop's setup
    budget_ns = model.logic_budget(clock_ns)
    stage, finish, lut_addr, rom_reg, split_at, partial_at = {}, {}, {}, [], {}, {}
    longest: dict = {}     # cycle -> the longest logic path ending in it (ns)
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
    # a shared unit's operands come through a phase-selected mux in front of it
    share_mux = operand_mux_delay(model, math.ceil(len(costs) / slots)) if slots is not None else 0.0

    def place(c: int, offset: float, d: float, n=None) -> tuple[int, float]:
        """First (cycle, start) at or after (c, offset) where ``d`` fits and, for a product, DSPs are free."""
        if offset > 0 and offset + d > budget_ns:
            c, offset = c + 1, 0.0
        if n is not None and slots is not None:
            while usage.get(c, 0) >= slots:
                c, offset = c + 1, 0.0
            usage[c] = usage.get(c, 0) + 1
        return c, offset

    def done(name: str, c: int, end: float) -> None:
        stage[name], finish[name] = c, end
        longest[c] = max(longest.get(c, 0.0), end)

    def ready(inputs) -> tuple[int, float]:
        c = max((stage[i] for i in inputs), default=0)
        return c, max((finish[i] for i in inputs if stage[i] == c), default=0.0)

    def has_term(n) -> bool:
        # a step-time preset counts the terms there are; the others every node of a kind that may
        # carry one, as before (their schedules, and so the default build's HDL, stay as they were)
        return overflow_term(graph, n) if preset in EXACT_OVERFLOW_TERMS else n.kind not in MAY_OVERFLOW_NOT

    rom_offset = model.rom_clk_to_out - model.clk_to_q   # the ROM word arrives this much later than a register's
    for n in graph.nodes:
        if n.kind in SOURCES:
            stage[n.name], finish[n.name] = 0, 0.0
            continue
        c, o = ready(n.inputs)
        product = _is_product(graph, n)
        d = node_delay(graph, n, model, shape)
        if n.kind is Kind.LUT:
            c, o = place(c, o, d)
            lut_addr[n.name] = c
            longest[c] = max(longest.get(c, 0.0), o + d)
            di = interp_delay(graph, n, model, shape) + (share_mux if product else 0.0) + muxed.get(n.name, 0.0)
            c, o = c + 1, rom_offset
            if di and o + di > budget_ns:
                rom_reg.append(n.name)
                longest[c] = max(longest.get(c, 0.0), o)
                c, o = c + 1, 0.0
            if di and slots is None and n.name not in muxed and di + model.lut_level > budget_ns:
                cut = register_cut(model, *product_widths(graph, n), shape, budget_ns)
                if cut is not None:       # slope x fraction from registers; rounded and summed a cycle later
                    dm, after, partial = cut
                    (partial_at if partial else split_at)[n.name] = c
                    longest[c] = max(longest.get(c, 0.0), dm)
                    done(n.name, c + 1, di - after)
                    longest[c + 1] = max(longest[c + 1], di - after + model.lut_level)
                    continue
            if di:
                c, o = place(c, o, di, n)
            done(n.name, c, o + di)
            continue
        d += (share_mux if product else 0.0) + muxed.get(n.name, 0.0)
        tail = model.lut_level if has_term(n) else 0.0
        if product and slots is None and n.name not in muxed:
            split = _split_product(graph, n, model, shape, stage, c, o, d, tail, budget_ns)
            if split is not None:
                p, rest, partial = split
                (partial_at if partial else split_at)[n.name] = p
                longest[p] = max(longest.get(p, 0.0), d - rest)
                done(n.name, p + 1, rest)
                longest[p + 1] = max(longest[p + 1], rest + tail)
                continue
        c, o = place(c, o, d + tail, n if product else None)
        done(n.name, c, o + d)
        longest[c] = max(longest[c], o + d + tail)
    last = 0
    for n in graph.of_kind(Kind.REGISTER, Kind.FSM):
        i = n.inputs[0]
        tail = model.add(graph[i].qformat.width + 1) if n.kind is Kind.FSM else 0.0
        c = stage[i] + (1 if finish[i] > 0 and finish[i] + tail > budget_ns else 0)
        longest[c] = max(longest.get(c, 0.0), (finish[i] if c == stage[i] else 0.0) + tail)
        last = max(last, c)
    last = max([last] + list(stage.values()))
    flag_tail = 3 * model.lut_level
    late_flag = [n.name for n in graph.nodes if has_term(n) and stage[n.name] == last
                 and finish[n.name] + flag_tail > budget_ns]
    # the last cycle's overflow terms reach the flag directly: if they cannot, a cycle that only
    # loads the state follows, and they are registered like every other cycle's
    ii = last + (2 if late_flag else 1)
    if not late_flag:
        for n in graph.nodes:
            if has_term(n) and stage[n.name] == last:
                longest[last] = max(longest[last], finish[n.name] + flag_tail)
    units = _share(graph, stage, shape, cost) if dsp is not None and ii > 1 else ()
    period = round(model.overhead() + max(longest.values(), default=0.0), 3)
    return Schedule(ii=ii, clock_ns=clock_ns, dsp_budget=budget, stage=stage, lut_addr=lut_addr,
                    rom_reg=tuple(rom_reg), units=units, preset=preset, target=target, estimated_period_ns=period,
                    product_reg=split_at, partial_reg=partial_at)


def _split_product(graph: Graph, n, model: DelayModel, shape: tuple, stage: dict, c: int, o: float, d: float,
                   tail: float, budget_ns: float):
    """``(product cycle, delay after its register, partial)`` when registering a product before
    its rounding (and the partial-product sum's carry-out; ``partial``: before the partial-product
    sum, see :func:`register_cut`) finishes it earlier than chaining it after its operands, else
    None. The product's operands must all be registers by then: it starts at offset 0 of the
    cycle after the last of them."""
    cut = register_cut(model, *product_widths(graph, n), shape, budget_ns)
    if cut is None:
        return None
    rest, partial = d - cut[1], cut[2]
    computed = [stage[i] for i in n.inputs if graph[i].kind not in SOURCES]
    p = max(computed) + 1 if computed else 0
    if d + tail > budget_ns:
        return p, rest, partial   # too long for any cycle unless registered
    chained = (c, o + d) if o + d + tail <= budget_ns else (c + 1, d)
    return (p, rest, partial) if (p + 1, rest) < chained else None


def register_cut(model: DelayModel, wa: int, wb: int, shape: tuple, budget_ns: float):
    """Where a product from registers is registered when it ends a cycle: ``(delay up to the
    register, delay of the product before it, partial)``. The whole product (its blocks and
    their partial-product sum) when that fits ``budget_ns``; else, for a product of two
    blocks, its two one-block partial products (``partial``: the sum of them starts the next
    cycle, an adder of ``wa + wb`` bits); else None (no cycle holds it)."""
    blocks = dsp_for(wa, wb, shape)
    whole = model.product(wa, wb, blocks)
    if whole <= budget_ns:
        return whole, whole, False
    if blocks == 2 and tuple(shape) == (18, 18) and model.mul_one <= budget_ns:
        return model.mul_one, whole - model.add(wa + wb), True
    return None


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


FAST_GOALS = tuple(round(5.0 + 0.5 * i, 1) for i in range(51))      # 5 ns to 30 ns


def fastest(graph: Graph, shape: tuple, goals=FAST_GOALS, dsp: int | None = None, preset: str = "fast",
            target: str = "ecp5-85k") -> Schedule:
    """Of the schedules for every clock goal in ``goals``, the one with the shortest estimated step
    (``ii`` x estimated period; ties: the higher clock). A tighter goal is not always faster: a
    product or table read that no longer fits a cycle's remainder starts the next one, so the
    step is searched, not derived."""
    if preset in SELECTIVE_SHARING and dsp is not None:
        return _fastest_shared(graph, shape, goals, dsp, preset, target)
    best = None
    for goal in goals:
        s = schedule_graph(graph, goal, dsp, shape, preset, target)
        if best is None or (s.estimated_step_ns, s.estimated_period_ns) < (best.estimated_step_ns,
                                                                            best.estimated_period_ns):
            best = s
    return best


def _fastest_shared(graph: Graph, shape: tuple, goals, dsp: int, preset: str, target: str) -> Schedule:
    """:func:`fastest` with the DSP budget met by :func:`pendc.passes.share.share_to_budget`: the
    goals in the order of their unshared estimate (a lower bound of the shared one: a mux only
    adds), until no unshared schedule left could beat the best shared one."""
    from .share import scheduled_blocks, share_to_budget

    def at(goal):
        return lambda muxed=None: schedule_graph(graph, goal, None, shape, preset, target, muxed)

    plain = sorted(((at(g)(), g) for g in goals), key=lambda sg: (sg[0].estimated_step_ns, sg[0].estimated_period_ns))
    best = None
    for s, goal in plain:
        if best is not None and not best[0][0] and s.estimated_step_ns >= best[0][1]:
            break
        shared, groups = share_to_budget(graph, s, dsp, shape, at(goal))
        widths = [[product_widths(graph, graph[p]) for p in g] for g in groups]
        units = tuple(Unit(f"mul{j}", (max(w[0] for w in ws), max(w[1] for w in ws)),
                           tuple(sorted(((p, shared.stage[p]) for p in g), key=lambda u: u[1])))
                      for j, (g, ws) in enumerate(zip(groups, widths)))
        shared = replace(shared, units=units, dsp_budget=dsp)
        key = (scheduled_blocks(graph, shared, shape) > dsp, shared.estimated_step_ns, shared.estimated_period_ns)
        if best is None or key < best[0]:
            best = (key, shared)
    return best[1]


def schedule_for(graph: Graph, shape: tuple, ii: int | None = None, dsp: int | None = None,
                 preset: str | None = None, target: str = "ecp5-85k") -> Schedule:
    """The schedule a build asks for: a preset, or ``--ii``/``--dsp``. With ``ii`` the clock goal
    is the shortest (bisection) whose schedule needs no more than ``ii`` cycles."""
    if preset is not None:
        if preset not in PRESETS:
            raise PendcError(f"unknown preset '{preset}' (known: {', '.join(PRESETS)})")
        clock, budget, _ = PRESETS[preset]
        budget = dsp if dsp is not None else budget
        if math.isinf(clock):
            return schedule_graph(graph, clock, budget, shape, preset, target)
        goals = (clock,) if preset in FIXED_GOAL else tuple(g for g in FAST_GOALS if g <= clock)
        return fastest(graph, shape, goals[::-1] if preset in LOOSEST_FIRST else goals, budget, preset, target)
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
        best = replace(best, ii=ii, dsp_budget=dsp, preset="")
    return best
