"""Runs from an operating point: where ``pendc hil --start NAME`` starts the plant (the point
with one measured state moved, so holding it takes the controller) and how closely a run held
the point, whoever controlled it (:func:`hold_summary`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import PendcError
from ...model.interface import unit_key
from ...model.plant import PlantModel
from ..plants.core_ports import CorePorts
from .operating_point_lqr import measured_coordinates, operating_state, wrap

START_OFFSET = {"m": 0.01, "rad": 0.05}   # --start: the offset of the moved state (start_moved)
START_SPAN_SHARE = 0.05                     # of a converter's span, the largest --start offset of a state it reads
START_CODES = 4                             # converter codes, the smallest --start offset of a state it reads
START_OFFSET_OTHER = 0.01


def start_moved(model: PlantModel, ports) -> str | None:
    """The measured state ``pendc hil --start`` moves: the pendulum if the plant is one pendulum
    on a driven coordinate (whichever the file declares first), else the last measured position
    with a rate (the far end of the chain: a top link, a ball), else the last measured state in the
    order of the file's sensors."""
    from .pendulum_roles import pendulum_roles

    try:
        pendulum = pendulum_roles(model).pendulum.position
    except PendcError:
        pendulum = None
    if pendulum in ports.measured:
        return pendulum
    rated = {s.derivative_of for s in model.interface.states if s.derivative_of}
    positions = [m for m in ports.measured if m in rated]
    return positions[-1] if positions else (ports.measured[-1] if ports.measured else None)


def start_state(model: PlantModel, point: str) -> tuple:
    """The reported states (the plant interface's order) at operating point ``point`` with one
    measured state (:func:`start_moved`) moved by :data:`START_OFFSET` (0.05 rad, 1 cm; 0.01 of
    another unit; at most 5 % of its converter's span): where ``pendc hil --start`` starts the
    plant, so that holding it takes the controller."""
    name, values = operating_state(model, point)
    iface = model.interface
    ports = CorePorts.of_interface(iface)
    moved = start_moved(model, ports)
    if moved is not None:
        offset = START_OFFSET.get(iface.state(moved).unit, START_OFFSET_OTHER)
        adc = ports.adc_of(moved)
        if adc is not None:       # within its converter's span (1 cm would leave a 14 mm maglev gap),
            # and a move it can read (0.01 K is a thirtieth of a heater sensor's code)
            offset = max(min(offset, START_SPAN_SHARE * (adc.hi - adc.lo)), START_CODES * adc.resolution)
        values[moved] += offset
    missing = [s for s in ports.states if s not in values]
    if missing:
        raise PendcError(f"operating point '{name}' gives no value of reported state {missing[0]}")
    return tuple(values[s] for s in ports.states)


@dataclass(frozen=True)
class PointHold:
    """An operating point and its measured coordinates, for :func:`hold_summary` of a run some
    other controller made from it (a socket client holding a crane's load hanging)."""

    point: str
    coords: tuple


def point_hold(model: PlantModel, point: str) -> PointHold | None:
    """The :class:`PointHold` of ``point``, or None where its coordinates are not all measured."""
    name, state = operating_state(model, point)
    try:
        return PointHold(name, measured_coordinates(model, state, name))
    except PendcError:
        return None


def hold_summary(run, controller, last_seconds: float = 1.0) -> dict:
    """How closely a run held the operating point of ``controller`` (an :class:`OperatingPointLqr`
    or a :class:`PointHold`): for each measured position, the largest distance from the point's
    value (wrapped for a periodic one) over the run's last ``last_seconds``
    (``hold_<state>_<unit>``), with the point's name."""
    out = {"operating_point": controller.point}
    tail = run.t >= (run.t[-1] if run.t.size else 0.0) - last_seconds
    for c, key in zip(controller.coords, hold_keys(controller)):
        column = np.asarray(run.column(c.position))[tail]
        dev = np.array([abs(wrap(v - c.target, c.period)) for v in column])
        out[key] = float(dev.max()) if dev.size else None
    return out


def hold_keys(controller) -> tuple:
    """The keys of :func:`hold_summary`'s distances, one per measured position (``hold_<state>_<unit>``)."""
    return tuple(unit_key(f"hold_{c.position}", c.unit) for c in controller.coords)

