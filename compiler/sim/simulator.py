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
from ..model.sensors import ADC
from .encoders import quantize as to_counts
from ..native.build import kernel_function
from .kernel import stored_kernel_source
from .signals import PlantSignals, signals_of

METHODS = ("euler", "rk4")
MAX_STEPS = 1e10   # about ten minutes of compiled stepping


@dataclass(frozen=True)
class SimResult:
    """Simulated trajectory at the input's sample times.

    ``states`` maps each state name (each position, its rate ``d<position>`` and any extra
    state such as a drive lag's) to an array the length of ``t``.
    ``outputs`` holds what the sensors read (each position plus any sensor offset of the
    model, quantised when asked); without sensor effects or quantisation it equals the
    states. ``signals`` names the plant's input, positions and rates (the default model's
    when not given).
    """

    t: np.ndarray
    u: np.ndarray
    states: dict
    outputs: dict = None
    signals: PlantSignals = None

    def __getitem__(self, name: str) -> np.ndarray:
        return self.states[name]

    def measured(self, name: str) -> np.ndarray:
        """What the sensor of position ``name`` reads."""
        return (self.outputs or self.states)[name]

    def columns(self) -> dict:
        """Time, the input, the positions (as the sensors read them), then their rates: the
        column order of the CLI's output file (the interface's names)."""
        sig = signals_of(self.signals)
        return {"t": self.t, sig.input: self.u, **{p: self.measured(p) for p in sig.positions},
                **{r: self.states[r] for r in sig.rates}}


