"""Float reference simulator of any plant model.

Fixed step (default 1 us forward Euler, the thesis' hardware integrator; RK4
selectable), zero-order-hold input, the velocity clamp after every step, and
optional encoder quantisation of the outputs. The right-hand side is compiled
once per model structure (see :mod:`pendc.sim.kernel`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import PendcError
from ..model.plant import PlantModel
from .encoders import quantize_theta, quantize_x
from .kernel import load_kernel

METHODS = ("euler", "rk4")
MAX_STEPS = 1e10   # about ten minutes of compiled stepping


@dataclass(frozen=True)
class SimResult:
    """Simulated trajectory at the input's sample times.

    ``states`` maps each state name (``x``, ``dx``, ``theta``, ``dtheta`` and any
    extra state such as ``F_m``) to an array the length of ``t``. ``outputs`` holds
    what the sensors read (``x`` and ``theta`` plus any sensor offset of the model,
    quantised when asked); without sensor effects or quantisation it equals the states.
    """

    t: np.ndarray
    u: np.ndarray
    states: dict
    outputs: dict = None

    def __getitem__(self, name: str) -> np.ndarray:
        return self.states[name]

    def measured(self, name: str) -> np.ndarray:
        """What the sensor of position ``name`` (x or theta) reads."""
        return (self.outputs or self.states)[name]

    def columns(self) -> dict:
        """``t, u, x, theta, dx, dtheta`` in the column order of the CLI's output file
        (positions as the sensors read them)."""
        return {"t": self.t, "u": self.u, "x": self.measured("x"), "theta": self.measured("theta"),
                "dx": self.states["dx"], "dtheta": self.states["dtheta"]}


class Simulator:
    """Simulate ``model`` on sampled inputs.

    >>> sim = Simulator(load_model(), dt=1e-6, method="euler")
    >>> res = sim(t, u)                       # starts at rest in the centre
    >>> res = sim(t, u, x0=(0, 0, 0.1, 0))    # (x, dx, theta, dtheta)
    >>> res = sim(t, u, params={"b_x": 900})  # same compiled kernel, new values

    ``quantize=True`` rounds x and theta to the ×4 encoder counts (2.5 um, 0.314 mrad),
    counted from the initial state as the real encoders do. ``x0`` is the true state;
    :meth:`true_state` turns measured positions into it (subtracting sensor offsets).
    The model's experiment (:meth:`PlantModel.for_experiment`) is part of its equations.
    """

    def __init__(self, model: PlantModel, dt: float = 1e-6, method: str = "euler"):
        if method not in METHODS:
            raise PendcError(f"unknown integration method '{method}' (choose {' or '.join(METHODS)})")
        if not (np.isfinite(dt) and 0 < dt <= 1e-2):
            raise PendcError(f"step dt must be in (0, 0.01] s, got {dt}")
        self.model = model
        self.dt = float(dt)
        self.method = method
        self.state_names = tuple(s.name for s in model.equations.states)
        self.param_names = tuple(s.name for s in model.equations.params)
        self.param_vector = np.asarray(model.parameter_vector(), dtype=np.float64)
        self._kernel = load_kernel(model.equations)
        eq = model.equations
        self._offsets = tuple((name, eq.params.index(expr) if expr in eq.params else None, expr)
                              for name, expr in eq.sensor_offsets)

    def offset_values(self, p: np.ndarray) -> dict:
        """``{state name: offset}`` of the sensor offsets for parameter vector ``p``."""
        out = {"x": 0.0, "theta": 0.0}
        for name, index, expr in self._offsets:
            if index is None:   # an offset that is an expression of parameters, not one of them
                expr = expr.subs(dict(zip(self.model.equations.params, p)))
                out[name] += float(expr)
            else:
                out[name] += float(p[index])
        return out

    def true_state(self, measured: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
        """The true ``(x, dx, theta, dtheta)`` whose sensors read ``measured`` (inverse of the output map)."""
        off = self.offset_values(self.param_vector if p is None else p)
        s = np.array(measured, dtype=np.float64)
        s[0] -= off["x"]
        s[2] -= off["theta"]
        return s

    def vector(self, params: dict | None = None) -> np.ndarray:
        """The kernel's parameter vector with some values replaced (no model rebuild, no recompile)."""
        p = self.param_vector.copy()
        for name, value in (params or {}).items():
            if name not in self.param_names:
                raise PendcError(f"unknown parameter '{name}' for this model (known: {', '.join(self.param_names)})")
            p[self.param_names.index(name)] = float(value)
        return p

    def raw(self, t: np.ndarray, u: np.ndarray, s0: np.ndarray, p: np.ndarray, k0: int = 0) -> tuple[np.ndarray, int]:
        """Unchecked kernel call for inner loops (identification): states array and the
        number of valid rows (fewer than len(t) if the run diverged). The run starts at
        row ``k0`` from ``s0``; rows before it only give an input delay its history."""
        return self._kernel.simulate(t, u, s0, p, self.dt, self.method == "rk4", k0)

    def __call__(self, t, u, x0=None, params: dict | None = None, quantize: bool = False) -> SimResult:
        t = np.ascontiguousarray(t, dtype=np.float64)
        u = np.ascontiguousarray(u, dtype=np.float64)
        if t.ndim != 1 or t.shape != u.shape or t.size < 1:
            raise PendcError("t and u must be 1-D arrays of the same, non-zero length")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(u))):
            raise PendcError("sample times and inputs must be finite numbers")
        if t.size > 1 and not np.all(np.diff(t) > 0):
            raise PendcError("sample times must be strictly increasing")
        if (t[-1] - t[0]) / self.dt > MAX_STEPS:
            raise PendcError(f"{(t[-1] - t[0]) / self.dt:.3g} steps of {self.dt:g} s requested; "
                             f"the limit is {MAX_STEPS:.0e} (use a larger dt or a shorter input)")
        s0 = np.zeros(4) if x0 is None else np.asarray(x0, dtype=np.float64)
        if s0.shape != (4,) or not np.all(np.isfinite(s0)):
            raise PendcError("initial state must be four finite numbers (x, dx, theta, dtheta)")
        out, valid = self.raw(t, u, s0, self.vector(params))
        if valid < t.size:
            raise PendcError(f"simulation diverged (non-finite state) at t = {t[valid]:.6g} s")
        states = {name: out[:, i].copy() for i, name in enumerate(self.state_names)}
        off = self.offset_values(self.vector(params))
        outputs = {"x": states["x"] + off["x"], "theta": states["theta"] + off["theta"]}
        if quantize:
            outputs = {"x": quantize_x(outputs["x"]), "theta": quantize_theta(outputs["theta"])}
            states["x"], states["theta"] = quantize_x(states["x"]), quantize_theta(states["theta"])
        return SimResult(t=t, u=u, states=states, outputs=outputs)

    run = __call__


def simulate(model: PlantModel, t, u, x0=None, dt: float = 1e-6, method: str = "euler",
             quantize: bool = False) -> SimResult:
    """One-shot convenience wrapper around :class:`Simulator`."""
    return Simulator(model, dt=dt, method=method)(t, u, x0=x0, quantize=quantize)
