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
from numbers import Real

from . import fsm as fsm_sem
from .graph import Graph, GraphError
from .nodes import ARITY, COMPARE_OPS, Kind, Node
from .qformat import QFormat

MULT_OPERAND_BITS = 32   # one DSP-friendly multiplier operand (nodes.py docstring)
EXACT_BITS = 64          # the golden model computes exact results in machine integers
MAX_ADDR_BITS = 20       # a typo (addr_bits=100) must not make tabulation try 2**100 entries
FSM_OPS = ("lt", "le", "gt", "ge")
_STATEFUL = (Kind.REGISTER, Kind.FSM)   # their input is taken at the end of the step


def verify(graph: Graph, typed: bool = False) -> None:
    """Check ``graph``'s invariants; raise GraphError naming the first node that breaks one.

    Always: unique names, defined inputs, arity, required params per kind, no
    combinational cycle, evaluation order, defined and unique outputs, unique input
    ports, no dangling node. With ``typed``: Q-formats and the bit-width rules.
    """
    _check_names(graph)
    by_name = {n.name: n for n in graph.nodes}
    for node in graph.nodes:
        _check_inputs(node, by_name)
    for node in graph.nodes:
        _PARAMS[node.kind](node)
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
            _check_typed(node, [by_name[i].qformat for i in node.inputs])


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
    n, arity = len(node.inputs), ARITY[node.kind]
    if node.kind is Kind.MUX:
        if n < 3:
            _fail(node, f"needs a select and at least 2 data inputs, has {n} input(s)")
    elif n != arity:
        _fail(node, f"needs {arity} input(s), has {n}")


def _check_ports(graph: Graph) -> None:
    # interpreters and the Verilog top level map ports by name: two nodes on one port would collide
    ports = {}
    for node in graph.of_kind(Kind.INPUT):
        port = node.param("port")
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


# -- params per kind ---------------------------------------------------------------

def _need(node: Node, *keys: str) -> None:
    have = {k for k, _ in node.params}
    for key in keys:
        if key not in have:
            _fail(node, f"missing param '{key}'")


def _real(node: Node, key: str, optional: bool = False) -> None:
    v = node.param(key)
    if optional and v is None:
        return
    if isinstance(v, bool) or not isinstance(v, Real) or not math.isfinite(v):
        _fail(node, f"param '{key}' must be a finite real number, got {v!r}")


def _int(node: Node, key: str, lo: int, hi: int | None = None) -> int:
    v = node.param(key)
    if isinstance(v, bool) or not isinstance(v, int) or v < lo or (hi is not None and v > hi):
        bound = f"{lo}..{hi}" if hi is not None else f">= {lo}"
        _fail(node, f"param '{key}' must be an integer {bound}, got {v!r}")
    return v


def _flag(node: Node, key: str) -> None:
    if not isinstance(node.param(key), bool):
        _fail(node, f"param '{key}' must be True or False, got {node.param(key)!r}")


def _p_const(node):
    _need(node, "value")
    _real(node, "value")


def _p_input(node):
    _need(node, "port")
    if not isinstance(node.param("port"), str) or not node.param("port"):
        _fail(node, f"param 'port' must be a non-empty string, got {node.param('port')!r}")


def _p_gain(node):
    _need(node, "value")
    _real(node, "value")


def _p_register(node):
    _need(node, "reset")
    _real(node, "reset")


def _p_lut(node):
    _need(node, "expr", "lo", "hi", "periodic", "addr_bits", "interpolate")
    if not isinstance(node.param("expr"), str) or not node.param("expr").strip():
        _fail(node, f"param 'expr' must be sympy text in v, got {node.param('expr')!r}")
    # lo/hi of a non-periodic table stay None until tabulate_luts has seen the input's range
    _real(node, "lo", optional=True)
    _real(node, "hi", optional=True)
    lo, hi = node.param("lo"), node.param("hi")
    if (lo is None) != (hi is None) or (lo is not None and not lo < hi):
        _fail(node, f"domain [lo, hi] = [{lo}, {hi}] is not an interval")
    _flag(node, "periodic")
    _flag(node, "interpolate")
    _int(node, "addr_bits", 1, MAX_ADDR_BITS)


def _p_slice(node):
    _need(node, "hi", "lo")
    hi, lo = node.param("hi"), node.param("lo")
    if hi == lo == -1:
        return          # -1:-1 means the most significant (sign) bit, whatever the width
    _int(node, "lo", 0)
    _int(node, "hi", lo)


def _p_compare(node):
    _need(node, "op")
    if node.param("op") not in COMPARE_OPS:
        _fail(node, f"op {node.param('op')!r} is not one of {', '.join(COMPARE_OPS)}")


