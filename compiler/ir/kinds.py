"""IR node kinds: their semantics, their typed parameters, their arity.

Every node computes one value per model step. Its *exact* result (before it is
fitted into the node's own Q-format) follows the rule in the table below; then
``requantize`` (pendc.ir.qformat) rounds it per ``rounding`` and fits the range per
``overflow``, raising the sticky overflow flag if it did not fit.

| kind     | inputs       | params (class below)              | exact result (fraction bits f)                  |
|----------|--------------|-----------------------------------|-------------------------------------------------|
| CONST    | -            | ConstParams(value)                | value quantised to nearest (the stored constant)|
| INPUT    | -            | InputParams(port)                 | the port's integer, already in the node's format|
| GAIN     | a            | GainParams(value, cfmt = the      | a * c, f = fa + fc                              |
|          |              | constant's format)                |                                                 |
| ADD      | a, b         | -                                 | a + b aligned, f = max(fa, fb)                  |
| SUB      | a, b         | -                                 | a - b aligned, f = max(fa, fb)                  |
| NEG      | a            | -                                 | -a, f = fa                                      |
| MUL      | a, b         | -                                 | a * b, f = fa + fb                              |
| REGISTER | next         | RegisterParams(reset, real)       | last step's ``next`` (format must equal next's) |
| LUT      | a            | LutParams(expr, lo, hi, periodic, | table[addr] (+ slope * offset if interpolating),|
|          |              | addr_bits, interpolate, fmax,     | f = output frac; see pendc.ir.lut               |
|          |              | shift, table)                     |                                                 |
| MUX      | sel, in0,    | -                                 | in_sel aligned to the output, f = output frac;  |
|          | in1, ...     |                                   | a select beyond the last input picks the last   |
| SLICE    | a            | SliceParams(hi, lo) or            | bits hi..lo of a's integer (or its sign bit),   |
|          |              | SliceParams.sign()                | unsigned, f = 0                                 |
| COMPARE  | a, b         | CompareParams(op: CompareOp)      | 1 if real(a) op real(b) else 0, UFIX1_0         |
| CAST     | a            | -                                 | a, f = fa (only requantised into its format)    |
| FSM      | a            | FsmParams(states, reset,          | Moore output word of the state after this step  |
|          |              | transitions, outputs, lo, hi)     | (see pendc.ir.fsm)                              |

Any node may declare a capacity ``max_abs`` (see :class:`NodeParams`).

Operands are read by their format's signedness: an unsigned value is never taken as
two's complement (its exact results count it with a zero sign bit, one bit more).
Multiplier operands (GAIN input and constant, MUL inputs) are at most
``limits.MULT_OPERAND_BITS``; every exact intermediate fits ``limits.EXACT_BITS``
signed bits (the verifier checks both), so the compiled golden model can use machine
integers.

A MUX select beyond its data inputs (a 2-bit select over three inputs reading 3) is
defined: it selects the last data input, in the interpreters, the golden kernel and the
Verilog alike (the select of a narrower-than-power-of-two mux saturates).

Parameters are typed: ``node.params`` is a frozen instance of the kind's params class
(``Kind.GAIN.params_class is GainParams``), checked when it is built, so a node with a
missing or malformed parameter cannot exist (:class:`GraphError` names the node). The
*legacy* key/value form stays as the construction and compatibility interface:
``make(..., value=0.5, cfmt="FIX32_31")``, ``node.param("cfmt")`` (returns the text
"FIX32_31"; a sign-bit SLICE reads ``hi = lo = -1``) and ``node.with_params(...)``; the
graph's text form prints it. New code reads the typed fields: ``node.params.cfmt`` is a
QFormat, ``node.params.op`` a CompareOp, ``node.params.sign_bit`` a bool.

Adding a kind: a params class here (if it has parameters), one ``Kind`` member naming it
and its arity, and a ``visit_<kind>`` method in every :class:`pendc.ir.visitor.NodeVisitor`
subclass (the printers and evaluators); an import fails at the first one without it and
``python -m pendc.ir.visitor_audit`` lists them all (docs/architecture.md has a worked
example).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from enum import Enum
from functools import cached_property
from numbers import Real
from typing import ClassVar, NamedTuple

from .compare_ops import CompareOp
from .limits import MAX_LUT_ADDR_BITS
from .params import NodeParams, NoParams, ParamError, check_flag, check_int, check_real
from .qformat import QFormat


@dataclass(frozen=True)
class ConstParams(NodeParams):
    """CONST: the real value (stored quantised to nearest in the node's format)."""

    value: float

    def check(self):
        check_real("value", self.value)


@dataclass(frozen=True)
class InputParams(NodeParams):
    """INPUT: the port name (``max_abs``, the port's full scale, bounds its range)."""

    port: str

    def check(self):
        if not isinstance(self.port, str) or not self.port:
            raise ParamError(f"param 'port' must be a non-empty string, got {self.port!r}")


@dataclass(frozen=True)
class GainParams(NodeParams):
    """GAIN: multiply by a real constant, stored in ``cfmt`` (None until Q-formats are assigned)."""

    value: float
    cfmt: QFormat | None = None

    @classmethod
    def _decode(cls, values):
        if isinstance(values.get("cfmt"), str):
            try:
                values["cfmt"] = QFormat.parse(values["cfmt"])
            except ValueError:
                raise ParamError(f"param 'cfmt' {values['cfmt']!r} is not a Q-format") from None
        return values

    def check(self):
        check_real("value", self.value)
        if self.cfmt is not None and not isinstance(self.cfmt, QFormat):
            raise ParamError(f"param 'cfmt' {self.cfmt!r} is not a Q-format")

    def _encode(self):
        out = {"value": self.value}
        if self.cfmt is not None:
            out["cfmt"] = str(self.cfmt)
        return out

    @cached_property
    def constant(self) -> int:
        """The constant's integer in ``cfmt`` (requires cfmt); computed once per params object."""
        return self.cfmt.from_float(float(self.value))


@dataclass(frozen=True)
class RegisterParams(NodeParams):
    """REGISTER: the real value after reset."""

    reset: float

    def check(self):
        check_real("reset", self.reset)


@dataclass(frozen=True)
class LutParams(NodeParams):
    """LUT: a function of one variable sampled on a grid (semantics in pendc.ir.lut).

    ``lo``/``hi`` of a non-periodic table stay None until ``tabulate_luts`` has seen the
    input's range; ``fmax`` (largest |f| on the domain), ``shift`` (grid step, log2 input
    LSBs) and ``table`` (entries in the output format) are filled by the passes."""

    expr: str
    lo: float | None
    hi: float | None
    periodic: bool
    addr_bits: int
    interpolate: bool
    fmax: float | None = None
    shift: int | None = None
    table: tuple | None = None

    def check(self):
        if not isinstance(self.expr, str) or not self.expr.strip():
            raise ParamError(f"param 'expr' must be sympy text in v, got {self.expr!r}")
        check_real("lo", self.lo, optional=True)
        check_real("hi", self.hi, optional=True)
        if (self.lo is None) != (self.hi is None) or (self.lo is not None and not self.lo < self.hi):
            raise ParamError(f"domain [lo, hi] = [{self.lo}, {self.hi}] is not an interval")
        check_flag("periodic", self.periodic)
        check_flag("interpolate", self.interpolate)
        check_int("addr_bits", self.addr_bits, 1, MAX_LUT_ADDR_BITS)
        check_real("fmax", self.fmax, optional=True)

    @property
    def segments(self) -> int:
        """Grid segments, 2**addr_bits."""
        return 1 << self.addr_bits

    @property
    def entries(self) -> int:
        """Table entries: one more than the segments when interpolating."""
        return self.segments + (1 if self.interpolate else 0)


@dataclass(frozen=True)
class SliceParams(NodeParams):
    """SLICE: bits ``hi..lo`` of the input's integer, or (``sign_bit``) its most significant
    bit whatever the input's width. Build the latter with :meth:`sign`; its legacy form is
    ``hi = lo = -1``."""

    hi: int | None = None
    lo: int | None = None
    sign_bit: bool = False

    LEGACY_SIGN: ClassVar[int] = -1

    @classmethod
    def sign(cls) -> "SliceParams":
        """The most significant (sign) bit of the input."""
        return cls(sign_bit=True)

    @classmethod
    def _decode(cls, values):
        if values.get("hi") == values.get("lo") == cls.LEGACY_SIGN and "hi" in values:
            del values["hi"], values["lo"]
            values.setdefault("sign_bit", True)
        if not values.get("sign_bit"):
            for key in ("hi", "lo"):
                if key not in values:
                    raise ParamError(f"missing param '{key}'")
        return values

    def check(self):
        check_flag("sign_bit", self.sign_bit)
        if self.sign_bit:
            if self.hi is not None or self.lo is not None:
                raise ParamError(f"a sign-bit slice has no 'hi'/'lo', got {self.hi}..{self.lo}")
            return
        check_int("lo", self.lo, 0)
        check_int("hi", self.hi, self.lo)

    def _encode(self):
        if self.sign_bit:
            return {"hi": self.LEGACY_SIGN, "lo": self.LEGACY_SIGN}
        return {"hi": self.hi, "lo": self.lo}

    def bits(self, input_width: int) -> tuple[int, int]:
        """(hi, lo) bit positions in an input of ``input_width`` bits."""
        return (input_width - 1, input_width - 1) if self.sign_bit else (self.hi, self.lo)

    @property
    def width(self) -> int:
        """Bits of the result."""
        return 1 if self.sign_bit else self.hi - self.lo + 1


@dataclass(frozen=True)
class CompareParams(NodeParams):
    """COMPARE: the operator (the one table in pendc.ir.compare_ops)."""

    op: CompareOp

    @classmethod
    def _decode(cls, values):
        if "op" in values:
            try:
                values["op"] = CompareOp.parse(values["op"])
            except (ValueError, TypeError):
                ops = ", ".join(o.value for o in CompareOp)
                raise ParamError(f"op {values['op']!r} is not one of {ops}") from None
        return values

    def check(self):
        if not isinstance(self.op, CompareOp):
            raise ParamError(f"op {self.op!r} is not a CompareOp")

    def _encode(self):
        return {"op": self.op.value}


ANY_STATE = "*"


class Transition(NamedTuple):
    """One FSM rule: in ``source`` (or any state, ``"*"``), if ``input op threshold``, go to ``target``."""

    source: str
    op: CompareOp
    threshold: float
    target: str

    def legacy(self) -> tuple:
        """``(from, op name, threshold, to)``, the legacy tuple."""
        return (self.source, self.op.value, self.threshold, self.target)


@dataclass(frozen=True)
class FsmParams(NodeParams):
    """FSM: a Moore machine over one numeric input (semantics in pendc.ir.fsm)."""

    states: tuple
    reset: str
    transitions: tuple
    outputs: tuple
    lo: float
    hi: float

    @classmethod
    def _decode(cls, values):
        trans = values.get("transitions")
        if isinstance(trans, tuple):
            out = []
            for t in trans:
                if not isinstance(t, tuple) or len(t) != 4:
                    raise ParamError(f"transition {t!r} is not (from, op, threshold, to)")
                try:
                    op = CompareOp.parse(t[1])
                except (ValueError, TypeError):
                    op = None
                if op is None or not op.orders:
                    ops = ", ".join(o.value for o in CompareOp if o.orders)
                    raise ParamError(f"transition {tuple(t)!r} has op {t[1]!r}, not one of {ops}")
                out.append(Transition(t[0], op, t[2], t[3]))
            values["transitions"] = tuple(out)
        return values

    def check(self):
        states = self.states
        if not isinstance(states, tuple) or not states or len(set(states)) != len(states):
            raise ParamError(f"param 'states' must be a non-empty tuple of distinct names, got {states!r}")
        if self.reset not in states:
            raise ParamError(f"reset state {self.reset!r} is not one of its states")
        if not isinstance(self.transitions, tuple):
            raise ParamError(f"param 'transitions' must be a tuple, got {self.transitions!r}")
        for t in self.transitions:
            if not isinstance(t, Transition):
                raise ParamError(f"transition {t!r} is not a Transition")
            if t.source != ANY_STATE and t.source not in states:
                raise ParamError(f"transition {t.legacy()!r} starts in unknown state {t.source!r}")
            if t.target not in states:
                raise ParamError(f"transition {t.legacy()!r} goes to unknown state {t.target!r}")
            if not t.op.orders:
                raise ParamError(f"transition {t.legacy()!r} has op {t.op.value!r}, not an ordering")
            if (isinstance(t.threshold, bool) or not isinstance(t.threshold, Real)
                    or not math.isfinite(t.threshold)):
                raise ParamError(f"transition {t.legacy()!r} has a threshold that is not a finite number")
        outputs = self.outputs
        if (not isinstance(outputs, tuple) or len(outputs) != len(states)
                or any(isinstance(o, bool) or not isinstance(o, int) or o < 0 for o in outputs)):
            raise ParamError(f"param 'outputs' must hold one unsigned integer per state, got {outputs!r}")
        check_real("lo", self.lo)
        check_real("hi", self.hi)
        if not self.lo <= self.hi:
            raise ParamError(f"input range [{self.lo}, {self.hi}] is empty")

    def _encode(self):
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "max_abs"}
        out["transitions"] = tuple(t.legacy() for t in self.transitions)
        return out

    @property
    def reset_index(self) -> int:
        """Index of the reset state (the state register's value after reset)."""
        return self.states.index(self.reset)

    def rules_from(self, state: int) -> tuple:
        """The transitions tried, in order, in state number ``state``."""
        name = self.states[state]
        return tuple(t for t in self.transitions if t.source in (ANY_STATE, name))



