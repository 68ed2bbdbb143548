"""The golden model as a stepping plant: the compiled core's integers, continued call after call.

Bit-exact with the Verilog (the RTL plants must give the same integers). Encoder counts
come from the core's own encoder FSM outputs through a ×4 decoder sampling every model
step, as the bus wrapper's decoders count them; each sampled converter's code is the core's
code output after the last step.
"""

from __future__ import annotations

import numpy as np

from ...errors import PendcError
from ...golden import OVERFLOW_CHOICES, GoldenStepper, OverflowStop, first_overflow
from ...model.plant import PlantModel
from ...sim.signals import signals_of
from .core_ports import CorePorts
from .plant_state import PlantState, check_initial, check_step_request, x4_count_delta  # noqa: F401


def build_for(model: PlantModel, dt: float, build=None):
    """The compiled core of ``model`` (from the build cache), checked against the plant step ``dt``."""
    if build is None:
        from ...caching.build_cache import compile_cached
        from ...passes.pipeline import options_from_model
        build = compile_cached(model, options_from_model(model))
    if abs(build.options.dt - dt) > 1e-15:
        raise PendcError(f"the core was built for a step of {build.options.dt:g} s, not {dt:g} s")
    return build


def core_of(model: PlantModel, dt: float, build, on_overflow: str) -> tuple:
    """What every plant of the compiled core starts from, the golden and the RTL ones: the build
    (:func:`build_for`) and its core's ports (:class:`CorePorts`), ``on_overflow`` checked."""
    if on_overflow not in OVERFLOW_CHOICES:
        raise PendcError(f"on_overflow must be one of {', '.join(OVERFLOW_CHOICES)}, got {on_overflow!r}")
    build = build_for(model, dt, build)
    try:
        ports = CorePorts.of_graph(build.graph)
    except ValueError as exc:
        raise PendcError(str(exc)) from None
    return build, ports.with_offsets(model.sensor_offset_values())


class GoldenPlant:
    """Stateful, bit-exact plant over the compiled golden kernel.

    ``on_overflow="error"`` (default) raises :class:`~pendc.golden.OverflowStop` naming the node
    and the time at the step a node leaves its range; ``"mark"`` carries on and lists the nodes
    in ``overflows`` ({node: first step}). ``initial`` (one value per reported state, in the
    plant interface's order) starts the registers elsewhere than at reset (the encoders then
    count from there, as at power-on). ``like`` (an earlier typing of the build's graph, such as
    the nominal core a retyped sample comes from) shares its kernel's machine code
    (:class:`~pendc.ir.compiled.CompiledGraph`)."""

    def __init__(self, model: PlantModel, dt: float = 1e-6, build=None, on_overflow: str = "error",
                 initial: tuple | None = None, like=None):
        self.build, self.ports = core_of(model, dt, build, on_overflow)
        self.model, self.dt, self.on_overflow = model, float(dt), on_overflow
        graph = self.build.graph
        self.stepper = GoldenStepper(graph, like=like)
        self._col = {p: self.stepper.ports.index(p) for p in self.ports.outputs}
        self._lsb = {p: graph.output(p).qformat.lsb for p in self.ports.states + self.ports.codes}
        self._u_format = graph[self.ports.input].qformat
        self.initial = check_initial(self.ports, initial)
        self.reset()

    @property
    def overflows(self) -> dict:
        """{node: first step since reset} of every node that left its range."""
        return dict(self.stepper.overflows)

    def registers(self) -> tuple:
        """The integers of every state node now (registers, then FSM states): what
        :meth:`load` and the RTL plants' ``load`` continue from."""
        return tuple(int(v) for v in self.stepper.state)

    def load(self, registers) -> PlantState:
        """Reset, then continue from ``registers`` (as :meth:`registers` returns them); time and
        encoder counts restart at zero."""
        values = np.asarray([int(v) for v in registers], dtype=np.int64)
        if values.shape != self.stepper.state.shape:
            raise PendcError(f"a core state has {self.stepper.state.size} registers, got {values.size}")
        self.stepper.reset()
        self.stepper.state = values
        self._counts = [0] * len(self.ports.encoders)
        self._state = self._from_row(self._outputs_now())
        return self._state

    def quantize_input(self, u: float) -> int:
        """The input port's integer for ``u`` volts (nearest, saturating), as the bus writes it."""
        return self._u_format.from_float(u)

    def reset(self) -> PlantState:
        start = {} if self.initial is None else dict(zip(self.ports.states, self.initial))
        # a converter's code register holds the code of the state before the step: its reset value
        # is the code of 0, so a run started elsewhere starts it at the code of the initial value
        start.update({a.port: float(a.code(start[a.state])) for a in self.ports.adcs if a.state in start})
        self.stepper.reset(start)
        self._counts = [0] * len(self.ports.encoders)
        self._levels = None
        self._state = self._from_row(self._outputs_now())
        return self._state

    def _outputs_now(self) -> np.ndarray:
        """Output integers of the current state without advancing it."""
        saved, k, ov = self.stepper.state.copy(), self.stepper.k, dict(self.stepper.overflows)
        row = self.stepper.advance(0, 1)[0]
        self.stepper.state, self.stepper.k, self.stepper.overflows = saved, k, ov
        self._levels = row
        return row

    def _from_row(self, row) -> PlantState:
        return PlantState(t=self.stepper.k * self.dt,
                          states=tuple((p, int(row[self._col[p]]) * self._lsb[p]) for p in self.ports.states),
                          counts=tuple((e.name, c) for e, c in zip(self.ports.encoders, self._counts)),
                          codes=tuple((a.name, int(round(int(row[self._col[a.port]]) * self._lsb[a.port])))
                                      for a in self.ports.adcs))

    def raw(self) -> dict:
        """The output ports' integers after the last step (what the RTL must show bit for bit)."""
        return {p: int(self._levels[j]) for p, j in self._col.items()}

    def step(self, u_volts: float, n_steps: int) -> PlantState:
        u, n = check_step_request(u_volts, n_steps)
        known = set(self.stepper.overflows)
        out = self.stepper.advance(self.quantize_input(u), n)
        new = {k: s for k, s in self.stepper.overflows.items() if k not in known}
        if new and self.on_overflow == "error":
            node, step = first_overflow(new, self.build.graph)
            raise OverflowStop(node, step, self.dt, new, signals_of(self.model))
        c = self._col
        for i, e in enumerate(self.ports.encoders):
            self._counts[i] += x4_count_delta(out[:, c[e.channel_a]], out[:, c[e.channel_b]])
        self._levels = out[-1]
        self._state = self._from_row(out[-1])
        return self._state
