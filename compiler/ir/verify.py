"""The IR verifier, run between passes (in the spirit of PyRTL's ``Block.sanity_check``).

:func:`verify` raises :class:`~pendc.ir.graph.GraphError` with a one-line message
naming the first offending node (in evaluation order), so a broken rewrite is caught
at the pass that made it rather than as a wrong number several passes later.

Structural checks hold for every graph; ``typed=True`` adds the checks that need
Q-formats: format rules of registers and flags, the 32-bit multiplier operands and
the 64-bit exact intermediates the golden model relies on (see pendc.ir.nodes).
"""

from __future__ import annotations

import math

from . import fsm as fsm_sem
from .graph import Graph, GraphError
from .limits import EXACT_BITS, MULT_OPERAND_BITS
from .nodes import Kind, Node
from .qformat import QFormat
from .visitor import NodeVisitor

_STATEFUL = (Kind.REGISTER, Kind.FSM)   # their input is taken at the end of the step


def verify(graph: Graph, typed: bool = False) -> None:
    """Check ``graph``'s invariants; raise GraphError naming the first node that breaks one.

    Always: unique names, defined inputs, arity, params of the kind's class (their values
    are checked when a node is built, see pendc.ir.nodes), no combinational cycle, evaluation order, defined and unique outputs, unique input
    ports, no dangling node. With ``typed``: Q-formats and the bit-width rules.
    """
    _check_names(graph)
    by_name = {n.name: n for n in graph.nodes}
    for node in graph.nodes:
        _check_inputs(node, by_name)
    for node in graph.nodes:
        if type(node.params) is not node.kind.params_class:
            _fail(node, f"params are {type(node.params).__name__}, expected {node.kind.params_class.__name__}")
    _check_ports(graph)
    _check_cycles(graph, by_name)
    _check_order(graph)
    _check_outputs(graph, by_name)
    _check_live(graph, by_name)
    if typed:
        for node in graph.nodes:
            if node.qformat is None:
                _fail(node, "has no Q-format")
        for node in graph.nodes:
            _TYPED_RULES.visit(node, [by_name[i].qformat for i in node.inputs])


def _fail(node: Node, message: str):
    raise GraphError(f"{node.kind.value} node '{node.name}': {message}")


# -- structure ---------------------------------------------------------------------

def _check_names(graph: Graph) -> None:
    seen = set()
    for node in graph.nodes:
        if not isinstance(node.name, str) or not node.name:
            raise GraphError(f"node with empty or non-string name {node.name!r} ({node.kind.value})")
        if node.name in seen:
            raise GraphError(f"duplicate node name '{node.name}'")
        seen.add(node.name)


def _check_inputs(node: Node, by_name: dict) -> None:
    for i in node.inputs:
        if i not in by_name:
            _fail(node, f"reads undefined node '{i}'")
    n, arity = len(node.inputs), node.kind.arity
    if node.kind is Kind.MUX:
        if n < 3:
            _fail(node, f"needs a select and at least 2 data inputs, has {n} input(s)")
    elif n != arity:
        _fail(node, f"needs {arity} input(s), has {n}")


def _check_ports(graph: Graph) -> None:
    # interpreters and the Verilog top level map ports by name: two nodes on one port would collide
    ports = {}
    for node in graph.of_kind(Kind.INPUT):
        port = node.params.port
        if port in ports:
            _fail(node, f"input port '{port}' is already read by node '{ports[port]}'")
        ports[port] = node.name


def _check_cycles(graph: Graph, by_name: dict) -> None:
    """Depth-first search over combinational edges only: an edge into a REGISTER or FSM
    is a step boundary, so any cycle that remains has no state element on it."""
    state = {}   # name -> 1 on the DFS stack, 2 done
    for root in graph.nodes:
        if root.name in state:
            continue
        stack = [(root.name, iter(_comb_inputs(root)))]
        path = [root.name]
        state[root.name] = 1
        while stack:
            name, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                stack.pop()
                path.pop()
                state[name] = 2
            elif state.get(nxt) == 1:
                cycle = path[path.index(nxt):] + [nxt]
                _fail(by_name[nxt], "combinational cycle not broken by a REGISTER or FSM: "
                      + " <- ".join(cycle))
            elif nxt not in state:
                state[nxt] = 1
                path.append(nxt)
                stack.append((nxt, iter(_comb_inputs(by_name[nxt]))))


