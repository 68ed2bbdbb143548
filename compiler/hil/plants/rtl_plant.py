"""The generated Verilog as a stepping plant, under Verilator or Icarus, in lockstep over pipes.

The harness (:mod:`pendc.hil.plants.rtl_harness`) instantiates the core with ``step`` held high and
answers one request line at a time: hold the input for n steps, reset, or deposit a state
register. Every port name comes from the plant interface (:class:`~pendc.hil.plants.core_ports.CorePorts`).
Each design (the core's files and the harness) is built once and cached under its hash.
"""

from __future__ import annotations

from ...errors import PendcError
from ...model.plant import PlantModel
from .golden_plant import core_of
from .plant_state import PlantState, check_initial, check_step_request
from .rtl_harness import HarnessLink, build_harness

SIMULATORS = ("verilator", "icarus")


def deposit_registers(graph) -> tuple:
    """``(core register, width)`` of every state node (registers, then FSM states as in
    :class:`pendc.golden.GoldenStepper`'s state vector, same order), the registers a
    ``2 i value`` request writes: a golden state continues in the RTL from there."""
    from ...backend.viewmodel import sig
    from ...ir.nodes import Kind

    out = []
    for n in graph.nodes:
        if n.kind is Kind.REGISTER:
            out.append((sig(n.name), n.qformat.width))
        elif n.kind is Kind.FSM:
            out.append((f"{sig(n.name)}_state", max(1, (len(n.param("states")) - 1).bit_length())))
    return tuple(out)


class RtlPlant:
    """The generated core under ``simulator`` ("verilator" or "icarus"), stepped in lockstep.

    The same integers as :class:`~pendc.hil.plants.golden_plant.GoldenPlant` for the same inputs and the
    same ``initial`` (one value per reported state: deposited into the core's state registers after every
    reset, as a testbench deposits a state; the encoders count from there). ``schedule``: the
    build request (``{"preset": "comb"}``, ``{"ii": 4}``...; None: ``pendc build``'s default), every
    schedule being bit-exact with the same golden model. The core's sticky overflow flag stops
    the run (``on_overflow="error"``) with the time; the golden model names the node. Call
    :meth:`close` (or use ``with``) to end the simulator process."""

    def __init__(self, model: PlantModel, simulator: str = "verilator", dt: float = 1e-6, build=None,
                 on_overflow: str = "error", bus: str = "raptor", initial: tuple | None = None,
                 schedule: dict | None = None):
        if simulator not in SIMULATORS:
            raise PendcError(f"unknown RTL simulator '{simulator}' (choose {', '.join(SIMULATORS)})")
        self.simulator = simulator
        files, report = self._prepare(model, dt, build, on_overflow, bus, initial, schedule)
        self._deposit_ok = True
        self.executable = build_harness(files, self.ports, report["ports"], self.ii, simulator, self._deposit)
        self._link = None
        self.overflow_at = None
        self.reset()

    def _prepare(self, model, dt, build, on_overflow, bus, initial, schedule) -> tuple[dict, dict]:
        """Everything but the executable: the build, the HDL files and their report.json."""
        import json

        from ...backend.hdl import build_hdl, port_formats
        from ...golden import register_integers
        from ...ir.nodes import Kind

        self.build, self.ports = core_of(model, dt, build, on_overflow)
        self.model, self.dt, self.on_overflow = model, float(dt), on_overflow
        graph = self.build.graph
        if self.ports.adcs:   # the harnesses answer states, counts and channel levels, not codes
            raise PendcError(f"the RTL plant does not read converter codes yet (plant '{model.interface.name}' has "
                             f"{', '.join(a.name for a in self.ports.adcs)}): use --plant golden, bit-exact with it")
        self.initial = check_initial(self.ports, initial)
        self._deposit = deposit_registers(graph)
        self._state_names = [n.name for n in graph.nodes if n.kind in (Kind.REGISTER, Kind.FSM)]
        start = {} if self.initial is None else register_integers(graph, dict(zip(self.ports.states, self.initial)))
        self._initial_deposits = [(self._state_names.index(name), value) for name, value in start.items()]
        self.schedule_request = dict(schedule or {})
        files = build_hdl(graph, self.build.resources.to_json(), source=model.source, bus=bus,
                          request=self.schedule_request or None)
        report = json.loads(files["report.json"])
        self.ii = int(report["ii"])
        self.build_id = report["build_id"]
        self.port_formats = port_formats(graph)
        self._lsb = {p: 2.0 ** -report["ports"][p]["frac"] for p in self.ports.states}
        self._u_format = graph[self.ports.input].qformat
        return files, report

    def describe(self) -> dict:
        """Which core this plant runs: simulator, schedule request, ii and build id (for summary.json)."""
        return {"simulator": self.simulator, "schedule": self.schedule_request or {"preset": "default"},
                "ii": self.ii, "build_id": self.build_id}

    @property
    def _proc(self):
        """The simulator process (None before the first reset or after :meth:`close`)."""
        return None if self._link is None else self._link._proc

    def _request(self, text: str):
        return self._link.request(text)

    def _state(self, v) -> PlantState:
        cp = self.ports
        self.last = dict(zip(cp.states, v.states)) | dict(zip(cp.channels, v.levels))
        return PlantState(t=self._k * self.dt, states=tuple((p, q * self._lsb[p]) for p, q in zip(cp.states, v.states)),
                          counts=tuple((e.name, c) for e, c in zip(cp.encoders, v.counts)))

    def raw(self) -> dict:
        """The output ports' integers after the last step (compare with GoldenPlant.raw())."""
        return dict(self.last)

    def reset(self) -> PlantState:
        self._k = 0
        self.overflow_at = None
        if self._link is None or not self._link.alive:
            self._link = HarnessLink(self.executable, self.simulator, self.ports)
            v = self._link.answer()
        else:
            v = self._request("1 0 0")
        for i, value in self._initial_deposits:
            v = self._request(f"2 {i} {value}")
        return self._state(v)

    def load(self, registers) -> PlantState:
        """Reset, then continue from a golden state: ``registers`` are the integers of every state
        node (:meth:`pendc.hil.plants.golden_plant.GoldenPlant.registers`); time and encoder counts
        restart at zero, the overflow flag is clear."""
        values = [int(v) for v in registers]
        if len(values) != len(self._deposit):
            raise PendcError(f"a core state has {len(self._deposit)} registers, got {len(values)}")
        if not self._deposit_ok:
            raise PendcError("this plant was built without state loading (loadable=False)")
        self.reset()
        v = None
        for i, value in enumerate(values):
            v = self._request(f"2 {i} {value}")
        return self._state(v) if v is not None else self._state(self._request("1 0 0"))

    def step(self, u_volts: float, n_steps: int) -> PlantState:
        u, n = check_step_request(u_volts, n_steps)
        v = self._request(f"0 {self._u_format.from_float(u)} {n}")
        self._k += n
        if v.lost:
            raise PendcError(f"encoder channels A and B changed in the same step before t = {self._k * self.dt:.6g} s")
        if v.overflow and self.overflow_at is None:
            self.overflow_at = self._k
            if self.on_overflow == "error":
                raise PendcError(f"the core's overflow flag rose before t = {self._k * self.dt:.6g} s "
                                 f"(the golden plant names the node)")
        return self._state(v)

    def close(self) -> None:
        """End the simulator process."""
        if self._link is not None:
            self._link.close()
        self._link = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass
