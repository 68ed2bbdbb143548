"""From a typed IR graph to the flat view-model the Verilog templates print.

Timing of one model step (``ii`` clock cycles, from a :class:`pendc.passes.schedule.Schedule`;
without one, the combinational schedule: ``ii = 1 + number of table stages``): a step
request is accepted when ``ready`` is high (cycle 0); every table is a synchronous ROM
whose address is read at the end of its address cycle; nodes run in their scheduled
cycle (pipeline registers and shared multipliers: :mod:`.timing`); in the last cycle
the state registers and FSMs update. The input must be held from the accepting cycle to the last.

Each node's Verilog is one netlist block (:class:`pendc.backend.arith.Block`) under a comment
naming the node, its kind, parameters, Q-format and meaning (:func:`node_comment`); the
templates print the blocks in graph order, so every wire is declared where it is assigned.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..ir.graph import Graph
from ..ir.nodes import Kind
from ..ir.visitor import NodeVisitor
from ..ir.qformat import Overflow, Rounding
from ..model.interface import PlantInterface, graph_interface
from ..passes.schedule import Schedule, schedule_graph
from .arith import Netlist, aligned, bits, extend, literal, operand_width, requantize, ulit
from .tables_fsm import emit_fsm, emit_fsm_check, emit_lut
from .timing import Datapath


# names the core template declares itself (templates/core.v.j2), besides the ports
TEMPLATE_NAMES = ("clk", "rst", "step", "ready", "overflow", "phase", "last", "overflow_hit", "overflow_r",
                  "overflow_status", "overflow_status_r")


@dataclass
class Rom:
    """One table's synchronous ROM: its memory-initialisation file, instance, words and the
    core's wires to it (every table is an instance of the core's one ROM module,
    :func:`pendc.backend.tables_fsm.rom_module`)."""

    table: str         # the LUT node
    file: str          # its words, one a line in hexadecimal ($readmemh), beside the Verilog
    inst: str
    addr_width: int
    data_width: int
    words: list        # hex strings, index = address
    layout: str        # what a word's bits hold, for a reader of the file
    addr: str          # address wire in the core
    q: str             # registered data wire in the core
    en: str            # read enable: the cycle the address is valid in (the word then holds until the next step)


@dataclass
class CoreView:
    """Everything the core's templates print, as flat lists (see the module docstring)."""

    module: str
    ii: int
    phase_width: int
    ports: list                       # (direction, name, width, signed)
    net: Netlist
    registers: list = field(default_factory=list)   # (name, width, signed, reset literal, next)
    fsms: list = field(default_factory=list)        # dict(name, state_width, reset, input, rules, ...)
    roms: list = field(default_factory=list)
    lut_regs: list = field(default_factory=list)    # (name, width, source, enable) registered beside a ROM
    outputs: list = field(default_factory=list)     # (port, wire)
    dp: Datapath | None = None                      # pipeline registers, shared units, overflow gating
    interface: PlantInterface | None = None         # the plant the graph was lowered from (None: built by hand)


def sig(name: str) -> str:
    """The Verilog wire (or register) that holds node ``name``'s value."""
    return f"n_{name}"


def table_stages(graph: Graph) -> dict:
    """Stage of every LUT: 1 + the largest stage of the LUTs feeding its address."""
    stage: dict = {}
    for n in graph.nodes:
        upstream = [stage[i] for i in n.inputs if i in stage]
        if n.kind is Kind.LUT:
            stage[n.name] = 1 + max(upstream, default=0)
        elif upstream and n.kind not in (Kind.REGISTER, Kind.FSM):
            stage[n.name] = max(upstream)
    return {n.name: stage[n.name] for n in graph.of_kind(Kind.LUT)}


def core_ports(graph: Graph) -> list:
    """``(direction, port, width, signed)`` of the core's data ports: the graph's input
    ports in node order, then its outputs in their order (a plant's input, reported states
    and encoder lines, as the lowering laid them out)."""
    ports = [("input", n.params.port, n.qformat.width, n.qformat.signed) for n in graph.of_kind(Kind.INPUT)]
    ports += [("output", port, graph[node].qformat.width, graph[node].qformat.signed)
              for port, node in graph.outputs]
    return ports


