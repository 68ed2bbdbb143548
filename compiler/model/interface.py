"""The plant interface: what the compiler, the golden model and the testbench need to know of a plant.

A plant model (:class:`~pendc.model.plant.PlantModel`) derives its equations from physics;
everything *around* the equations that a generic compiler pass would otherwise have to spell
out by name lives here instead, in one frozen value:

* the **states** with unit, meaning, periodicity (a position that wraps, e.g. an angle with
  period 2π rad, whose tables the hardware addresses by the phase within one period), the
  capacity of a periodic register (whole periods either way), a velocity clamp, the error
  tolerance the error budget holds a position to, and the rate the range analysis trains on
  from reset (a spinning pendulum);
* the **inputs** with unit, meaning, full scale and the range the actuator takes;
* the **sensors** (:mod:`pendc.model.sensors`; quadrature encoders: which state each reads, its band width, lines and
  bands per revolution, hence its counts per unit; sampled converters: which state, bits and
  range, hence the code rule);
* the **named intermediate quantities** of the equations (their meanings for the IR);
* the name of the hardware core.

:attr:`PlantModel.interface <pendc.model.plant.PlantModel.interface>` builds it from the model;
the lowering pass stores it in the graph's ``info`` (key ``"interface"``), where every later
pass, the backend and the golden model find it with :func:`graph_interface`. A second plant
is a second instance of this value, never a second code path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import PendcError
from .sensors import SensorSpec

INFO_KEY = "interface"


@dataclass(frozen=True)
class StateSpec:
    """One state of the plant.

    ``period`` (in ``unit``) marks a periodic position: the hardware keeps the register
    continuous with room for ``turns`` whole periods either way and addresses its tables by the
    phase. ``derivative_of`` names the state this one is the rate of. ``velocity_bound`` clamps
    |value| after every integration step. ``budget`` is the largest |fixed - float| the error
    budget allows this state over the check horizon (positions that a sensor measures: half a
    count). ``training_rate`` is a value the range analysis also starts this register at (a rate
    beyond what the stimuli reach, e.g. a pendulum spinning at its encoder's limit);
    ``working_range`` ``(low, high)`` where the state works, at both ends of which the range
    analysis also starts it (a slow plant the seconds of training never carry there). ``output``
    says whether the hardware reports the state every step. ``body`` and ``quantity`` word the
    meanings of derived signals ("pendulum" + "angle"). ``initial`` is the value at reset (a
    state-equation file's ``initial``): the register's reset, where float runs, the range
    analysis' training runs and the HIL plants start unless told otherwise.
    """

    name: str
    unit: str
    meaning: str
    body: str = ""
    quantity: str = ""
    derivative_of: str | None = None
    period: float | None = None
    turns: int | None = None
    velocity_bound: float | None = None
    budget: float | None = None
    training_rate: float | None = None
    output: bool = True
    initial: float = 0.0
    working_range: tuple | None = None

    @property
    def label(self) -> str:
        """Short noun phrase for derived signals: "pendulum angle"."""
        return f"{self.body} {self.quantity}".strip() or self.name

    @property
    def periodic(self) -> bool:
        """Whether the state is a position that wraps every ``period``."""
        return self.period is not None

    @property
    def capacity(self) -> float | None:
        """Largest |value| the register of a periodic state must hold (``turns`` periods)."""
        return None if self.period is None or self.turns is None else self.period * self.turns


def check_input_range(lo, hi, where: str) -> tuple:
    """``(lo, hi)`` as floats: two finite numbers with ``lo < hi``; else a one-line
    :class:`PendcError` naming ``where`` (a model file's ``input.range``, an input spec)."""
    pair = (lo, hi)
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in pair):
        raise PendcError(f"{where} must be two numbers [low, high], got [{lo!r}, {hi!r}]")
    if not all(math.isfinite(v) for v in pair):
        raise PendcError(f"{where} must be finite, got [{lo!r}, {hi!r}]")
    if not lo < hi:
        raise PendcError(f"{where} must have low < high, got [{lo!r}, {hi!r}]")
    return float(lo), float(hi)


@dataclass(frozen=True)
class InputRange:
    """The values an input's actuator takes, ``lo`` to ``hi`` in ``unit`` (the SCT drive:
    0 to 10 V); beyond them it saturates."""

    lo: float
    hi: float
    unit: str

    @property
    def span(self) -> float:
        """``hi - lo``: what a DAC over the whole range spans."""
        return self.hi - self.lo

    @property
    def centre(self) -> float:
        """The middle of the range."""
        return 0.5 * (self.lo + self.hi)

    def describe(self) -> str:
        """``0-10 V``, ``±10 V`` for a range symmetric about zero, ``-2 to 10 V`` from below zero
        (where a dash would read as a minus)."""
        if self.lo == -self.hi:
            return with_unit(f"±{self.hi:g}", self.unit)
        return with_unit(f"{self.lo:g}{' to ' if self.lo < 0 else '-'}{self.hi:g}", self.unit)


@dataclass(frozen=True)
class InputSpec:
    """One input of the plant: its port name, unit, meaning, full scale (the largest |value|
    the hardware's input port holds) and the range ``lo`` .. ``hi`` its actuator takes (the
    SCT drive 0-10 V, the QUBE's amplifier ±10 V; ±``full_scale`` when not given). The range
    lies within ±``full_scale``: a one-line :class:`PendcError` otherwise.

    ``neutral`` is the input at which the actuator is idle, where the standard stimuli centre
    (the file's ``neutral``; default zero when the range holds it, else the range's middle)."""

    name: str
    unit: str
    meaning: str
    full_scale: float
    lo: float | None = None
    hi: float | None = None
    neutral: float | None = None

    def __post_init__(self):
        where = f"the range of input '{self.name}'"
        lo = -self.full_scale if self.lo is None else self.lo
        hi = self.full_scale if self.hi is None else self.hi
        lo, hi = check_input_range(lo, hi, where)
        if max(abs(lo), abs(hi)) > self.full_scale:
            raise PendcError(f"{where} {with_unit(f'[{lo:g}, {hi:g}]', self.unit)} exceeds its full scale "
                             f"{with_unit(f'±{self.full_scale:g}', self.unit)}")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)
        object.__setattr__(self, "neutral", neutral_input(lo, hi, self.neutral, f"the neutral of input '{self.name}'"))

    @property
    def range(self) -> InputRange:
        """What the actuator takes: ``InputRange(lo, hi, unit)``."""
        return InputRange(self.lo, self.hi, self.unit)


def neutral_input(lo: float, hi: float, neutral: float | None, where: str) -> float:
    """``neutral`` checked to lie in [lo, hi]; when None, zero if the range holds it, else its middle."""
    if neutral is None:
        return 0.0 if lo <= 0.0 <= hi else (lo + hi) / 2
    if not lo <= neutral <= hi:
        raise PendcError(f"{where} {neutral:g} lies outside the range [{lo:g}, {hi:g}]")
    return float(neutral)


def input_spec(described: tuple, input_range: tuple, neutral: float | None = None) -> InputSpec:
    """The :class:`InputSpec` of ``described`` (name, unit, meaning) taking ``input_range``
    (lo, hi) idle at ``neutral`` (dropped when the range no longer holds it): the hardware
    port's full scale is the larger end's magnitude."""
    lo, hi = input_range
    if neutral is not None and not lo <= neutral <= hi:
        neutral = None
    return InputSpec(*described, full_scale=max(abs(lo), abs(hi)), lo=lo, hi=hi, neutral=neutral)


@dataclass(frozen=True)
class QuantitySpec:
    """A named intermediate of the equations (a force, an acceleration) and its meaning."""

    name: str
    unit: str
    meaning: str


@dataclass(frozen=True)
class PlantInterface:
    """Everything a generic pass needs to know of one plant (see the module docstring)."""

    name: str
    core: str
    states: tuple
    inputs: tuple
    sensors: tuple = ()
    quantities: tuple = ()

    def __post_init__(self):
        names = [s.name for s in self.states] + [i.name for i in self.inputs] + [q.name for q in self.quantities]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"plant interface '{self.name}' names {', '.join(dup)} twice")
        known = {s.name for s in self.states}
        for s in self.states:
            if s.derivative_of is not None and s.derivative_of not in known:
                raise ValueError(f"state '{s.name}' is the derivative of unknown state '{s.derivative_of}'")
            if s.period is not None and not (math.isfinite(s.period) and s.period > 0):
                raise ValueError(f"state '{s.name}' has a bad period {s.period!r}")
        taken = set(names)
        for sensor in self.sensors:
            if sensor.state not in known:
                raise ValueError(f"sensor '{sensor.name}' reads unknown state '{sensor.state}'")
            clash = sorted(taken & set(sensor.ports))
            if clash:
                raise ValueError(f"sensor '{sensor.name}': its port {clash[0]} is also the name of a state, "
                                 f"input or quantity")
            taken |= set(sensor.ports)

    def state(self, name: str) -> StateSpec:
        """The state called ``name`` (KeyError if none)."""
        for s in self.states:
            if s.name == name:
                return s
        raise KeyError(name)

    @property
    def input(self) -> InputSpec:
        """The plant's one input (the compiler's graphs have one input port)."""
        if len(self.inputs) != 1:
            raise ValueError(f"plant '{self.name}' has {len(self.inputs)} inputs; the hardware step takes one")
        return self.inputs[0]

    @property
    def outputs(self) -> tuple:
        """Names of the states the hardware reports every step, in order."""
        return tuple(s.name for s in self.states if s.output)

    @property
    def periodic(self) -> tuple:
        """The periodic states."""
        return tuple(s for s in self.states if s.periodic)

    def budgets(self) -> dict:
        """State -> error tolerance, for the states that have one."""
        return {s.name: s.budget for s in self.states if s.budget is not None}

    def sensor_of(self, state: str) -> SensorSpec | None:
        """The sensor that reads ``state``, or None."""
        return next((s for s in self.sensors if s.state == state), None)

    def register_names(self) -> dict:
        """Signal -> its bus register name(s): the input's word (``U``), each reported state's
        LO/HI pair (``X_LO``, ``X_HI``), each encoder's count word (``ENC_X_COUNT``), each
        converter's code word (``ADC_X_CODE``: ``NAME_CODE``). The
        wrappers' register map (``backend/wrapper.py``) lays these out."""
        regs = {i.name: (i.name.upper(),) for i in self.inputs}
        regs.update({s: (f"{s.upper()}_LO", f"{s.upper()}_HI") for s in self.outputs})
        regs.update({e.name: (f"{e.name.upper()}_CODE" if e.is_adc else f"{e.name.upper()}_COUNT",)
                     for e in self.sensors})
        return regs

    def meaning(self, name: str, default: str = "") -> str:
        """The meaning of a state, input or named quantity (``default`` for any other name)."""
        for spec in (*self.states, *self.inputs, *self.quantities):
            if spec.name == name:
                return spec.meaning
        return default