def _comb_inputs(node: Node) -> tuple:
    return () if node.kind in _STATEFUL else node.inputs


def _check_order(graph: Graph) -> None:
    # interpreters evaluate in node order: a combinational node must follow its inputs
    position = {n.name: k for k, n in enumerate(graph.nodes)}
    for k, node in enumerate(graph.nodes):
        for i in _comb_inputs(node):
            if position[i] > k:
                _fail(node, f"is evaluated before its input '{i}' (rebuild the graph with Graph.build)")


def _check_outputs(graph: Graph, by_name: dict) -> None:
    if not graph.outputs:
        raise GraphError(f"graph '{graph.name}' has no outputs")
    ports = set()
    for port, name in graph.outputs:
        if name not in by_name:
            raise GraphError(f"output '{port}' names undefined node '{name}'")
        if port in ports:
            raise GraphError(f"duplicate output port '{port}' (node '{name}')")
        ports.add(port)


def _check_live(graph: Graph, by_name: dict) -> None:
    """Every node must feed an output, directly or through registers and FSMs."""
    live = set()
    todo = [name for _, name in graph.outputs]
    while todo:
        name = todo.pop()
        if name not in live:
            live.add(name)
            todo.extend(by_name[name].inputs)
    for node in graph.nodes:
        if node.name not in live:
            _fail(node, "is dangling: it reaches no graph output")


# -- typed checks --------------------------------------------------------------------

def _flag_format(node: Node, width: int) -> None:
    want = QFormat(False, width, 0)
    if node.qformat != want:
        _fail(node, f"format must be {want}, is {node.qformat}")


def _fits(node: Node, bits: int, what: str) -> None:
    if bits > EXACT_BITS:
        _fail(node, f"{what} needs {bits} bits, more than {EXACT_BITS}")


def _operand(node: Node, fmt: QFormat, what: str) -> None:
    if fmt.width > MULT_OPERAND_BITS:
        _fail(node, f"multiplier operand {what} is {fmt} ({fmt.width} bits), at most {MULT_OPERAND_BITS} allowed")


def _signed_bits(fmt: QFormat) -> int:
    """Bits of ``fmt``'s values as signed numbers (an unsigned value needs a zero sign bit)."""
    return fmt.width + (0 if fmt.signed else 1)


def _aligned_sum_bits(fa: QFormat, fb: QFormat) -> int:
    # both operands (as signed numbers) shifted to the larger fraction, plus one bit for the carry
    return max(_signed_bits(fa) - fa.frac, _signed_bits(fb) - fb.frac) + max(fa.frac, fb.frac) + 1


class _TypedRules(NodeVisitor):
    """The format and bit-width rules of each kind: ``visit_<kind>(node, input formats)``."""

    def visit_const(self, node, fin):
        pass

    def visit_input(self, node, fin):
        pass

    def visit_register(self, node, fin):
        if node.qformat != fin[0]:
            _fail(node, f"format {node.qformat} differs from its input '{node.inputs[0]}' ({fin[0]})")

    def visit_compare(self, node, fin):
        _flag_format(node, 1)
        _fits(node, _aligned_sum_bits(*fin), "the aligned comparison")

    def visit_slice(self, node, fin):
        p = node.params
        if not p.sign_bit and p.hi >= fin[0].width:
            _fail(node, f"bit {p.hi} is outside its {fin[0].width}-bit input '{node.inputs[0]}'")
        _flag_format(node, p.width)

    def visit_fsm(self, node, fin):
        _flag_format(node, fsm_sem.output_width(node.params.outputs))

    def visit_add(self, node, fin):
        _fits(node, _aligned_sum_bits(*fin), "the aligned sum")

    visit_sub = visit_add

    def visit_neg(self, node, fin):
        _fits(node, fin[0].width + 1, "the negation")      # -min_int needs one bit more

    def visit_mul(self, node, fin):
        _operand(node, fin[0], f"'{node.inputs[0]}'")
        _operand(node, fin[1], f"'{node.inputs[1]}'")
        _fits(node, _signed_bits(fin[0]) + _signed_bits(fin[1]), "the product")

    def visit_gain(self, node, fin):
        _check_gain(node, fin[0])

    def visit_mux(self, node, fin):
        _check_mux(node, fin)

    def visit_cast(self, node, fin):
        _fits(node, _signed_bits(fin[0]) + max(0, node.qformat.frac - fin[0].frac), "the input aligned to the output")

    def visit_lut(self, node, fin):
        _check_table(node, fin[0])


