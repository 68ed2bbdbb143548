"""What every stepping plant shares: the state it returns, the step request's checks, the
encoder counting, the start state's checks (:class:`PlantState`, :class:`Plant`).

The plants themselves (:mod:`.plant`'s float plant and factory, :mod:`.golden_plant`,
:mod:`.rtl_plant`, :mod:`.rtl_cpp`) import this module; it imports none of them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from ...errors import PendcError

MAX_STEPS_PER_CALL = 100_000_000   # 100 s at 1 us: a larger request is a caller's mistake


@dataclass(frozen=True)
class PlantState:
    """The plant after a step: time since reset, its reported states in SI units, each
    encoder's ×4 count since reset and each sampled converter's (ADC's) code.

    ``states``, ``counts`` and ``codes`` are ``(name, value)`` pairs in the plant interface's
    order (its reported states; its encoders; its converters). A state, an encoder or a
    converter also reads as an attribute under its interface name (``state.<name>``), so code
    written for one plant reads naturally."""

    t: float
    states: tuple
    counts: tuple
    codes: tuple = ()

    def __getattr__(self, name: str):
        # only reached when ordinary lookup fails: the plant's own names
        d = self.__dict__
        for key, value in (*d.get("states", ()), *d.get("counts", ()), *d.get("codes", ())):
            if key == name:
                return value
        raise AttributeError(f"the plant state has no '{name}' (states: "
                             f"{', '.join(k for k, _ in d.get('states', ()))}; sensors: "
                             f"{', '.join(k for k, _ in (*d.get('counts', ()), *d.get('codes', ())))})")

    def value(self, name: str) -> float:
        """The state called ``name`` (SI units)."""
        return dict(self.states)[name]

    def count(self, encoder: str) -> int:
        """The ×4 count since reset of the encoder called ``encoder``."""
        return dict(self.counts)[encoder]

    def code(self, adc: str) -> int:
        """The code of the sampled converter called ``adc``."""
        return dict(self.codes)[adc]

    @classmethod
    def at_rest(cls, ports, t: float = 0.0) -> "PlantState":
        """Every state 0 and every count 0 (power-on) for a core with these ports; each
        converter's code is that of its state at 0."""
        return cls(t, tuple((s, 0.0) for s in ports.states), tuple((e.name, 0) for e in ports.encoders),
                   tuple((a.name, a.code(0.0)) for a in getattr(ports, "adcs", ())))


def start_counts(ports, initial) -> dict:
    """{encoder: count} of each encoder's absolute band grid at the reported state ``initial``
    (one value per ``ports.states``, None: power-on, all 0): what a run adds to the counts
    since reset so that its controller reads positions from the grid's zero, as a rig with
    homed encoders does (:func:`pendc.hil.loop.run_closed_loop`'s ``count_origin``)."""
    if initial is None:
        return {e.name: 0 for e in ports.encoders}
    values = dict(zip(ports.states, initial))
    return {e.name: int(math.floor(values[e.state] / e.resolution)) for e in ports.encoders}


@runtime_checkable
class Plant(Protocol):
    """What every plant offers: a model step ``dt`` (s), the core's names ``ports``
    (:class:`~pendc.hil.plants.core_ports.CorePorts`: its input, reported states and encoders, from the
    plant interface), ``reset()`` and ``step(u_volts, n_steps)``."""

    dt: float
    ports: object

    def reset(self) -> PlantState:
        """Back to power-on: every state at rest, encoders at zero."""
        ...

    def step(self, u_volts: float, n_steps: int) -> PlantState:
        """Hold ``u_volts`` for ``n_steps`` model steps; the state after the last one."""
        ...


def check_step_request(u_volts, n_steps) -> tuple[float, int]:
    """``(u, n)`` validated: a finite voltage and a whole number of steps in [1, 1e8]."""
    try:
        u = float(u_volts)
    except (TypeError, ValueError):
        raise PendcError(f"plant input must be a number of volts, got {u_volts!r}") from None
    if not math.isfinite(u):
        raise PendcError(f"plant input must be finite, got {u}")
    if isinstance(n_steps, bool) or not isinstance(n_steps, (int, np.integer)):
        raise PendcError(f"number of steps must be an integer, got {n_steps!r}")
    n = int(n_steps)
    if not 1 <= n <= MAX_STEPS_PER_CALL:
        raise PendcError(f"number of steps must be in 1..{MAX_STEPS_PER_CALL}, got {n}")
    return u, n


def encoder_counts(value: float, origin: float, resolution: float) -> int:
    """×4 counts of a position on the absolute band grid, relative to the position at reset."""
    return int(math.floor(value / resolution) - math.floor(origin / resolution))


# Gray index of the channel levels (A, B) along increasing position: A leads B by a quarter period
_GRAY = np.array([0, 3, 1, 2])   # index by 2*A + B: 00 -> 0, 01 -> 3, 10 -> 1, 11 -> 2


def x4_count_delta(a: np.ndarray, b: np.ndarray) -> int:
    """Net ×4 counts over a sequence of channel levels (every edge of A and B counts, sign by
    which channel leads), as a quadrature decoder sampling every model step counts them.
    Both channels changing between two samples is a lost count: an error, never a guess."""
    phase = _GRAY[2 * np.asarray(a, dtype=np.int64) + np.asarray(b, dtype=np.int64)]
    moves = np.diff(phase) % 4
    if np.any(moves == 2):
        bad = int(np.flatnonzero(moves == 2)[0])
        raise PendcError(f"encoder channels A and B changed in the same step (sample {bad + 1}): "
                         f"the decoder cannot tell the direction")
    return int(np.count_nonzero(moves == 1) - np.count_nonzero(moves == 3))


def check_initial(ports, initial) -> tuple | None:
    """``initial`` as floats, one per reported state (None stays None); a wrong count is an error."""
    if initial is None:
        return None
    values = tuple(float(v) for v in initial)
    if len(values) != len(ports.states):
        raise PendcError(f"initial state needs {len(ports.states)} values ({', '.join(ports.states)}), "
                         f"got {len(values)}")
    return values
