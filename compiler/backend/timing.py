"""How a schedule (pendc.passes.schedule) shows up in the netlist: pipeline registers,
shared multiplier units and the cycle-gated overflow flag.

A node's value is read as its own wire in the cycle it is computed in and, in later
cycles, from a pipeline register loaded at the end of that cycle (only when the
schedule has a finite clock goal or shared units: a purely combinational schedule
reads every value directly, since all of them stay stable through the step).
Products assigned to a shared unit read its product, whose operands are selected by
the phase counter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..ir.nodes import Kind
from ..passes.schedule import SOURCES, Schedule
from .arith import Netlist, extend, literal, ulit

# a product split into two multiplier blocks splits its wide operand here: 17 unsigned low bits
# (with a zero sign bit, one 18x18 block) and the signed rest
LOW_BITS = 17


@dataclass
class Datapath:
    """Schedule-dependent parts of the core's view-model."""

    schedule: Schedule
    net: Netlist
    kinds: dict                                       # node name -> Kind
    phase_width: int
    pipe_regs: list = field(default_factory=list)     # (name, width, signed, source, stage)
    unit_ops: dict = field(default_factory=dict)      # unit -> [(stage, a expr, b expr)]
    _piped: dict = field(default_factory=dict)

    @property
    def registered(self) -> bool:
        return not math.isinf(self.schedule.clock_ns) or bool(self.schedule.units)

    def unit_of(self, node: str):
        for u in self.schedule.units:
            if any(name == node for name, _ in u.uses):
                return u
        return None

    def ref(self, node: str, cycle: int, wire: str) -> str:
        """The wire to read ``node``'s value (``wire``) from in ``cycle``."""
        stage = self.schedule.stage.get(node, 0)
        if self.kinds[node] in SOURCES or stage >= cycle or not self.registered:
            return wire
        if wire not in self._piped:
            self._piped[wire] = (self.net.fresh(f"{wire}_p"), stage)
        return self._piped[wire][0]

    def finish(self) -> None:
        """Declare the shared units and the pipeline registers (widths from the wires they copy)."""
        self.emit_units()
        decls = {name: (width, signed) for name, width, signed in self.net.decls}
        for wire, stage in self._piped_overflow(decls):
            if wire not in self._piped:     # a fresh name: n_<node>_ovf_p may be another node's value
                self._piped[wire] = (self.net.fresh(f"{wire}_p"), stage)
        self.pipe_regs = [(reg, *decls[wire], wire, stage) for wire, (reg, stage) in self._piped.items()]

    def __post_init__(self):
        # the shared units' wires are named before any product reads them
        self._unit_wires = {u.name: {side: self.net.fresh(f"u_{u.name}_{side}", claim=True) for side in ("a", "b", "p", "p_unused")}
                            for u in self.schedule.units}

    def product(self, base: str, node: str, a: tuple, b: tuple) -> tuple:
        """``(wire, width)`` of the exact signed product of operands ``(expr, width, constant
        or None, signed)`` (a constant is a signed integer, an unsigned operand is read with a
        zero sign bit): its own multiplier, or a slice of the shared unit's product."""
        sw = [w + (0 if s or c is not None else 1) for _, w, c, s in (a, b)]
        width = sw[0] + sw[1]
        unit = self.unit_of(node)
        big, small = ((a, sw[0]), (b, sw[1])) if a[1] >= b[1] else ((b, sw[1]), (a, sw[0]))
        if unit is not None and (big[1] > unit.widths[0] or small[1] > unit.widths[1]):
            unit = None     # an unsigned operand as wide as the unit: the unit's signed operand cannot hold it
        if unit is None:
            cycle = getattr(self.schedule, "partial_reg", {}).get(node)
            if cycle is not None:
                wide, narrow = sorted(((a, sw[0]), (b, sw[1])), key=lambda op: -op[1])
                return self._partial_products(base, wide, narrow, cycle), width
            ops = [f"$signed({literal(c, width) if c is not None else extend(e, w, s, width)})" for e, w, c, s in (a, b)]
            return self._product_reg(node, self.net.wire(f"{base}_x", width, f"{ops[0]} * {ops[1]}")), width
        wa, wb = unit.widths
        names = self._unit_wires[unit.name]
        (e1, w1, c1, s1), (e2, w2, c2, s2) = big[0], small[0]
        ea = literal(c1, wa) if c1 is not None else extend(e1, w1, s1, wa)
        eb = literal(c2, wb) if c2 is not None else extend(e2, w2, s2, wb)
        self.unit_ops.setdefault(unit.name, []).append((self.schedule.stage[node], ea, eb))
        p = names["p"]
        return self.net.wire(f"{base}_x", width, p if width == wa + wb else f"{p}[{width - 1}:0]"), width

    def _product_reg(self, node: str, wire: str) -> str:
        """``wire``, or its pipeline register when the schedule registers ``node``'s product
        before rounding it (``Schedule.product_reg``: the cycle whose end loads it)."""
        cycle = getattr(self.schedule, "product_reg", {}).get(node)
        if cycle is None:
            return wire
        self._piped[wire] = (self.net.fresh(f"{wire}_p"), cycle)
        return self._piped[wire][0]

    def _partial_products(self, base: str, big: tuple, small: tuple, cycle: int) -> str:
        """The exact product of a wide operand (``big``: (operand, signed width), at most 35 bits)
        and a narrow one (``small``, at most 18), as two one-block partial products loaded into
        pipeline registers at the end of ``cycle`` and summed in the next
        (``Schedule.partial_reg``): a x b = (a_hi x b) * 2**17 + a_lo x b with a_lo the low 17
        bits of a (unsigned) and a_hi the rest (signed). No cycle then holds more than one
        multiplier block; the sum and the rounding run in the next."""
        (e1, w1, c1, s1), wa = big
        (e2, w2, c2, s2), wb = small
        if wa <= LOW_BITS + 1 or wa > 2 * LOW_BITS + 1 or wb > LOW_BITS + 1:
            raise ValueError(f"{base}: a {wa}x{wb} product is not two 18x18 blocks")
        xa = self.net.wire(f"{base}_xa", wa, literal(c1, wa) if c1 is not None else extend(e1, w1, s1, wa))
        xb = self.net.wire(f"{base}_xb", wb, literal(c2, wb) if c2 is not None else extend(e2, w2, s2, wb))
        lo_w, hi_w = LOW_BITS + 1 + wb, wa - LOW_BITS + wb
        lo = self.net.wire(f"{base}_xlo", lo_w, f"$signed({{1'b0, {xa}[{LOW_BITS - 1}:0]}}) * $signed({xb})")
        hi = self.net.wire(f"{base}_xhi", hi_w, f"$signed({xa}[{wa - 1}:{LOW_BITS}]) * $signed({xb})")
        regs = []
        for wire in (lo, hi):
            self._piped[wire] = (self.net.fresh(f"{wire}_p"), cycle)
            regs.append(self._piped[wire][0])
        total = wa + wb
        return self.net.wire(f"{base}_x", total, f"$signed({{{regs[1]}, {LOW_BITS}'d0}}) + "
                                                 f"$signed({extend(regs[0], lo_w, True, total)})")

    def emit_units(self) -> None:  # called by finish()
        """Declare every shared unit: phase-selected operands and one product."""
        pw = self.phase_width
        for unit in self.schedule.units:
            wa, wb = unit.widths
            names = self._unit_wires[unit.name]
            uses = self.unit_ops.get(unit.name, [])
            for side, width, j in (("a", wa, 1), ("b", wb, 2)):
                rhs = uses[-1][j] if uses else literal(0, width)
                for stage, *ops in reversed(uses[:-1]):
                    rhs = f"(phase == {ulit(stage, pw)}) ? {ops[j - 1]} : {rhs}"
                self.net.wire(names[side], width, rhs, own=True)
            p = self.net.wire(names["p"], wa + wb, f"$signed({names['a']}) * $signed({names['b']})", own=True)
            self.net.wire(names["p_unused"], wa + wb, p, signed=False, own=True)

    def overflow_stages(self) -> list:
        """``(wire, node, stage)`` of every overflow term: the cycle of the step in which the
        term is valid and counts (FSMs update in the last cycle)."""
        last = self.schedule.ii - 1
        return [(wire, node, last if self.kinds.get(node) is Kind.FSM else self.schedule.stage.get(node, 0))
                for wire, node in self.net.overflow]

    def cycle_gate(self, stage: int) -> str:
        """Expression true in cycle ``stage`` of a step being computed."""
        if self.schedule.ii == 1:
            return "step"
        return "(ready & step)" if stage == 0 else f"(phase == {ulit(stage, self.phase_width)})"

    def _piped_overflow(self, decls: dict) -> list:
        """``(wire, stage)`` of the overflow terms counted one cycle late from a pipeline register:
        those of every cycle but the last of a pipelined step (the OR of all terms into the sticky
        flag would otherwise end every cycle's longest path; the last cycle's terms stay direct,
        so the flag still rises with ``ready``). Terms that already are registers stay as they are."""
        if not self.registered or self.schedule.ii < 2:
            return []
        last = self.schedule.ii - 1
        return [(wire, stage) for wire, _, stage in self.overflow_stages() if stage < last and wire in decls]

    def overflow_hit(self, multicycle: bool) -> str:
        """Expression: some node overflowed during a step (counted in the cycle it is computed in,
        or in the next from its pipeline register: see ``_piped_overflow``)."""
        by_stage: dict = {}
        for wire, _, stage in self.overflow_stages():
            if multicycle and wire in self._piped and self.registered and stage < self.schedule.ii - 1:
                wire, stage = self._piped[wire][0], stage + 1
            by_stage.setdefault(stage, []).append(wire)
        if not by_stage:
            return "1'b0"
        terms = []
        for stage in sorted(by_stage):
            ors = " | ".join(by_stage[stage])
            gate = self.cycle_gate(stage) if multicycle else "step"
            terms.append(f"({gate} & ({ors}))")
        return " | ".join(terms)