DIMENSIONLESS_SPELLINGS = ("", "-", "1")   # what a plant file writes for "no unit" (units.parse_unit)


def is_dimensionless(unit: str) -> bool:
    """Whether ``unit`` is one of the spellings of "no unit"."""
    return (unit or "").strip() in DIMENSIONLESS_SPELLINGS


def with_unit(value: str, unit: str) -> str:
    """``value`` followed by ``unit``, or alone for a dimensionless one: "0.4", not "0.4 -" or
    "0.4 1". Every message that prints a value with its unit goes through here."""
    return value if is_dimensionless(unit) else f"{value} {unit.strip()}"


def unit_name(unit: str) -> str:
    """``unit`` where it is named on its own ("[V]", "(kg)"): the word "dimensionless" for none,
    not a bare "-" or an empty "[]"."""
    return "dimensionless" if is_dimensionless(unit) else unit.strip()


def unit_key(name: str, unit: str) -> str:
    """``name`` and ``unit`` as one JSON key of word characters: '/' as "_per_", '*' as '_', a
    power's '^' dropped and brackets left out (``max_abs_x_m``, ``hold_w_rad_per_s``,
    ``max_abs_C_A_mol_per_m3``, ``hold_T_W_per_m2_K``); ``name`` alone for a dimensionless unit
    (``max_abs_d``, not ``max_abs_d_-``)."""
    if is_dimensionless(unit):
        return name
    spelled = unit.strip().replace("/", "_per_").replace("*", "_").replace("^", "")
    return f"{name}_{''.join(c for c in spelled if c not in '() ')}"


def graph_interface(graph) -> PlantInterface | None:
    """The plant interface a graph was lowered from (None for a graph built by hand)."""
    return dict(graph.info).get(INFO_KEY)


def require_interface(graph) -> PlantInterface:
    """The plant interface of ``graph``; ValueError for a graph without one."""
    iface = graph_interface(graph)
    if iface is None:
        raise ValueError(f"graph '{graph.name}' carries no plant interface (lower it from a plant model)")
    return iface