# -- kinds --------------------------------------------------------------------------------

class Kind(Enum):
    """A node kind: its text name (the value), its params class and its number of inputs
    (None: variable, a MUX has a select and at least two data inputs)."""

    def __new__(cls, text: str, params_class: type, arity: int | None):
        obj = object.__new__(cls)
        obj._value_ = text
        obj.params_class = params_class
        obj.arity = arity
        return obj

    CONST = ("const", ConstParams, 0)
    INPUT = ("input", InputParams, 0)
    GAIN = ("gain", GainParams, 1)
    ADD = ("add", NoParams, 2)
    SUB = ("sub", NoParams, 2)
    NEG = ("neg", NoParams, 1)
    MUL = ("mul", NoParams, 2)
    REGISTER = ("reg", RegisterParams, 1)
    LUT = ("lut", LutParams, 1)
    MUX = ("mux", NoParams, None)
    SLICE = ("slice", SliceParams, 1)
    COMPARE = ("cmp", CompareParams, 2)
    CAST = ("cast", NoParams, 1)
    FSM = ("fsm", FsmParams, 1)

    @property
    def stateful(self) -> bool:
        """True for kinds whose input is taken at the end of the step (they break cycles)."""
        return self in (Kind.REGISTER, Kind.FSM)


ARITY = {k: k.arity for k in Kind}
COMPARE_OPS = tuple(o.value for o in CompareOp)     # legacy names, for messages and old callers
SOURCE_KINDS = (Kind.CONST, Kind.INPUT, Kind.REGISTER, Kind.FSM)   # valued at the start of a step
