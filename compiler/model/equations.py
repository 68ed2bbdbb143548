"""The symbolic state equations of one plant model (:class:`Equations`), whatever its body."""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

DEFAULT_EXPERIMENT = "free"     # the experiment in which everything moves (every plant has it)


@dataclass(frozen=True)
class Equations:
    """Symbolic state equations of one model.

    ``assignments`` are ``(symbol, expr)`` pairs in evaluation order; each expr uses
    states, the input, parameters and earlier assignments. ``derivatives[i]`` is
    d/dt of ``states[i]``; the first four states are the rigid body's two coordinates, each
    followed by its rate (q, dq for each coordinate q). ``input`` is the voltage
    as the plant sees it (after any transport delay ``delay``, which the simulator applies).
    ``velocity_bound`` clamps |states[1]| after every integration step. ``initial`` gives the
    initial value of each extra state (beyond the first four) from the input and parameters.
    ``sensor_offsets`` is the measured-output map: ``(state name, offset)`` pairs, the
    sensor of that position reading state + offset (parameters only, so the inverse, the
    true state from a measured one, is a subtraction). ``experiment`` names what was held
    or removed (a plant file's ``[experiments]``); the parameters are the same in every one.
    ``measured`` names the positions a run of that experiment measures.
    """

    states: tuple
    input: sp.Symbol
    params: tuple
    assignments: tuple
    derivatives: tuple
    initial: tuple = ()
    velocity_bound: sp.Expr | None = None
    delay: sp.Expr | None = None
    sensor_offsets: tuple = ()
    experiment: str = DEFAULT_EXPERIMENT
    measured: tuple = ()

    def outputs(self) -> tuple:
        """Names of the positions a run of this experiment measures (those its plant file's experiment does not hold)."""
        return self.measured

    def inline(self, expr: sp.Expr) -> sp.Expr:
        """``expr`` with every assignment symbol replaced by its definition."""
        # xreplace, not subs: the symbols are atoms, and on a chain of links' equations subs is
        # 16 times slower (its pattern matching walks every subtree)
        for sym, value in reversed(self.assignments):
            expr = expr.xreplace({sym: value})
        return expr

    def assignment(self, name: str) -> sp.Expr:
        """The expression bound to the named intermediate ``name`` (KeyError if none)."""
        for sym, value in self.assignments:
            if sym.name == name:
                return value
        raise KeyError(name)
