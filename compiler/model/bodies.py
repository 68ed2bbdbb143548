"""The rigid bodies a model file can select (``[plant] body = "..."``), each with its constants,
effect catalogue, experiments, equations and plant interface.

A :class:`~pendc.model.plant.PlantModel` names its body; everything body-specific it needs
(which constants ``[plant]`` must hold, which effects exist, how the equations and the
interface are built) is looked up here, so a third plant is a third entry, not a new code
path. The cart-pendulum (the SCT rig) is the default: a model file without ``body`` is one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..errors import PendcError
from .cart import PLANT_CONSTANTS, build_cart_equations, build_cart_interface
from .effects import CATALOGUE, CONFLICTS
from .experiments import EXPERIMENTS, FURUTA_EXPERIMENTS
from .furuta import CONSTANTS as FURUTA_CONSTANTS
from .furuta_effects import FURUTA_CATALOGUE, FURUTA_CONFLICTS
from .furuta_plant import build_furuta_equations, build_furuta_interface
from .identification_notes import CART_NOTES, FURUTA_NOTES, IdentificationNotes

DEFAULT_BODY = "cart_pendulum"


@dataclass(frozen=True)
class Body:
    """One rigid body: ``constants`` (name -> (unit, meaning)) that ``[plant]`` holds, its
    effect ``catalogue`` (name -> class) and ``conflicts`` (pairs of effects that define the
    same part), its ``experiments`` (name -> what was held or removed), the functions
    that build a model's equations and plant interface, and the ``notes`` identification
    reports about its effects (:mod:`pendc.model.identification_notes`)."""

    name: str
    summary: str
    constants: dict
    catalogue: dict
    conflicts: tuple
    experiments: dict
    equations: Callable
    interface: Callable
    notes: IdentificationNotes


BODIES: dict[str, Body] = {
    "cart_pendulum": Body("cart_pendulum", "servo cart on a ball screw with a free pendulum (the SCT rig)",
                          PLANT_CONSTANTS, CATALOGUE, CONFLICTS, EXPERIMENTS,
                          build_cart_equations, build_cart_interface, CART_NOTES),
    "furuta": Body("furuta", "rotary (Furuta) pendulum: a motor-driven arm with a free pendulum at its end",
                   FURUTA_CONSTANTS, FURUTA_CATALOGUE, FURUTA_CONFLICTS, FURUTA_EXPERIMENTS,
                   build_furuta_equations, build_furuta_interface, FURUTA_NOTES),
}


def body_named(name, source: str = "") -> Body:
    """The body called ``name``; a one-line :class:`PendcError` naming the known ones if none."""
    pre = f"{source}: " if source else ""
    if not isinstance(name, str):
        raise PendcError(f"{pre}plant.body must be a string naming the rigid body, got {name!r}")
    if name not in BODIES:
        raise PendcError(f"{pre}plant.body = '{name}' is not a rigid body pendc knows (known: {', '.join(BODIES)})")
    return BODIES[name]


def catalogue_of(body: str) -> dict:
    """The effect catalogue (name -> class) of the body called ``body``."""
    return body_named(body).catalogue


def default_body() -> Body:
    """The body a model file without ``[plant] body`` is (the cart-pendulum)."""
    return BODIES[DEFAULT_BODY]