def build_view(graph: Graph, module: str | None = None, schedule: Schedule | None = None) -> CoreView:
    """The view-model of the core for ``schedule`` (default: combinational between table reads).
    ``module``: the core's name (default: the graph's, which lowering takes from the plant
    interface's ``core``)."""
    schedule = schedule or schedule_graph(graph)
    ii = schedule.ii
    net = Netlist()
    ports = core_ports(graph)
    for name in TEMPLATE_NAMES + tuple(p[1] for p in ports):
        net.claim(name)
    for n in graph.nodes:       # node values first: every helper name is allocated around them
        net.claim(sig(n.name))
    view = CoreView(module=module or graph.name, ii=ii, phase_width=max(1, (ii - 1).bit_length()), ports=ports,
                    net=net, interface=graph_interface(graph))
    view.dp = Datapath(schedule, net, {n.name: n.kind for n in graph.nodes}, view.phase_width)
    emitter = NodeEmitter(view, graph)
    for n in graph.nodes:
        net.begin(node_comment(n), node=n.name)
        emitter.visit(n)
    for n in graph.of_kind(Kind.FSM):   # after every node: the checks read the FSM's input
        net.begin((f"input range of {n.name}: outside it the machine's rules are not defined",))
        emitter.fsm_input_check(n)
    if schedule.units:
        net.begin(("shared multipliers: operands selected by the phase of the step",), early=True)
    view.dp.finish()
    view.outputs = [(p, sig(node)) for p, node in graph.outputs]
    return view


def node_comment(n) -> tuple:
    """The comment above a node's wires: ``name = kind(inputs) params : Q-format -- meaning``
    (the golden kernel printer's spelling, so the same name finds both)."""
    detail = ParamsText().visit(n)
    fixes = []
    if n.rounding is not Rounding.NEAREST:
        fixes.append("truncating")
    if n.overflow is Overflow.SATURATE:
        fixes.append("saturating")
    if n.inputs:
        head = f"{n.name} = {n.kind.value}({', '.join(n.inputs)}){' ' + detail if detail else ''} : {n.qformat}"
    else:       # a source: its parameter is its argument
        head = f"{n.name} = {n.kind.value}({detail}) : {n.qformat}"
    head += f" ({', '.join(fixes)})" if fixes else ""
    return (f"{head} -- {n.meaning}",) if n.meaning else (head,)


class ParamsText(NodeVisitor):
    """A node's parameters as its comment spells them (empty for kinds without any)."""

    def visit_const(self, n) -> str:
        return f"{n.params.value!r}"

    def visit_input(self, n) -> str:
        return f"port {n.params.port}"

    def visit_gain(self, n) -> str:
        return f"* {n.params.value!r} as {n.params.cfmt}"

    def visit_compare(self, n) -> str:
        return f"op {n.params.op.value}"

    def visit_register(self, n) -> str:
        return f"reset {n.params.reset!r}"

    def visit_slice(self, n) -> str:
        p = n.params
        return "sign bit" if p.sign_bit else f"bits [{p.hi}:{p.lo}]"

    def visit_lut(self, n) -> str:
        p = n.params
        mode = "periodic" if p.periodic else "clamped"
        return f"{p.segments} segments over [{p.lo!r}, {p.hi!r}) {mode}{', interpolated' if p.interpolate else ''}"

    def visit_fsm(self, n) -> str:
        return f"{len(n.params.states)} states, reset {n.params.reset}"

    def _none(self, n) -> str:
        return ""

    visit_add = visit_sub = visit_neg = visit_mul = visit_mux = visit_cast = _none


def _use_cycle(view: CoreView, n) -> int:
    """The cycle a node reads its inputs in."""
    if n.kind in (Kind.REGISTER, Kind.FSM):
        return view.ii - 1
    if n.kind is Kind.LUT:
        return view.dp.schedule.lut_addr[n.name]
    return view.dp.schedule.stage.get(n.name, 0)


