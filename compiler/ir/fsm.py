"""Semantics of FSM nodes: an MCode-like Moore machine over one numeric input.

Params of an FSM node:
  ``states``       state names; the state register holds the index
  ``reset``        name of the state after reset
  ``transitions``  ``(from, op, threshold, to)`` rules tried in order; ``from`` is a
                   state name or ``"*"``; ``op`` an ordering CompareOp (lt le gt ge, by
                   enum or name; typed nodes hold :class:`pendc.ir.nodes.Transition`); the threshold is a
                   real number compared with the input's real value. If no rule
                   matches, the state is kept.
  ``outputs``      Moore output word per state (unsigned integers)
  ``lo``, ``hi``   the input range the machine is designed for: an input outside it
                   raises the overflow flag (for encoders: a step that crossed more
                   than two bands).

Timing: the node's value during a step is the output word of the state *registered*
at the start of the step; at the end of the step the state advances on that step's
input. So an FSM, like a register, breaks combinational cycles.
"""

from __future__ import annotations

import math

from .compare_ops import CompareOp
from .qformat import QFormat


def threshold_int(threshold: float, fin: QFormat) -> int:
    """A threshold expressed on the input's integer grid (to nearest), clamped to one step
    beyond the input's range: ``min_int - 1 .. max_int + 1`` (every comparison of an input
    value with it comes out as with the unclamped threshold, and it stays a small integer)."""
    lo, hi = fin.min_int - 1, fin.max_int + 1
    try:
        scaled = math.ldexp(threshold, fin.frac)
    except OverflowError:
        return hi if threshold > 0 else lo
    if math.isinf(scaled):
        return hi if scaled > 0 else lo
    return min(max(math.floor(scaled + 0.5), lo), hi)


def constant_outcome(op, t: int, fin: QFormat) -> bool | None:
    """``v op t`` for every value ``v`` of ``fin`` when the threshold integer ``t`` lies outside
    the input's range (the comparison does not depend on ``v``), else None."""
    if fin.min_int <= t <= fin.max_int:
        return None
    above = t > fin.max_int
    return above if CompareOp.parse(op) in (CompareOp.LT, CompareOp.LE) else not above


def next_state(state: int, v: int, fin: QFormat, states: tuple, transitions: tuple) -> int:
    """The state after one step with input integer ``v`` (format ``fin``)."""
    name = states[state]
    for src, op, threshold, dst in transitions:
        if src in ("*", name) and CompareOp.parse(op).apply(v, threshold_int(threshold, fin)):
            return states.index(dst)
    return state


def next_state_float(state: int, value: float, states: tuple, transitions: tuple) -> int:
    """Float counterpart of :func:`next_state` (range analysis)."""
    name = states[state]
    for src, op, threshold, dst in transitions:
        if src in ("*", name) and CompareOp.parse(op).apply(value, threshold):
            return states.index(dst)
    return state


def output_width(outputs: tuple) -> int:
    return max(1, max(int(o) for o in outputs).bit_length())
