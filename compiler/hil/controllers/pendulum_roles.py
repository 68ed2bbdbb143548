"""The roles of a pendulum plant's coordinates: the one the input drives and the pendulum's angle.

The balance and swing-up controllers address the state vector by role, never by a state's
name: the **actuated** coordinate (a cart's position, a rotary arm's angle) and the
**pendulum** angle, each with its rate, its unit and its index in the model's state vector.
The plant interface gives the measured positions (its encoders' states), their rates
(``derivative_of``), units and periods; which of the two is the pendulum is physics, read off
the model's own equations: the pendulum's angle is the measured *periodic* position that
gravity restores (its acceleration at rest falls as the angle grows: d²q/dt² = -k q with
k > 0) and whose generalized force the input does not enter (:func:`driven_positions`), the
actuated one is the other measured position (a cart or an arm, on which gravity does not act).
The angle counts from hanging down, so the upright is half a turn away.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import PendcError
from ...model.plant import PlantModel
from .numeric_model import NumericModel

PROBE = 1e-4   # a small displacement (in the position's unit) for the stiffness at rest
PIVOT_STIFFNESS = 0.01   # of the pendulum's: the most gravity may hold the driven coordinate (a cart, a level arm: 0)


@dataclass(frozen=True)
class Coordinate:
    """A measured position and its rate: names, units, the position's period (None for a
    translation) and their indices in the model's state vector."""

    position: str
    rate: str
    unit: str
    rate_unit: str
    period: float | None
    index: int
    rate_index: int


@dataclass(frozen=True)
class PendulumRoles:
    """The coordinates of a pendulum plant by role (see the module docstring)."""

    plant: str
    actuated: Coordinate
    pendulum: Coordinate

    @property
    def upright(self) -> float:
        """The pendulum angle at the upright: half a period from hanging down."""
        return 0.5 * self.pendulum.period

    def order(self, n_states: int) -> list:
        """Indices into the state vector of (actuated position, its rate, pendulum angle, its
        rate) followed by every other state (a motor lag...)."""
        main = [self.actuated.index, self.actuated.rate_index, self.pendulum.index, self.pendulum.rate_index]
        return main + [i for i in range(n_states) if i not in main]


def _coordinate(iface, numeric: NumericModel, position: str) -> Coordinate:
    spec = iface.state(position)
    rate = next((s for s in iface.states if s.derivative_of == position), None)
    if rate is None:
        raise PendcError(f"the swing-up and balance controllers drive a pendulum, and plant '{iface.name}' has "
                         f"no rate of its measured '{position}' (not a mechanism): use --controller lqr at an "
                         f"operating point, or hold")
    return Coordinate(position, rate.name, spec.unit, rate.unit, spec.period,
                      numeric.index(position), numeric.index(rate.name))


def driven_positions(model: PlantModel) -> set:
    """The positions whose generalized force the input enters (directly or through intermediates
    and effects such as a drive law): a pendulum is not one of them, however gravity acts on it
    (a helicopter's pitch, driven by its rotor, is not the pendulum of its yaw)."""
    d = model.definition
    depends = {model.interface.input.name}
    for sym, expr in model.equations.assignments:
        if {str(x) for x in expr.free_symbols} & depends:
            depends.add(sym.name)
    forces = {c.name: c.force for c in d.coordinates}
    forces.update({s.rate_of: s.force for s in d.states if s.rate_of and s.force})
    return {position for position, force in forces.items() if force in depends}


def restoring_stiffness(numeric: NumericModel, coord: Coordinate) -> float:
    """-d(acceleration)/d(position) of ``coord`` at rest (every state 0, no input): positive
    for a pendulum hanging under gravity, zero for a free cart or arm."""
    n = len(numeric.names)
    accel = []
    for sign in (1.0, -1.0):
        state = np.zeros(n)
        state[coord.index] = sign * PROBE
        accel.append(numeric.derivatives(state, 0.0)[coord.rate_index])
    return -(accel[0] - accel[1]) / (2 * PROBE)


def pendulum_roles(model: PlantModel, numeric: NumericModel | None = None) -> PendulumRoles:
    """The actuated coordinate and the pendulum of ``model`` (see the module docstring); a
    one-line :class:`PendcError` for a plant that is not one pendulum on one driven coordinate."""
    iface = model.interface
    numeric = numeric or NumericModel.of(model)
    measured = [_coordinate(iface, numeric, s.state) for s in iface.sensors]
    driven = driven_positions(model)
    pendulums = [c for c in measured if c.period is not None and c.position not in driven
                 and restoring_stiffness(numeric, c) > 0]
    others = [c for c in measured if c not in pendulums]
    # the input must turn a link gravity does not hold (a level arm, a wheel): a Pendubot's driven
    # shoulder is a pendulum itself, and the swing-up threw its upright arm down (a translation is
    # a pivot whatever holds it: a cart on a centring spring is still a cart)
    if len(measured) == 2 and len(pendulums) == 1 and others[0].period is not None:
        held = restoring_stiffness(numeric, others[0])
        if abs(held) > PIVOT_STIFFNESS * restoring_stiffness(numeric, pendulums[0]):
            raise PendcError(f"the swing-up and balance controllers drive one pendulum on a coordinate gravity does "
                             f"not hold; in plant '{iface.name}' gravity holds the driven {others[0].position} too "
                             f"(a second pendulum, not a cart or a level arm)")
    if len(measured) != 2 or len(pendulums) != 1:
        what = ", ".join(c.position for c in measured) or "nothing"
        raise PendcError(f"the swing-up and balance controllers drive one pendulum (a measured angle that gravity "
                         f"restores) on one other measured coordinate; plant '{iface.name}' "
                         f"({model.experiment} experiment) measures {what} and "
                         f"{len(pendulums)} of them is such an angle")
    return PendulumRoles(plant=iface.name, actuated=others[0], pendulum=pendulums[0])