class NodeEmitter(NodeVisitor):
    """The Verilog of one node per kind (``visit``): its value ``n_<name>`` and helper wires in
    the netlist's current block, its registers and tables in the view."""

    def __init__(self, view: CoreView, graph: Graph):
        self.view, self.graph, self.net = view, graph, view.net

    def _operands(self, n) -> tuple:
        """(wires, formats) of ``n``'s inputs as read in the cycle ``n`` uses them."""
        wires = [self.view.dp.ref(i, _use_cycle(self.view, n), sig(i)) for i in n.inputs]
        return wires, [self.graph[i].qformat for i in n.inputs]

    def _requantize(self, n, exact: str, width: int, frac: int, signed: bool = True) -> str:
        return requantize(self.net, sig(n.name), exact, width, frac, n.qformat, n.rounding, n.overflow, n.name,
                          signed=signed, result=sig(n.name))

    def visit_const(self, n) -> None:
        out = n.qformat
        self.net.wire(sig(n.name), out.width, literal(out.from_float(n.params.value), out.width), own=True,
                      constant=True)

    def visit_input(self, n) -> None:
        self.net.wire(sig(n.name), n.qformat.width, n.params.port, own=True)

    def visit_register(self, n) -> None:
        a, _ = self._operands(n)
        out = n.qformat
        name = self.net.reg(sig(n.name), out.width, True, fresh=False)
        self.view.registers.append((name, out.width, literal(out.from_float(n.params.reset), out.width), a[0]))

    def visit_fsm(self, n) -> None:
        emit_fsm(self.view, n)

    def fsm_input_check(self, n) -> None:
        """The FSM's valid-input-range term (placed after the node that computes its input)."""
        a, f = self._operands(n)
        emit_fsm_check(self.view, n, a[0], f[0])

    def _product(self, n, second: tuple, frac: int) -> None:
        a, f = self._operands(n)
        name = sig(n.name)
        x, width = self.view.dp.product(name, n.name, (a[0], f[0].width, None, f[0].signed), second)
        self._requantize(n, x, width, frac)

    def visit_gain(self, n) -> None:
        c = n.params.cfmt
        k = self.net.wire(f"{sig(n.name)}_k", c.width, literal(c.from_float(n.params.value), c.width),
                          constant=True)
        self._product(n, (k, c.width, None, True), self.graph[n.inputs[0]].qformat.frac + c.frac)

    def visit_mul(self, n) -> None:
        a, f = self._operands(n)
        self._product(n, (a[1], f[1].width, None, f[1].signed), f[0].frac + f[1].frac)

    def _aligned(self, n) -> tuple:
        """Both operands at a common fraction in a width that holds either and a carry."""
        a, f = self._operands(n)
        frac = max(q.frac for q in f)
        width = max(operand_width(q) - q.frac for q in f) + frac + 1     # signed integer bits + carry
        ea, eb = (self.net.wire(f"{sig(n.name)}_{t}", width, aligned(s, q, frac, width))
                  for t, s, q in zip("ab", a, f))
        return ea, eb, width, frac

    def _sum(self, n, op: str) -> None:
        ea, eb, width, frac = self._aligned(n)
        self._requantize(n, self.net.wire(f"{sig(n.name)}_x", width, f"{ea} {op} {eb}"), width, frac)

    def visit_add(self, n) -> None:
        self._sum(n, "+")

    def visit_sub(self, n) -> None:
        self._sum(n, "-")

    def visit_compare(self, n) -> None:
        ea, eb, _, _ = self._aligned(n)
        self.net.wire(sig(n.name), 1, f"$signed({ea}) {n.params.op.symbol} $signed({eb})",
                      signed=False, own=True)

    def visit_neg(self, n) -> None:
        a, f = self._operands(n)
        width = f[0].width + 1
        x = self.net.wire(f"{sig(n.name)}_x", width, f"{ulit(0, width)} - {extend(a[0], f[0].width, f[0].signed, width)}")
        self._requantize(n, x, width, f[0].frac)

    def visit_cast(self, n) -> None:
        a, f = self._operands(n)
        self._requantize(n, a[0], f[0].width, f[0].frac, signed=f[0].signed)

    def visit_slice(self, n) -> None:
        a, f = self._operands(n)
        p = n.params
        hi, lo = (f[0].width - 1, f[0].width - 1) if p.sign_bit else (p.hi, p.lo)
        self.net.wire(sig(n.name), n.qformat.width, bits(a[0], f[0].width, hi, lo), signed=False, own=True)

    def visit_mux(self, n) -> None:
        net, name, out = self.net, sig(n.name), n.qformat
        a, f = self._operands(n)
        sel, sel_w = a[0], f[0].width
        last = len(a) - 2
        choices = []
        for j, (s, q) in enumerate(zip(a[1:], f[1:])):
            before = len(net.overflow)
            choices.append(requantize(net, f"{name}_in{j}", s, q.width, q.frac, out, n.rounding, n.overflow, n.name,
                                      signed=q.signed))
            # only the selected input can overflow the mux (as in the interpreter); a select
            # beyond the data inputs selects the last one (pendc.ir.nodes)
            picked = (f"({sel} >= {ulit(j, sel_w)})" if j == last and last < (1 << sel_w) - 1
                      else f"({sel} == {ulit(j, sel_w)})")
            for k in range(before, len(net.overflow)):
                ovf, node = net.overflow[k]
                gated = net.wire(f"{ovf}_sel", 1, f"{ovf} & {picked}", signed=False)
                net.overflow[k] = (gated, node)
        rhs = choices[-1]
        for j in range(len(choices) - 2, -1, -1):
            rhs = f"({sel} == {ulit(j, sel_w)}) ? {choices[j]} : {rhs}"
        net.wire(name, out.width, rhs, own=True)

    def visit_lut(self, n) -> None:
        a, f = self._operands(n)
        emit_lut(self.view, n, a[0], f[0], Rom)


