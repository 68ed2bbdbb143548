"""IR node kinds and the immutable node record.

Every node computes one value per model step. Its *exact* result (before it is
fitted into the node's own Q-format) follows the rule in the table below; then
``requantize`` (pendc.ir.qformat) rounds it per ``rounding`` and fits the range per
``overflow``, raising the sticky overflow flag if it did not fit.

| kind     | inputs                 | params                                 | exact result (fraction bits f)                     |
|----------|------------------------|----------------------------------------|----------------------------------------------------|
| CONST    | -                      | value, (qformat = its own)             | value quantised to nearest (the stored constant)   |
| INPUT    | -                      | port                                   | the port's integer, already in the node's format    |
| GAIN     | a                      | value, cfmt (constant's format)        | a * c, f = fa + fc                                  |
| ADD      | a, b                   | -                                      | a + b aligned, f = max(fa, fb)                      |
| SUB      | a, b                   | -                                      | a - b aligned, f = max(fa, fb)                      |
| NEG      | a                      | -                                      | -a, f = fa                                          |
| MUL      | a, b                   | -                                      | a * b, f = fa + fb                                  |
| REGISTER | next                   | reset (real value)                     | last step's ``next`` (format must equal next's)     |
| LUT      | a                      | expr, lo, hi, periodic, addr_bits,     | table[addr] (+ slope * offset if interpolating),    |
|          |                        | interpolate, table (filled late)       | f = output frac; see pendc.ir.lut                   |
| MUX      | sel, in0, in1, ...     | -                                      | in_sel aligned to the output, f = output frac;      |
|          |                        |                                        | a select beyond the last input picks the last one   |
| SLICE    | a                      | hi, lo (bit positions)                 | bits hi..lo of a's integer, unsigned, f = 0         |
| COMPARE  | a, b                   | op (lt le gt ge eq ne)                 | 1 if real(a) op real(b) else 0, UFIX1_0             |
| CAST     | a                      | -                                      | a, f = fa (only requantised into the node's format) |
| FSM      | a                      | states, transitions, outputs, reset,   | Moore output word of the state after this step      |
|          |                        | lo, hi (valid input range)             | (see pendc.ir.fsm)                                  |

Operands are read by their format's signedness: an unsigned value is never taken as
two's complement (its exact results count it with a zero sign bit, one bit more).
Multiplier operands (GAIN input and constant, MUL inputs) are at most 32 bits; every
exact intermediate fits in 64 signed bits (the verifier checks both), so the compiled
golden model can use machine integers.

A MUX select beyond its data inputs (a 2-bit select over three inputs reading 3) is
defined: it selects the last data input, in the interpreters, the golden kernel and the
Verilog alike (the select of a narrower-than-power-of-two mux saturates).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import Enum

from .qformat import Overflow, QFormat, Rounding


class Kind(Enum):
    CONST = "const"
    INPUT = "input"
    GAIN = "gain"
    ADD = "add"
    SUB = "sub"
    NEG = "neg"
    MUL = "mul"
    REGISTER = "reg"
    LUT = "lut"
    MUX = "mux"
    SLICE = "slice"
    COMPARE = "cmp"
    CAST = "cast"
    FSM = "fsm"


ARITY = {
    Kind.CONST: 0, Kind.INPUT: 0, Kind.GAIN: 1, Kind.ADD: 2, Kind.SUB: 2, Kind.NEG: 1,
    Kind.MUL: 2, Kind.REGISTER: 1, Kind.LUT: 1, Kind.MUX: None, Kind.SLICE: 1,
    Kind.COMPARE: 2, Kind.CAST: 1, Kind.FSM: 1,
}

COMPARE_OPS = ("lt", "le", "gt", "ge", "eq", "ne")


@dataclass(frozen=True)
class Node:
    """One IR node. ``inputs`` are node names; ``params`` is a tuple of (key, value) pairs
    so the node stays hashable and prints deterministically; ``qformat`` is None until
    the Q-format pass has run. ``meaning`` says what the value is physically."""

    name: str
    kind: Kind
    inputs: tuple = ()
    params: tuple = ()
    qformat: QFormat | None = None
    rounding: Rounding = Rounding.NEAREST
    overflow: Overflow = Overflow.WRAP
    meaning: str = field(default="", compare=False)

    def param(self, key: str, default=None):
        for k, v in self.params:
            if k == key:
                return v
        return default

    def with_params(self, **changes) -> "Node":
        """A copy with some params replaced or added (kept in sorted key order)."""
        merged = dict(self.params)
        merged.update(changes)
        return replace(self, params=tuple(sorted(merged.items())))

    def typed(self, fmt: QFormat) -> "Node":
        return replace(self, qformat=fmt)


def make(name: str, kind: Kind, inputs=(), meaning: str = "", qformat: QFormat | None = None,
         rounding: Rounding = Rounding.NEAREST, overflow: Overflow = Overflow.WRAP, **params) -> Node:
    """Build a node with params in sorted key order (the canonical form)."""
    return Node(name=name, kind=kind, inputs=tuple(inputs), params=tuple(sorted(params.items())),
                qformat=qformat, rounding=rounding, overflow=overflow, meaning=meaning)
