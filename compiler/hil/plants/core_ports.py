"""The generated core's ports as the plant interface names them: one place for every harness.

The HIL plants (:mod:`pendc.hil.plants.rtl_plant`, :mod:`pendc.hil.plants.rtl_cpp`), the golden plant and the
cocotb testbench (``tb/``) all talk to the same module: ``clk``, ``rst``, ``step``, ``ready``,
the plant's one input, its reported states, two channel lines per encoder, one code port per
sampled converter (ADC) and ``overflow``.
:class:`CorePorts` reads those names from the plant interface carried on the graph
(:func:`pendc.model.interface.require_interface`), so no harness spells a state of a plant;
:func:`core_instance` is the Verilog that declares and instantiates the core, shared by every
Verilog harness.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ...model.interface import require_interface


@dataclass(frozen=True)
class EncoderPorts:
    """One quadrature encoder of the core: its name, the state it reads, its two channel
    outputs (A leads when the state grows), one ×4 count's motion in the state's unit, that
    unit, and whether the state is periodic (an angle)."""

    name: str
    state: str
    channel_a: str
    channel_b: str
    resolution: float
    unit: str = ""
    periodic: bool = False

    @property
    def channels(self) -> tuple:
        """``(channel_a, channel_b)``."""
        return (self.channel_a, self.channel_b)


@dataclass(frozen=True)
class AdcPorts:
    """One sampled converter (ADC) of the core: its name, the state it reads, its code port,
    bits and range ``lo`` .. ``hi`` in the state's unit (the code of the state after the last
    step: :meth:`pendc.model.sensors.SensorSpec.code`), and the plant's sensor ``offset`` (the
    converter codes state + offset; a controller's :meth:`reading` does not know it)."""

    name: str
    state: str
    port: str
    bits: int
    lo: float
    hi: float
    unit: str = ""
    offset: float = 0.0

    @property
    def resolution(self) -> float:
        """One LSB, in the state's unit."""
        return (self.hi - self.lo) / (1 << self.bits)

    def reading(self, code) -> float:
        """The state a code stands for (the middle of its step)."""
        return self.lo + (float(code) + 0.5) * self.resolution

    def code(self, value) -> int:
        """The code of state ``value`` (plus the offset), by the interface's rule
        (:func:`pendc.model.sensors.converter_code`: floor, clipped to the range)."""
        from ...model.sensors import converter_code
        return int(converter_code(float(value) + self.offset, self.lo, self.hi, self.bits))


@dataclass(frozen=True)
class CorePorts:
    """Module and data-port names of a generated core, in the core's port order."""

    module: str
    input: str
    states: tuple
    encoders: tuple
    adcs: tuple = ()
    input_range: tuple = ()           # (low, high) the input's actuator takes, from the interface
    input_unit: str = ""

    @classmethod
    def of_interface(cls, iface) -> "CorePorts":
        """The ports of the core built from plant interface ``iface``."""
        encoders = tuple(EncoderPorts(s.name, s.state, *s.channels, s.resolution, iface.state(s.state).unit,
                                      iface.state(s.state).periodic) for s in iface.sensors if not s.is_adc)
        adcs = tuple(AdcPorts(s.name, s.state, s.code_port, s.bits, s.lo, s.hi, iface.state(s.state).unit)
                     for s in iface.sensors if s.is_adc)
        return cls(module=iface.core, input=iface.input.name, states=tuple(iface.outputs), encoders=encoders,
                   adcs=adcs, input_range=(iface.input.lo, iface.input.hi), input_unit=iface.input.unit)

    def with_offsets(self, offsets: dict) -> "CorePorts":
        """The same ports with each converter coding its state plus ``offsets[state]`` (a model's
        :meth:`~pendc.model.plant.PlantModel.sensor_offset_values`), as the compiled core does."""
        adcs = tuple(replace(a, offset=float(offsets.get(a.state, 0.0))) for a in self.adcs)
        return replace(self, adcs=adcs)

    @classmethod
    def of_graph(cls, graph) -> "CorePorts":
        """The ports of the core compiled from ``graph`` (its plant interface); checked against
        the graph's output nodes."""
        ports = cls.of_interface(require_interface(graph))
        have = [name for name, _ in graph.outputs]
        if list(ports.outputs) != have:
            raise ValueError(f"graph '{graph.name}' has outputs {have}, its plant interface names "
                             f"{list(ports.outputs)}")
        return ports

    @property
    def channels(self) -> tuple:
        """Every encoder channel output, encoder by encoder (A then B)."""
        return tuple(c for e in self.encoders for c in e.channels)

    @property
    def codes(self) -> tuple:
        """Every converter's code port, in sensor order."""
        return tuple(a.port for a in self.adcs)

    @property
    def outputs(self) -> tuple:
        """States, channels, then codes: the order of a golden row and of the graph's outputs."""
        return self.states + self.channels + self.codes

    @property
    def measured(self) -> tuple:
        """The states a sensor reads: the encoders', then the converters' (each once)."""
        out = [e.state for e in self.encoders] + [a.state for a in self.adcs]
        return tuple(dict.fromkeys(out))

    def encoder_of(self, state: str) -> EncoderPorts | None:
        """The encoder that reads ``state``, or None."""
        return next((e for e in self.encoders if e.state == state), None)

    def adc_of(self, state: str) -> AdcPorts | None:
        """The converter that reads ``state``, or None."""
        return next((a for a in self.adcs if a.state == state), None)


def _decl(fmt: dict) -> str:
    return f"{'signed ' if fmt['signed'] else ''}[{fmt['width'] - 1}:0]"


def core_instance(ports: CorePorts, formats: dict, input_reg: bool = True, indent: str = "    ") -> str:
    """Verilog declaring the core's data wires and instantiating it as ``core``.

    ``formats``: report.json's "ports" (width, signedness per data port). With ``input_reg``
    the input is a ``reg`` driven by the harness (initially 0), else a wire the caller declares
    (a module port)."""
    lines = []
    if input_reg:
        w = formats[ports.input]["width"]
        lines.append(f"reg {_decl(formats[ports.input])} {ports.input} = {w}'sd0;")
    lines.append("wire ready, overflow;")
    lines += [f"wire {_decl(formats[p])} {p};" for p in ports.states + ports.codes]
    if ports.channels:
        lines.append(f"wire {', '.join(ports.channels)};")
    lines.append(instance_line(ports))
    return "\n".join(indent + ln for ln in lines)


def instance_line(ports: CorePorts) -> str:
    """``<module> core (.clk(clk), ...);``: the core instantiated as ``core``, every port on the
    signal of its own name."""
    conns = ["clk", "rst", "step", "ready", ports.input, *ports.outputs, "overflow"]
    return f"{ports.module} core (" + ", ".join(f".{c}({c})" for c in conns) + ");"


def verilog_decl(fmt: dict) -> str:
    """The ``signed [w-1:0]`` part of a declaration of a port of format ``fmt`` (report.json)."""
    return _decl(fmt)
