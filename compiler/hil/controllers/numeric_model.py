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

from ...model.plant import PlantModel


def _no_delta(expr: sp.Expr) -> sp.Expr:
    # d sign(v)/dv is a DiracDelta, zero away from v = 0 where a Jacobian is evaluated
    return expr.replace(lambda e: isinstance(e, sp.DiracDelta), lambda e: sp.Integer(0))


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
        """Inline, substitute the parameter values, differentiate and lambdify ``model``'s equations."""
        eq = model.equations
        values = {p: sp.Float(v) for p, v in zip(eq.params, model.parameter_vector())}
        rhs = [eq.inline(d).xreplace(values) for d in eq.derivatives]
        variables = list(eq.states) + [eq.input]
        jac = [[_no_delta(sp.diff(f, v)) for v in variables] for f in rhs]
        return cls(names=tuple(s.name for s in eq.states), plant=model.interface.name,
                   _f=sp.lambdify(variables, rhs, modules=["numpy"]),
                   _jac=sp.lambdify(variables, jac, modules=["numpy"]))

    def index(self, state: str) -> int:
        """Position of ``state`` in the state vector."""
        return self.names.index(state)

    def derivatives(self, state, u: float) -> np.ndarray:
        """d(state)/dt at ``state`` (a sequence in ``names`` order) and input ``u``."""
        return np.array(self._f(*state, u), dtype=float)

    def jacobian(self, state, u: float) -> np.ndarray:
        """d(derivatives)/d(state, u): one row per state, one column per state and the input last."""
        return np.array(self._jac(*state, u), dtype=float)
