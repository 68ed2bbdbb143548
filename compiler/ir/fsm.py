"""Semantics of FSM nodes: an MCode-like Moore machine over one numeric input.

Params of an FSM node:
  ``states``       state names; the state register holds the index
  ``reset``        name of the state after reset
  ``transitions``  ``(from, op, threshold, to)`` rules tried in order; ``from`` is a
                   state name or ``"*"``; ``op`` one of lt le gt ge; the threshold is a
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

from .qformat import QFormat

_OPS = {
    "lt": lambda a, b: a < b, "le": lambda a, b: a <= b,
    "gt": lambda a, b: a > b, "ge": lambda a, b: a >= b,
}


def threshold_int(threshold: float, fin: QFormat) -> int:
    """A threshold expressed on the input's integer grid (to nearest)."""
    return math.floor(math.ldexp(threshold, fin.frac) + 0.5)


def next_state(state: int, v: int, fin: QFormat, states: tuple, transitions: tuple) -> int:
    """The state after one step with input integer ``v`` (format ``fin``)."""
    name = states[state]
    for src, op, threshold, dst in transitions:
        if src in ("*", name) and _OPS[op](v, threshold_int(threshold, fin)):
            return states.index(dst)
    return state


def next_state_float(state: int, value: float, states: tuple, transitions: tuple) -> int:
    """Float counterpart of :func:`next_state` (range analysis)."""
    name = states[state]
    for src, op, threshold, dst in transitions:
        if src in ("*", name) and _OPS[op](value, threshold):
            return states.index(dst)
    return state


def output_width(outputs: tuple) -> int:
    return max(1, max(int(o) for o in outputs).bit_length())