_TYPED_RULES = _TypedRules()


def check_typed_node(node: Node, input_formats: list) -> None:
    """The format and bit-width rules for one typed node whose inputs have ``input_formats``
    (what ``verify(typed=True)`` checks per node; its params were checked when it was built).
    Raises GraphError naming the node."""
    if node.qformat is None:
        _fail(node, "has no Q-format")
    _TYPED_RULES.visit(node, list(input_formats))


def _check_gain(node: Node, fin: QFormat) -> None:
    cfmt, value = node.params.cfmt, node.params.value
    if cfmt is None:
        _fail(node, "missing param 'cfmt'")
    _operand(node, fin, f"'{node.inputs[0]}'")
    _operand(node, cfmt, "(the constant)")
    _fits(node, _signed_bits(fin) + cfmt.width, "the product")
    # from_float saturates silently: a constant that does not fit would be a different gain
    scaled = math.floor(math.ldexp(value, cfmt.frac) + 0.5)
    if not cfmt.contains(scaled):
        _fail(node, f"value {value!r} does not fit its constant format {cfmt}")


def _check_mux(node: Node, fin: list) -> None:
    sel = fin[0]
    if sel.signed or sel.frac != 0:
        _fail(node, f"select '{node.inputs[0]}' must be an unsigned integer (UFIXw_0), is {sel}")
    data = len(node.inputs) - 1
    if data > 1 << sel.width:
        _fail(node, f"{data} data inputs but a {sel.width}-bit select reaches only {1 << sel.width}")
    for name, f in zip(node.inputs[1:], fin[1:]):
        _fits(node, _signed_bits(f) + max(0, node.qformat.frac - f.frac), f"input '{name}' aligned to the output")


def _check_table(node: Node, fin: QFormat) -> None:
    p = node.params
    for key in ("table", "shift"):
        if getattr(p, key) is None:
            _fail(node, f"missing param '{key}'")
    if p.lo is None:
        _fail(node, "has no domain (run tabulate_luts before typing)")
    shift, table = p.shift, p.table
    if isinstance(shift, bool) or not isinstance(shift, int) or shift < 0:
        _fail(node, f"param 'shift' must be an integer >= 0, got {shift!r}")
    if not isinstance(table, tuple) or len(table) != p.entries:
        size = len(table) if isinstance(table, tuple) else type(table).__name__
        _fail(node, f"table must have {p.entries} entries for addr_bits={p.addr_bits}, has {size}")
    for j, y in enumerate(table):
        if isinstance(y, bool) or not isinstance(y, int) or not node.qformat.contains(y):
            _fail(node, f"table entry {j} ({y!r}) is not an integer of its format {node.qformat}")
    if p.periodic and (1 << (p.addr_bits + shift)) != round(math.ldexp(p.hi - p.lo, fin.frac)):
        # the free wrap-around of the address only works if one period is exactly 2**k LSBs
        _fail(node, f"period {p.hi - p.lo} is not 2**{p.addr_bits + shift} LSBs of {fin}")
    if p.interpolate:
        _fits(node, node.qformat.width + 1 + shift, "the interpolation product")
