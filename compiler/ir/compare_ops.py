"""The one table of comparison operators (COMPARE nodes and FSM transitions).

Every printer and evaluator reads an operator from here: its name in the graph's
text form, the Python function that evaluates it and the infix spelling, which is
the same in Python and in Verilog (``<``, ``<=``, ``>``, ``>=``, ``==``, ``!=``).
"""

from __future__ import annotations

import operator
from enum import Enum


class CompareOp(Enum):
    """A comparison ``a op b``; the value is the name used in the text form and in ``make(op=...)``."""

    LT = "lt"
    LE = "le"
    GT = "gt"
    GE = "ge"
    EQ = "eq"
    NE = "ne"

    @property
    def symbol(self) -> str:
        """Infix spelling, valid Python and Verilog alike."""
        return _SYMBOL[self]

    def apply(self, a, b) -> bool:
        """``a op b`` on Python numbers."""
        return _FUNCTION[self](a, b)

    @property
    def orders(self) -> bool:
        """True for the four ordering tests (an FSM transition may use only these)."""
        return self in ORDERING_OPS

    @classmethod
    def parse(cls, op) -> "CompareOp":
        """``op`` as a CompareOp: the enum itself or its name ("lt", ...); ValueError otherwise."""
        if isinstance(op, cls):
            return op
        try:
            return cls(op)
        except ValueError:
            raise ValueError(f"op {op!r} is not one of {', '.join(o.value for o in cls)}") from None


_SYMBOL = {CompareOp.LT: "<", CompareOp.LE: "<=", CompareOp.GT: ">", CompareOp.GE: ">=",
           CompareOp.EQ: "==", CompareOp.NE: "!="}
_FUNCTION = {CompareOp.LT: operator.lt, CompareOp.LE: operator.le, CompareOp.GT: operator.gt,
             CompareOp.GE: operator.ge, CompareOp.EQ: operator.eq, CompareOp.NE: operator.ne}
ORDERING_OPS = (CompareOp.LT, CompareOp.LE, CompareOp.GT, CompareOp.GE)