class Simulator:
    """Simulate ``model`` on sampled inputs.

    >>> sim = Simulator(load_model(), dt=1e-6, method="euler")
    >>> res = sim(t, u)                       # starts at rest in the centre
    >>> res = sim(t, u, x0=(0, 0, 0.1, 0))    # the reported states: each position followed by its rate
    >>> res = sim(t, u, params={"b": 900})    # same compiled kernel, new values (any parameter)

    ``quantize=True`` rounds each position a sensor reads to its ×4 encoder counts (for
    each position the step of the sensor its plant file declares), counted from the initial state as the real encoders do. ``x0`` is the true state;
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
        self.signals = signals_of(model)
        clamped = self.signals.clamped()
        # the source text, not the compiled function: a model goes to other processes (pickled)
        source = model.derived(f"float kernel source, {clamped} clamped",
                               lambda m: stored_kernel_source(m.equations, clamped))
        self._simulate = kernel_function(source, "pendc_kernel", "simulate")
        eq = model.equations
        self._start_names = self.state_names[:len(self.state_names) - len(eq.initial)]
        self._initial = {st.name: st.initial for st in model.interface.states}
        self._offsets = tuple((name, eq.params.index(expr) if expr in eq.params else None, expr)
                              for name, expr in eq.sensor_offsets)
        self.reading_limits = converter_limits(self.signals)

    def offset_values(self, p: np.ndarray) -> dict:
        """``{state name: offset}`` of the sensor offsets for parameter vector ``p``."""
        out = dict.fromkeys(self.signals.positions, 0.0)
        for name, index, expr in self._offsets:
            if index is None:   # an offset that is an expression of parameters, not one of them
                expr = expr.subs(dict(zip(self.model.equations.params, p)))
                out[name] += float(expr)
            else:
                out[name] += float(p[index])
        return out

    def reading(self, position: str, values: np.ndarray, limits: dict | None = None) -> np.ndarray:
        """What the sensor of ``position`` reads of ``values`` (the position plus its offset) where
        ``limits`` (:meth:`limits_reached`) says its converter's range is reached: there its reading
        stops at the middle of its end code; elsewhere, and for an encoder, ``values``."""
        bounds = (limits or {}).get(position)
        return values if bounds is None else np.clip(values, *bounds)

    def limits_reached(self, measured: dict) -> dict:
        """The :attr:`reading_limits` of the converter-read positions whose ``measured`` values reach
        an end code: a model's reading past the range is compared as the converter's end there (a
        maglev's ball on its post, read past the range with an offset). Where the data stay inside,
        a model that leaves the range is wrong by all its distance, and is not clipped."""
        out = {}
        for p, (lo, hi) in self.reading_limits.items():
            y = measured.get(p)
            tol = 1e-6 * (hi - lo)
            # the end code's own value is the last (first) reading: values past it are no converter's
            if y is not None and len(y) and (abs(float(np.max(y)) - hi) <= tol or abs(float(np.min(y)) - lo) <= tol):
                out[p] = (lo, hi)
        return out

    def initial_state(self) -> np.ndarray:
        """Where a run starts unless told otherwise: each state's ``initial`` (zero in a
        mechanical file), in the order of ``x0``."""
        return np.array([self._initial.get(name, 0.0) for name in self.signals.mechanical], dtype=np.float64)

    def true_state(self, measured: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
        """The true reported state (each position, then its rate) whose sensors read ``measured``
        (inverse of the output map)."""
        off = self.offset_values(self.param_vector if p is None else p)
        s = np.array(measured, dtype=np.float64)
        for name, value in off.items():
            s[self.signals.index(name)] -= value
        return s

    def initial_vector(self, positions: dict, rates: dict, k: int = 0) -> np.ndarray:
        """The reported state at sample ``k`` from per-position arrays of measured positions and
        of their rates (a position without a rate state contributes only itself)."""
        s = np.zeros(len(self.signals.mechanical))
        for p in self.signals.positions:
            s[self.signals.index(p)] = positions[p][k]
            r = self.signals.rate(p)
            if r is not None:
                s[self.signals.index(r)] = rates[p][k]
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
        out = np.empty((len(t), len(self.state_names)))
        rows = self._simulate(_frozen(t), _frozen(u), _frozen(self._kernel_start(s0)), _frozen(p), self.dt,
                              self.method == "rk4", int(k0), out)
        return out, rows

    def _kernel_start(self, s0) -> np.ndarray:
        """The kernel's start vector (every state but the lags, which start from the input) from
        ``s0``, the reported states (:attr:`PlantSignals.mechanical`): a state the hardware does
        not report (``output = false``) starts at its ``initial``. The kernel read a shorter
        vector past its end."""
        s0 = np.asarray(s0, dtype=np.float64)
        if s0.size == len(self._start_names):
            return s0
        full = np.array([self._initial.get(name, 0.0) for name in self._start_names])
        for i, name in enumerate(self.signals.mechanical):
            full[self._start_names.index(name)] = s0[i]
        return full

    def _why_diverged(self, out: np.ndarray, valid: int) -> str:
        """Forward Euler's instability at this step where that is the cause, else the last finite
        state and the square-root hint."""
        if self.method == "euler":
            from ..model.modes import euler_instability

            words = euler_instability(self.model, self.dt)
            if words:
                return f": {words}"
        return _last_finite(self, out, valid)

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
        names = self.signals.mechanical
        s0 = self.initial_state() if x0 is None else np.asarray(x0, dtype=np.float64)
        if s0.shape != (len(names),) or not np.all(np.isfinite(s0)):
            raise PendcError(f"initial state must be {len(names)} finite numbers ({', '.join(names)})")
        out, valid = self.raw(t, u, s0, self.vector(params))
        if valid < t.size:
            raise PendcError(f"simulation diverged (non-finite state) at t = {t[valid]:.6g} s{self._why_diverged(out, valid)}")
        states = {name: out[:, i].copy() for i, name in enumerate(self.state_names)}
        off = self.offset_values(self.vector(params))
        outputs = {p: self.reading(p, states[p] + off[p], self.reading_limits if quantize else None)
                   for p in self.signals.positions}
        if quantize:
            for p in self.signals.positions:
                step = self.signals.resolution(p)
                if step is not None:
                    outputs[p], states[p] = to_counts(outputs[p], step), to_counts(states[p], step)
        return SimResult(t=t, u=u, states=states, outputs=outputs, signals=self.signals)

    run = __call__


def converter_limits(signals) -> dict:
    """``{position: (low, high)}`` of each converter-read position: the middles of its converter's
    first and last codes, where its reading stops (a ball on a post past the converter's range)."""
    out = {}
    for p in signals.positions:
        sensor = signals.interface.sensor_of(p)
        if sensor is not None and sensor.kind == ADC:
            half = 0.5 * (sensor.hi - sensor.lo) / (1 << sensor.bits)
            out[p] = (sensor.lo + half, sensor.hi - half)
    return out


def _last_finite(sim: "Simulator", out: np.ndarray, valid: int) -> str:
    """The states at the last finite sample, and what commonly breaks there: a square root or a
    logarithm of a state that went negative (a tank run dry: sqrt(Max(L, 0)) holds it at zero)."""
    if valid == 0:
        return ""
    row = out[valid - 1]
    values = ", ".join(f"{name} = {float(v):.4g}" for name, v in zip(sim.state_names, row))
    return (f"; last finite state {values} (a square root or a logarithm of a state that went below "
            f"zero? write sqrt(Max(x, 0)))")


def sensor_offsets(model: PlantModel) -> dict:
    """``{position: offset}``: what each position's sensor adds to it (the model's sensor offset
    effects at its own parameter values; 0 where there is none), without compiling a kernel."""
    out = dict.fromkeys(signals_of(model).positions, 0.0)
    out.update(model.sensor_offset_values())
    return out


def _frozen(a) -> np.ndarray:
    """``a`` as a contiguous float64 array the kernel cannot write: numba compiles one machine
    code per argument type, and read-only is part of the type, so writable and read-only inputs
    (a recording's frozen columns, a fresh array) compiled the kernel twice or three times."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.flags.writeable:
        a = a.view()
        a.flags.writeable = False
    return a


def simulate(model: PlantModel, t, u, x0=None, dt: float = 1e-6, method: str = "euler",
             quantize: bool = False) -> SimResult:
    """One-shot convenience wrapper around :class:`Simulator`."""
    return Simulator(model, dt=dt, method=method)(t, u, x0=x0, quantize=quantize)