def _p_fsm(node):
    _need(node, "states", "reset", "transitions", "outputs", "lo", "hi")
    states = node.param("states")
    if not isinstance(states, tuple) or not states or len(set(states)) != len(states):
        _fail(node, f"param 'states' must be a non-empty tuple of distinct names, got {states!r}")
    if node.param("reset") not in states:
        _fail(node, f"reset state {node.param('reset')!r} is not one of its states")
    if not isinstance(node.param("transitions"), tuple):
        _fail(node, f"param 'transitions' must be a tuple, got {node.param('transitions')!r}")
    for t in node.param("transitions"):
        if not isinstance(t, tuple) or len(t) != 4:
            _fail(node, f"transition {t!r} is not (from, op, threshold, to)")
        src, op, threshold, dst = t
        if src != "*" and src not in states:
            _fail(node, f"transition {t!r} starts in unknown state {src!r}")
        if dst not in states:
            _fail(node, f"transition {t!r} goes to unknown state {dst!r}")
        if op not in FSM_OPS:
            _fail(node, f"transition {t!r} has op {op!r}, not one of {', '.join(FSM_OPS)}")
        if isinstance(threshold, bool) or not isinstance(threshold, Real) or not math.isfinite(threshold):
            _fail(node, f"transition {t!r} has a threshold that is not a finite number")
    outputs = node.param("outputs")
    if (not isinstance(outputs, tuple) or len(outputs) != len(states)
            or any(isinstance(o, bool) or not isinstance(o, int) or o < 0 for o in outputs)):
        _fail(node, f"param 'outputs' must hold one unsigned integer per state, got {outputs!r}")
    _real(node, "lo")
    _real(node, "hi")
    if not node.param("lo") <= node.param("hi"):
        _fail(node, f"input range [{node.param('lo')}, {node.param('hi')}] is empty")


def _p_none(node):
    pass


_PARAMS = {
    Kind.CONST: _p_const, Kind.INPUT: _p_input, Kind.GAIN: _p_gain, Kind.ADD: _p_none,
    Kind.SUB: _p_none, Kind.NEG: _p_none, Kind.MUL: _p_none, Kind.REGISTER: _p_register,
    Kind.LUT: _p_lut, Kind.MUX: _p_none, Kind.SLICE: _p_slice, Kind.COMPARE: _p_compare,
    Kind.CAST: _p_none, Kind.FSM: _p_fsm,
}


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


def _check_typed(node: Node, fin: list) -> None:
    out, k = node.qformat, node.kind
    if k is Kind.REGISTER and out != fin[0]:
        _fail(node, f"format {out} differs from its input '{node.inputs[0]}' ({fin[0]})")
    elif k is Kind.COMPARE:
        _flag_format(node, 1)
        _fits(node, _aligned_sum_bits(*fin), "the aligned comparison")
    elif k is Kind.SLICE:
        hi, lo = node.param("hi"), node.param("lo")
        if hi >= fin[0].width:
            _fail(node, f"bit {hi} is outside its {fin[0].width}-bit input '{node.inputs[0]}'")
        _flag_format(node, 1 if hi == lo == -1 else hi - lo + 1)
    elif k is Kind.FSM:
        _flag_format(node, fsm_sem.output_width(node.param("outputs")))
    elif k in (Kind.ADD, Kind.SUB):
        _fits(node, _aligned_sum_bits(*fin), "the aligned sum")
    elif k is Kind.NEG:
        _fits(node, fin[0].width + 1, "the negation")      # -min_int needs one bit more
    elif k is Kind.MUL:
        _operand(node, fin[0], f"'{node.inputs[0]}'")
        _operand(node, fin[1], f"'{node.inputs[1]}'")
        _fits(node, _signed_bits(fin[0]) + _signed_bits(fin[1]), "the product")
    elif k is Kind.GAIN:
        _check_gain(node, fin[0])
    elif k is Kind.MUX:
        _check_mux(node, fin)
    elif k is Kind.CAST:
        _fits(node, _signed_bits(fin[0]) + max(0, out.frac - fin[0].frac), "the input aligned to the output")
    elif k is Kind.LUT:
        _check_table(node, fin[0])


def _check_gain(node: Node, fin: QFormat) -> None:
    _need(node, "cfmt")
    try:
        cfmt = QFormat.parse(node.param("cfmt"))
    except (ValueError, AttributeError):
        _fail(node, f"param 'cfmt' {node.param('cfmt')!r} is not a Q-format")
    _operand(node, fin, f"'{node.inputs[0]}'")
    _operand(node, cfmt, "(the constant)")
    _fits(node, _signed_bits(fin) + cfmt.width, "the product")
    # from_float saturates silently: a constant that does not fit would be a different gain
    scaled = math.floor(math.ldexp(node.param("value"), cfmt.frac) + 0.5)
    if not cfmt.contains(scaled):
        _fail(node, f"value {node.param('value')!r} does not fit its constant format {cfmt}")


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
    _need(node, "table", "shift")
    p = dict(node.params)
    if p["lo"] is None:
        _fail(node, "has no domain (run tabulate_luts before typing)")
    shift = _int(node, "shift", 0)
    table = p["table"]
    n = (1 << p["addr_bits"]) + (1 if p["interpolate"] else 0)
    if not isinstance(table, tuple) or len(table) != n:
        size = len(table) if isinstance(table, tuple) else type(table).__name__
        _fail(node, f"table must have {n} entries for addr_bits={p['addr_bits']}, has {size}")
    for j, y in enumerate(table):
        if isinstance(y, bool) or not isinstance(y, int) or not node.qformat.contains(y):
            _fail(node, f"table entry {j} ({y!r}) is not an integer of its format {node.qformat}")
    if p["periodic"] and (1 << (p["addr_bits"] + shift)) != round(math.ldexp(p["hi"] - p["lo"], fin.frac)):
        # the free wrap-around of the address only works if one period is exactly 2**k LSBs
        _fail(node, f"period {p['hi'] - p['lo']} is not 2**{p['addr_bits'] + shift} LSBs of {fin}")
    if p["interpolate"]:
        _fits(node, node.qformat.width + 1 + shift, "the interpolation product")
