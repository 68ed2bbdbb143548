"""Plants that step: one interface for the float simulator, the golden model and the RTL.

A controller (or a scenario, or the socket server) is written once against
:class:`Plant`: ``reset()`` returns the state at power-on, ``step(u, n)`` holds the
input ``u`` (volts, zero-order hold) for ``n`` model steps and returns the state after
them. Every :class:`PlantState` carries the true states in SI units and the ×4 encoder
counts since reset, which is all a real controller sees.

``make_plant(kind, model)`` builds one: ``float`` (the compiled float simulator),
``golden`` (the compiled core's integers, bit-exact with the Verilog), ``verilator`` and
``icarus`` (the generated RTL in lockstep, see :mod:`pendc.hil.plants.rtl_plant`).
"""

from __future__ import annotations

import numpy as np

from ...errors import PendcError
from ...model.plant import PlantModel
from .plant_state import (MAX_STEPS_PER_CALL, Plant, PlantState, check_initial, check_step_request,  # noqa: F401
                          encoder_counts, start_counts, x4_count_delta)   # (re-exported: the plants' shared names)

PLANT_KINDS = ("float", "golden", "verilator", "icarus")


def _step_source(n_states: int, n_params: int, n_start: int) -> str:
    """A stepping loop appended to the float kernel's module (it uses its ``rhs``/``bound``/``start``);
    ``start`` takes the first ``n_start`` states (the mechanical ones) and makes the rest."""
    from ...sim.kernel import integration_step, tuple_text as tup

    ns = n_states
    return f'''

@njit(cache=True)
def plant_start(s0, u0, p, out):
    """All states at power-on (into out) from the mechanical ones (extra states from the input)."""
    P = {tup(f"p[{i}]" for i in range(n_params))}
    S = start({tup(f"s0[{i}]" for i in range(n_start))}, u0, P)
    for i in range({ns}):
        out[i] = S[i]


@njit(cache=True)
def plant_advance(s, u, p, dt, use_rk4, out):
    """States after len(u) steps of dt from s, u[m] held over step m, into out; False if non-finite."""
    P = {tup(f"p[{i}]" for i in range(n_params))}
    S = {tup(f"s[{i}]" for i in range(ns))}
    h = dt
    h2 = 0.5 * dt
    h6 = dt / 6.0
    for m in range(u.shape[0]):
        uk = u[m]
{integration_step(ns, "        ")}    for i in range({ns}):
        out[i] = S[i]
    return math.isfinite({" + ".join(f"S[{i}]" for i in range(ns))})
'''


