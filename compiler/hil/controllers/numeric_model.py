"""A model's state equations as numeric functions: the derivatives and their Jacobian.

The controllers' design (which coordinate is the pendulum, the linearisations at the hanging
and the upright rest) evaluates the same sympy equations at a few points. They are inlined,
given the parameter values, differentiated and lambdified once here, in the order of
``model.equations.states``, and shared by every evaluation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import sympy as sp

from ...model.modes import without_delta
from ...model.plant import PlantModel


# The math printer's names bound to NumPy's functions. The swing-up evaluates ``derivatives``
# twice every control period; NumPy's printer writes a Piecewise (a friction law, end stops) as
# ``numpy.select`` over broadcast arrays, about 150 us a call on the rig model and most of a
# run's time. The math printer writes it as a conditional expression (17 us). The functions stay
# NumPy's and the arguments NumPy scalars (a division by zero gives inf, not an exception), so
# every value is the one NumPy's printer gives (tests/test_hil_numeric_model.py).
NUMPY_FUNCTIONS = {name: getattr(np, numpy_name) for name, numpy_name in (
    ("sin", "sin"), ("cos", "cos"), ("tan", "tan"), ("asin", "arcsin"), ("acos", "arccos"), ("atan", "arctan"),
    ("atan2", "arctan2"), ("sinh", "sinh"), ("cosh", "cosh"), ("tanh", "tanh"), ("exp", "exp"), ("expm1", "expm1"),
    ("log", "log"), ("log1p", "log1p"), ("sqrt", "sqrt"), ("hypot", "hypot"), ("copysign", "copysign"),
    ("fabs", "fabs"), ("floor", "floor"), ("ceil", "ceil"))}


def scalar_function(args, exprs):
    """``exprs`` of the symbols ``args`` as a Python function for scalar arguments: the math
    printer's conditional expressions, NumPy's functions (see ``NUMPY_FUNCTIONS``)."""
    return sp.lambdify(args, exprs, modules=[NUMPY_FUNCTIONS, "math"])


@dataclass(frozen=True)
class NumericModel:
    """``derivatives(state, u)`` and ``jacobian(state, u)`` (columns: the states, then the input)
    of one model, states in the order of ``names`` (the equations')."""

    names: tuple
    plant: str
    _f: Callable
    _jac: Callable

    @classmethod
    def of(cls, model: PlantModel) -> "NumericModel":
        """Inline, substitute the parameter values, differentiate and lambdify ``model``'s equations
        (once per model: the roles, the linearisations and the controllers of a run all ask)."""
        return model.derived("numeric_model", cls._make)

    @classmethod
    def _make(cls, model: PlantModel) -> "NumericModel":
        eq = model.equations
        values = {p: sp.Float(v) for p, v in zip(eq.params, model.parameter_vector())}
        rhs = [eq.inline(d).xreplace(values) for d in eq.derivatives]
        variables = list(eq.states) + [eq.input]
        jac = [[without_delta(sp.diff(f, v)) for v in variables] for f in rhs]
        return cls(names=tuple(s.name for s in eq.states), plant=model.interface.name,
                   _f=scalar_function(variables, rhs), _jac=scalar_function(variables, jac))

    def index(self, state: str) -> int:
        """Position of ``state`` in the state vector."""
        return self.names.index(state)

    def derivatives(self, state, u: float) -> np.ndarray:
        """d(state)/dt at ``state`` (a sequence in ``names`` order) and input ``u``."""
        return np.array(self._f(*np.asarray(state, dtype=float), np.float64(u)), dtype=float)

    def jacobian(self, state, u: float) -> np.ndarray:
        """d(derivatives)/d(state, u): one row per state, one column per state and the input last."""
        return np.array(self._jac(*np.asarray(state, dtype=float), np.float64(u)), dtype=float)
