"""Periodic states in the expression lowerer (:class:`pendc.passes.lower_expr.ExpressionLowerer`).

A table of a periodic state (an angle) is addressed by the state's *phase* in turns: the state
less its whole turns, over the period, so the state register stays continuous and the table's
wrap is free. A counter register follows the whole turns (``turns_phase``: ``period x turns``
held in a register of its own), and with ``lookahead`` each such table is a register read a step
ahead, from the next phase. :class:`PeriodicTables` is the lowerer's part that builds these; the
register names are here for the passes that must tell them from the plant's states.
"""

from __future__ import annotations

import math

import sympy as sp

from ..ir import lut as lut_sem
from ..ir.compare_ops import CompareOp
from ..ir.nodes import Kind, make
from ..model.interface import StateSpec


def turn_counter(state: str) -> str:
    """Name of the whole-turns register of a periodic state."""
    return f"{state}_turn"


def turn_registers(state: str) -> tuple:
    """The registers that count a periodic state's whole turns (the counter and, with
    ``turns_phase``, period x turns): bookkeeping for periodic tables, not the plant's state."""
    return turn_counter(state), f"{state}_whole_turns"


class PeriodicTables:
    """The periodic-state part of :class:`~pendc.passes.lower_expr.ExpressionLowerer`, which
    holds its state (``periodic``, ``turns_phase``, ``lookahead``, ``ahead``, ``turn_steps``)
    and the node building it uses (``emit``, ``const``, ``value``, ``value_key``, ``fresh``)."""

    def periodic_table(self, expr, var, spec: StateSpec, hint: str) -> str:
        """A LUT node for ``expr``, a smooth function of the periodic state ``var`` with its period:
        addressed by the phase in turns, or with ``lookahead`` the register read a step ahead."""
        v = sp.Symbol("v", real=True)
        if self.lookahead:
            text = sp.sstr(expr.subs(var, sp.nsimplify(spec.period, [sp.pi]) * v))
            return self.value_key(("lut ahead", spec.name, text), lambda: self._table_ahead(
                var, spec, text, hint, f"{sp.sstr(expr)} by {spec.name}"))
        source = self.value_key(("turns", spec.name), lambda: self.emit(
            Kind.GAIN, [self.phase(var)], f"{spec.name}_turns", f"{spec.label} in turns",
            value=1.0 / spec.period, max_abs=0.5))
        text = sp.sstr(expr.subs(var, sp.nsimplify(spec.period, [sp.pi]) * v))
        key = ("lut", source, text)
        return self.value_key(key, lambda: self.emit(
            Kind.LUT, [source], f"{hint}_lut", f"{sp.sstr(expr)} by {spec.name}", expr=text, lo=0.0, hi=1.0,
            periodic=True, addr_bits=10, interpolate=True))

    def phase(self, var) -> str:
        """A periodic state less its whole turns, within half a period of zero give or take one
        step: what periodic tables read. A turn counter follows the state (one step late, which
        only widens the interval by one increment); the phase is computed from the continuous
        register, so it never drifts from it, and its few integer bits leave a narrow multiplier
        operand all the precision."""
        spec: StateSpec = self.periodic[var]
        name, period, half = spec.name, spec.period, spec.period / 2
        counter = turn_counter(name)

        def build():
            state = self.variables[var]
            if self.turns_phase:
                whole = self._whole_turns_register(spec)
            else:
                whole = self.emit(Kind.GAIN, [counter], f"{name}_whole_turns",
                                  f"{spec.quantity} of the whole turns ({spec.unit})",
                                  value=period, max_abs=period * (spec.turns + 1))
            # within half a period by construction (a run started anywhere starts its counter at
            # the nearest whole turns: pendc.golden.register_integers), though training may
            # never have turned the state that far
            phase = self.emit(Kind.SUB, [state, whole], f"{name}_phase",
                              f"{spec.label} less its whole turns ({spec.unit})", max_abs=half)
            self._turn_counter(spec, phase, half)
            return phase
        return self.value_key(("phase", name), build)

    def _whole_turns_register(self, spec: StateSpec) -> str:
        """``period x turns`` held in a register loaded with ``period x turns_next``: the
        product runs at the end of the previous step, off the path from the state register to
        the tables (``turns_phase``; in real numbers the same value as the default's product)."""
        counter, name = turn_registers(spec.name)
        bound = spec.period * (spec.turns + 1)
        self.nodes.append(make(f"{name}_next", Kind.GAIN, [f"{counter}_next"], value=spec.period, max_abs=bound,
                               meaning=f"{spec.quantity} of the whole turns of the next step ({spec.unit})"))
        start = nearest_turns(spec.initial, spec.period)
        self.nodes.append(make(name, Kind.REGISTER, [f"{name}_next"], reset=start * spec.period, max_abs=bound,
                               meaning=f"{spec.quantity} of the whole turns ({spec.unit})"))
        self.used_names |= {name, f"{name}_next"}
        return name

    def _turn_counter(self, spec: StateSpec, phase: str, half: float) -> None:
        """The whole-turns register of ``spec``, stepped when ``phase`` leaves [-half, half)."""
        counter = turn_counter(spec.name)
        over = self.emit(Kind.COMPARE, [phase, self.const(half)], f"{spec.name}_phase_over", op=CompareOp.GE)
        under = self.emit(Kind.COMPARE, [phase, self.const(-half)], f"{spec.name}_phase_under", op=CompareOp.LT)
        down = self.emit(Kind.MUX, [under, self.const(0.0), self.const(-1.0)], f"{counter}_down")
        # a turn either way, though training may never turn the state (-1 fits any signed format)
        step = self.emit(Kind.MUX, [over, down, self.const(1.0)], f"{counter}_step", "whole turns gained",
                         max_abs=1.0)
        self.turn_steps[spec.name] = step
        self.nodes.append(make(f"{counter}_next", Kind.ADD, [counter, step], max_abs=float(spec.turns + 1)))
        start = nearest_turns(spec.initial, spec.period)
        self.nodes.append(make(counter, Kind.REGISTER, [f"{counter}_next"], reset=float(start),
                               max_abs=float(spec.turns + 1), meaning=f"whole turns of the {spec.body} (counter)"))
        self.used_names |= {counter, f"{counter}_next"}

    def _table_ahead(self, var, spec: StateSpec, text: str, hint: str, meaning: str) -> str:
        """The register that holds a periodic table's value for this step, read during the
        previous step from the next state (:meth:`read_ahead` emits the read); the phase and its
        turn counter are still built from this step's state."""
        self.phase(var)
        name = self.fresh(f"{hint}_lut")
        self.ahead.append((name, spec, text, meaning))
        return name

    def read_ahead(self, rates: dict, dt: float) -> None:
        """The reads of the tables of :meth:`_table_ahead` for the next step, each into its table's
        register. They are addressed by the next phase in turns, ``phase/period + dt rate/period -
        turns gained`` (``rates``: state -> its derivative, sympy): in real numbers the next state
        less its next whole turns, over the period, but with no product after the state's sum or
        the turn counter, only the phase's own product and one adder. The states reset to zero,
        so a register resets to its table's value at turn 0
        (:func:`pendc.passes.tabulate.fill_lut_tables` makes it the table's entry)."""
        turns_next: dict = {}
        for name, spec, text, meaning in self.ahead:
            if spec.name not in turns_next:
                var = next(v for v, s in self.periodic.items() if s is spec)
                now = self.emit(Kind.GAIN, [self.phase(var)], f"{spec.name}_turns", f"{spec.label} in turns",
                                value=1.0 / spec.period, max_abs=0.5)
                moved = self.value(sp.expand(sp.Float(dt / spec.period) * rates[spec.name]),
                                   f"{spec.name}_turns_inc", f"{spec.label} increment per step in turns")
                ahead = self.emit(Kind.SUB, [moved, self.turn_steps[spec.name]], f"{spec.name}_turns_ahead",
                                  f"{spec.label} increment less the whole turns gained, in turns")
                turns_next[spec.name] = self.emit(Kind.ADD, [ahead, now], f"{spec.name}_turns_next",
                                                  f"{spec.label} less its whole turns, next step, in turns")
            read = self.emit(Kind.LUT, [turns_next[spec.name]], f"{name}_next", f"{meaning}, next step", expr=text,
                             lo=0.0, hi=1.0, periodic=True, addr_bits=10, interpolate=True)
            phase = spec.initial / spec.period - nearest_turns(spec.initial, spec.period)
            self.nodes.append(make(name, Kind.REGISTER, [read], reset=float(lut_sem.evaluate(text, [phase])[0]),
                                   meaning=f"{meaning} (read a step ahead)"))


def nearest_turns(value: float, period: float) -> int:
    """The whole turns a periodic state's counter holds at ``value``: the nearest, so the phase
    (``value`` less them) is within half a period (at reset, and in a run started there)."""
    return math.floor(value / period + 0.5)


def is_periodic(expr, var, period: float) -> bool:
    """Whether ``expr`` repeats with ``period`` in ``var`` (sampled at nine points, not proved)."""
    f = sp.lambdify(var, expr, "math")
    points = [0.1 + 0.77 * i for i in range(9)]
    try:
        return all(math.isclose(f(p), f(p + period), rel_tol=1e-9, abs_tol=1e-12) for p in points)
    except (ValueError, ZeroDivisionError, OverflowError):
        return False