class FloatPlant:
    """The float simulator, stepped from its current state (1 us Euler by default, like the core).

    Extra states (a motor lag) carry over between steps; an input delay is applied from the
    history of inputs since reset (before reset the plant saw the first input). Encoder counts
    are those of a ×4 decoder on the absolute band grid, counted from reset; each converter's
    code is the interface's rule applied to its state plus its sensor offset (:meth:`~pendc.hil.plants.core_ports.AdcPorts.code`).
    ``initial`` (one value per reported state, in the plant interface's order, as the golden
    plant takes it) starts the mechanical states elsewhere than at rest at 0 (extra states such
    as a motor lag start from the first input; the encoders count from there).
    """

    def __init__(self, model: PlantModel, dt: float = 1e-6, method: str = "euler", initial: tuple | None = None):
        from ...native.build import kernel_function
        from ...sim.kernel import stored_kernel_source
        from ...sim.simulator import Simulator

        sim = Simulator(model, dt=dt, method=method)  # validates dt and method
        self.model = model
        self.dt = sim.dt
        self.method = method
        self._params = sim.param_vector
        eq = model.equations
        from .core_ports import CorePorts
        self.ports = CorePorts.of_interface(model.interface).with_offsets(model.sensor_offset_values())
        names = [s.name for s in eq.states]
        missing = [n for n in self.ports.states if n not in names]
        if missing:
            raise PendcError(f"the model has no state(s) {', '.join(missing)} its interface reports")
        self._index = {name: names.index(name) for name in self.ports.states}
        self._n_start = n_start = len(names) - len(eq.initial)    # the mechanical states; lags start from u
        if initial is None and any(s.initial for s in model.interface.states):
            # a state-equation file's initial values: where the hardware's registers reset
            initial = tuple(model.interface.state(name).initial for name in self.ports.states)
        self.initial = check_initial(self.ports, initial)
        start = dict(zip(self.ports.states, self.initial or ()))
        extra = [n for n, v in start.items() if v != 0.0 and names.index(n) >= n_start]
        if extra:
            raise PendcError(f"the float plant starts {', '.join(extra)} from the input, not from an initial value")
        initial = {st.name: st.initial for st in model.interface.states}    # a state not reported
        self._start = np.array([start.get(n, initial.get(n, 0.0)) for n in names[:n_start]], dtype=float)
        self._origin = {e.name: start.get(e.state, 0.0) for e in self.ports.encoders}
        clamped = next((st.name for st in model.interface.states if st.velocity_bound is not None), None)
        source = stored_kernel_source(eq, clamped) + _step_source(len(eq.states), len(self._params), n_start)
        self._plant_start = kernel_function(source, "pendc_plant", "plant_start")
        self._plant_advance = kernel_function(source, "pendc_plant", "plant_advance")
        values = model.parameter_values()
        self._delay_steps = (float(eq.delay.subs({s: values[s.name] for s in eq.delay.free_symbols}))
                             / self.dt if eq.delay is not None else 0.0)
        self.reset()

    def reset(self) -> PlantState:
        self._k = 0
        self._state = None            # all states; made at the first step, when u is known
        self._history = []            # (first step index, u) of each request, for an input delay
        if self.initial is None:
            return PlantState.at_rest(self.ports)
        return self._report(dict(zip(self.ports.states, self.initial)))

    def _report(self, values: dict) -> PlantState:
        """The plant state of reported ``values``: encoder counts since reset, converter codes."""
        return PlantState(t=self._k * self.dt, states=tuple(values.items()),
                          counts=tuple((e.name, encoder_counts(values[e.state], self._origin[e.name], e.resolution))
                                       for e in self.ports.encoders),
                          codes=tuple((a.name, a.code(values[a.state])) for a in self.ports.adcs))

    def _inputs(self, u: float, n: int) -> np.ndarray:
        """The input the plant sees at each of the next n steps (delayed if the model says so)."""
        if self._delay_steps <= 0:
            return np.full(n, u)
        starts = np.array([k for k, _ in self._history])
        values = np.array([v for _, v in self._history])
        seen = np.floor(np.arange(self._k, self._k + n) - self._delay_steps + 1e-3).astype(np.int64)
        idx = np.clip(np.searchsorted(starts, seen, side="right") - 1, 0, None)
        # forget requests no later step can still see
        keep = max(0, int(np.searchsorted(starts, self._k + n - self._delay_steps, side="right")) - 2)
        self._history = self._history[keep:]
        return values[idx]

    def step(self, u_volts: float, n_steps: int) -> PlantState:
        u, n = check_step_request(u_volts, n_steps)
        if self._state is None:
            self._state = np.empty(len(self.model.equations.states))
            self._plant_start(self._start, u, self._params, self._state)
        self._history.append((self._k, u))
        new = np.empty_like(self._state)
        ok = self._plant_advance(self._state, self._inputs(u, n), self._params, self.dt, self.method == "rk4", new)
        if not ok:
            raise PendcError(f"float plant diverged (non-finite state) before t = {(self._k + n) * self.dt:.6g} s")
        self._state = new
        self._k += n
        return self._report({name: float(new[i]) for name, i in self._index.items()})


def make_plant(kind: str, model: PlantModel | None = None, dt: float | None = None, **options) -> Plant:
    """A plant of ``kind`` (float, golden, verilator, icarus) for ``model`` (default: the default model),
    stepping every ``dt`` s (default: the core's, the plant file's ``[hardware] dt``, else 1e-6).

    ``options`` go to the plant's constructor: ``initial`` (the reported states, in order) for
    every kind; ``method`` for float; ``build`` (reuse a compiled
    build) and ``on_overflow`` ("error" or "mark") for golden and the RTL plants; ``bus`` and ``schedule`` (the build request; verilator defaults to the
    comb schedule, the fastest to simulate and bit-exact like every schedule) for the RTL plants;
    ``loadable`` for verilator (a harness whose registers ``load`` can write)."""
    if kind not in PLANT_KINDS:
        raise PendcError(f"unknown plant '{kind}' (choose {', '.join(PLANT_KINDS)})")
    if model is None:
        from ...model.modelfile import load_model
        model = load_model()
    if dt is None:
        from ...passes.pipeline import core_step
        dt = core_step(model)
    if kind == "float":
        return FloatPlant(model, dt=dt, **options)
    if kind == "golden":
        from .golden_plant import GoldenPlant
        return GoldenPlant(model, dt=dt, **options)
    if kind == "verilator":   # plain C++ harness: 2-3x faster than the --timing Verilog one, same integers
        from .rtl_cpp import VerilatorCppPlant
        return VerilatorCppPlant(model, dt=dt, **options)
    from .rtl_plant import RtlPlant
    return RtlPlant(model, simulator=kind, dt=dt, **options)
