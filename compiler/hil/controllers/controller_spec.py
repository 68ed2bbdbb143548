"""``--controller builtin|swing-up|balance|lqr[:POINT]|hold|package.module:Class``: find and build a controller.

``swing-up`` and ``balance`` drive any plant that is one pendulum on one driven coordinate
(the cart-pendulum, the Furuta pendulum: :mod:`pendc.hil.controllers.pendulum_roles`); ``lqr`` is the
LQR about the plant file's first operating point (``lqr:NAME``: about operating point NAME,
:mod:`pendc.hil.controllers.operating_point_lqr`) and drives any plant that has one; ``builtin`` is the
pendulum supervisor (swing up, then balance) on a single-pendulum plant and ``lqr`` on any
other plant with an operating point; ``hold`` (a PD hold of the first measured position at
its power-on value, :mod:`pendc.hil.controllers.position_hold`) drives any plant.

A user's class plugs in with no change to pendc: it needs ``reset()`` and
``step(measurement) -> volts``; its constructor may take ``model`` (the
:class:`~pendc.model.plant.PlantModel` of ``--model``) and/or ``period`` (the control
period in s) as keyword arguments, and gets whichever of the two it names. The
current folder is searched first, so ``my_ctrl:MyController`` finds ``./my_ctrl.py``.
"""

from __future__ import annotations

import importlib
import inspect
import os
import sys

from ...errors import PendcError
from ...model.plant import PlantModel
from .pendulum import EnergySwingUp, LqrBalance, PendulumConstants, Supervisor
from .numeric_model import NumericModel
from .operating_point_lqr import OperatingPointLqr, operating_point_names
from .pendulum_roles import pendulum_roles
from .position_hold import PositionHold

BUILTIN_CONTROLLERS = {
    "builtin": Supervisor,      # single pendulum: swing up, then balance; other plants: lqr
    "swing-up": EnergySwingUp,  # energy pumping only (Fig. IV.22)
    "balance": LqrBalance,      # LQR only
    "lqr": OperatingPointLqr,   # any plant: LQR about the file's first operating point (lqr:NAME: another)
    "hold": PositionHold,       # any plant: PD on the first measured position
}


def make_controller(spec: str, model: PlantModel, period: float = 1e-3, position_ref=0.0,
                    excursions: dict | None = None):
    """The controller that ``spec`` names, designed for ``model`` at ``period`` (``position_ref``:
    the balance's set point of the actuated position; ``excursions``: the LQR's weights by name,
    :class:`OperatingPointLqr`, for ``lqr`` only)."""
    if excursions and not (spec == "lqr" or spec.startswith("lqr:")):
        raise PendcError(f"--excursion sets the weights of --controller lqr, not of '{spec}'")
    if spec == "lqr" or spec.startswith("lqr:"):
        point = spec.partition(":")[2] or None
        return OperatingPointLqr(model, period, point, excursions=excursions)
    if spec == "builtin":
        numeric = NumericModel.of(model)
        try:
            pendulum_roles(model, numeric)
        except PendcError as exc:
            if not operating_point_names(model):
                raise PendcError(f"--controller builtin: plant '{model.interface.name}' is not one pendulum on one "
                                 f"driven coordinate and declares no [operating_points] for an LQR; try "
                                 f"--controller hold") from exc
            try:
                return OperatingPointLqr(model, period, numeric=numeric)
            except PendcError as lqr_exc:
                raise PendcError(f"--controller builtin: plant '{model.interface.name}' ({model.experiment} "
                                 f"experiment) is not one pendulum on one driven coordinate, and {lqr_exc}; try "
                                 f"--controller hold") from None
        return Supervisor(PendulumConstants.from_model(model, numeric), period, position_ref=position_ref)
    if spec in BUILTIN_CONTROLLERS:
        cls = BUILTIN_CONTROLLERS[spec]
        if cls is PositionHold:
            return cls(model, period)
        consts = PendulumConstants.from_model(model)
        if cls is EnergySwingUp:
            return cls(consts, period)
        return cls(consts, period, position_ref=position_ref)
    cls = load_controller_class(spec)
    try:
        params = inspect.signature(cls).parameters
    except (TypeError, ValueError):
        params = {}
    offered = {"model": model, "period": period}
    kwargs = {k: v for k, v in offered.items() if k in params}
    try:
        controller = cls(**kwargs)
    except Exception as exc:   # any failure of user code becomes one line, not a traceback
        raise PendcError(f"--controller {spec}: constructing it failed: {type(exc).__name__}: {exc}") from None
    for method in ("reset", "step"):
        if not callable(getattr(controller, method, None)):
            raise PendcError(f"--controller {spec}: the class has no {method}() method "
                             "(a controller needs reset() and step(measurement) -> volts)")
    return controller


def load_controller_class(spec: str):
    """Import ``package.module:Class`` (the current folder first on the import path)."""
    module_name, sep, class_name = spec.partition(":")
    if not sep or not module_name or not class_name.isidentifier():
        raise PendcError(f"--controller must be {', '.join(BUILTIN_CONTROLLERS)}, lqr:POINT or package.module:Class, "
                         f"got {spec!r}")
    cwd = os.getcwd()
    added = cwd not in sys.path
    if added:
        sys.path.insert(0, cwd)
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        raise PendcError(f"--controller {spec}: no module named {exc.name!r}") from None
    except Exception as exc:   # a syntax or runtime error in the user's module
        raise PendcError(f"--controller {spec}: importing {module_name} failed: {type(exc).__name__}: {exc}") from None
    finally:
        if added:
            sys.path.remove(cwd)
    cls = getattr(module, class_name, None)
    if cls is None:
        raise PendcError(f"--controller {spec}: module {module_name} has no {class_name}")
    if not callable(cls):
        raise PendcError(f"--controller {spec}: {class_name} is not a class")
    return cls
