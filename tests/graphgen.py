"""Hypothesis strategies for random small typed IR graphs, for differential fuzzing of the backend.

A :class:`FuzzCase` is a typed graph the Verilog backend accepts (one INPUT node ``u`` and the
core's output ports), an input integer per step, and an optional schedule (clock goal, DSP
budget) for backends that pipeline. The graphs use every node kind with random Q-formats
(signed and unsigned, 1 to 64 bits, fraction bits beyond the width or negative), random
rounding and overflow, registers with feedback, FSMs, LUTs (periodic or clamped, with or
without interpolation, inputs narrower than their index), muxes (also with fewer data
inputs than select codes), slices (of 1-bit values too), compares and FSMs (thresholds and
input ranges at and beyond the input's range). Node names often extend one another
(``a``, ``a_x``, ``p`` beside the probe ``p_x``), the way the backend names its helper wires.
Nothing is steered around: every graph the verifier accepts may come up. Every graph passes
``verify(graph, typed=True)``: a candidate node that would break a width rule is dropped
while drawing, so hypothesis never has to reject a whole graph.

Every output is a REGISTER (a probe) of the node it shows: a register's value is defined at
every step boundary whatever the schedule does inside the step, so the comparison with the
golden model does not depend on when a pipelined core computes a combinational node.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hypothesis import strategies as st

from pendc.ir import lut as lut_sem
from pendc.ir import verify as verify_mod
from pendc.ir.fsm import output_width
from pendc.ir.graph import Graph, GraphError
from pendc.ir.nodes import COMPARE_OPS, Kind, Node, make
from pendc.ir.qformat import Overflow, QFormat, Rounding, bits_for
from pendc.passes.fold_constants import live_nodes

STATE_PORTS = ("x", "dx", "theta", "dtheta")
FLAG_PORTS = ("enc_x_a", "enc_x_b", "enc_theta_a", "enc_theta_b")
LUT_EXPRS = ("sin(v)", "cos(3*v)", "atan(v)", "tanh(v/4)", "exp(-v**2)", "v", "v**2", "v/2 - 1/3")
# suffixes the backend appends to a node's wire for its helpers (and then some): a node named
# after another plus one of these is where generated Verilog names would collide
NAME_SUFFIXES = ("_x", "_a", "_b", "_r", "_s", "_z", "_p", "_q", "_q_r", "_d", "_f", "_f_r", "_ovf", "_sel",
                 "_in0", "_in1", "_state", "_unused", "_idx", "_addr", "_y0", "_step", "_1", "_x_1")
OP_KINDS = (Kind.ADD, Kind.SUB, Kind.NEG, Kind.MUL, Kind.GAIN, Kind.CAST, Kind.CONST, Kind.MUX,
            Kind.SLICE, Kind.COMPARE, Kind.LUT, Kind.FSM)


@dataclass(frozen=True)
class FuzzCase:
    """One graph, the integer fed to its input ``u`` at each step, and the schedule to emit it with
    (``None``: the backend's default; else ``(clock_ns, dsp_budget)``)."""

    graph: Graph
    u: tuple
    schedule: tuple | None = None

    @property
    def steps(self) -> int:
        """Steps the hardware runs; the references run one more to show the state after the last."""
        return len(self.u) - 1


def node_ok(node: Node, fin: list) -> bool:
    """True if ``node`` (inputs of formats ``fin``) passes the verifier's per-node rules (its
    params were checked when it was built)."""
    try:
        verify_mod.check_typed_node(node, fin)
    except GraphError:
        return False
    return True


def _rounding(draw) -> Rounding:
    return draw(st.sampled_from((Rounding.NEAREST, Rounding.TRUNCATE)))


def _overflow(draw) -> Overflow:
    return draw(st.sampled_from((Overflow.WRAP, Overflow.SATURATE)))


def _width(draw, max_width: int) -> int:
    band = draw(st.sampled_from(("narrow", "mid", "wide")))
    lo, hi = {"narrow": (1, 8), "mid": (9, 32), "wide": (33, 64)}[band]
    return draw(st.integers(min(lo, max_width), min(hi, max_width)))


def qformats(draw, signed: bool | None = None, max_width: int = 64) -> QFormat:
    """A random format: narrow (1-8), mid (9-32) or wide (33-64) bits, fraction bits -4..width+4.
    Unsigned formats stop at 63 bits (the int64 golden model cannot hold UFIX64)."""
    signed = draw(st.booleans()) if signed is None else signed
    width = _width(draw, max_width if signed else min(max_width, 63))
    if signed and width == 1:
        width = 2
    frac = draw(st.integers(-4, width + 4))
    return QFormat(signed, width, frac)


qformat_strategy = st.composite(qformats)


def _sw(f: QFormat) -> int:
    """Bits of ``f``'s values as signed numbers."""
    return f.width + (0 if f.signed else 1)


def _near(draw, signed: bool, width: int, frac: int) -> QFormat:
    """An output format near the exact result's (``width`` bits, ``frac`` fraction bits):
    a few fraction bits more or (often) fewer, integer bits cut so values may overflow."""
    signed = draw(st.booleans()) if draw(st.integers(0, 4)) == 0 else signed
    df = draw(st.integers(-6, 3))
    dw = draw(st.integers(-8, 1))
    top = 64 if signed else 63
    w = max(2 if signed else 1, min(top, width + df + dw))
    return QFormat(signed, w, frac + df)


class _Builder:
    """Nodes drawn so far; ``pool`` are the names a new node may read."""

    def __init__(self, draw):
        self.draw = draw
        self.nodes: list = []
        self.fmt: dict = {}
        self.pool: list = []
        # probes and the sign probe are named at the end: reserved from the start
        self.names: set = {f"p_{p}" for p in STATE_PORTS + FLAG_PORTS} | {"u", "u_sign", "p_u_sign"}

    def name(self, plain: str) -> str:
        """``plain`` or, often, a name extending another one (or a probe's prefix ``p``)."""
        draw = self.draw
        choice = draw(st.integers(0, 3))
        if choice == 1:
            stem = draw(st.sampled_from(sorted(self.names | {"p", "u", "n"})))
            candidate = stem + draw(st.sampled_from(NAME_SUFFIXES))
        elif choice == 2:
            candidate = draw(st.sampled_from(("p", "n", "p_x_x", "u_rom", "r0_next_x")))
        else:
            candidate = plain
        if candidate in self.names:
            candidate = plain if plain not in self.names else f"{plain}_{len(self.names)}"
        self.names.add(candidate)
        return candidate

    def add(self, node: Node) -> bool:
        if not node_ok(node, [self.fmt[i] for i in node.inputs]):
            return False
        self.nodes.append(node)
        self.fmt[node.name] = node.qformat
        self.pool.append(node.name)
        return True

    def pick(self, where=None) -> str | None:
        names = [n for n in self.pool if where is None or where(self.fmt[n])]
        if not names:
            return None
        # bias to recent nodes for depth; shrinks towards the newest
        j = self.draw(st.integers(0, len(names) - 1))
        return names[len(names) - 1 - j]


def _const(b: _Builder, name: str) -> Node:
    fmt = qformats(b.draw)
    k = b.draw(st.integers(fmt.min_int - 2, fmt.max_int + 2))   # just outside: from_float saturates
    return make(name, Kind.CONST, qformat=fmt, value=math.ldexp(k, -fmt.frac) + b.draw(st.sampled_from((0.0, 0.3))) * fmt.lsb)


def _arith(b: _Builder, name: str, kind: Kind) -> Node | None:
    draw = b.draw
    if kind in (Kind.MUL, Kind.GAIN):
        a = b.pick(lambda f: f.width <= 32)
        if a is None:
            return None
        fa = b.fmt[a]
        if kind is Kind.MUL:
            c = b.pick(lambda f: f.width <= 32)
            fc = b.fmt[c]
            inputs, params = (a, c), {}
        else:
            fc = qformats(draw, signed=True, max_width=32)
            k = draw(st.integers(fc.min_int, fc.max_int))
            inputs, params = (a,), {"value": math.ldexp(k, -fc.frac), "cfmt": str(fc)}
        out = _near(draw, True, _sw(fa) + _sw(fc), fa.frac + fc.frac)
    elif kind in (Kind.ADD, Kind.SUB):
        a, c = b.pick(), b.pick()
        fa, fc = b.fmt[a], b.fmt[c]
        frac = max(fa.frac, fc.frac)
        inputs, params = (a, c), {}
        out = _near(draw, True, max(_sw(fa) - fa.frac, _sw(fc) - fc.frac) + frac + 1, frac)
    elif kind is Kind.NEG:
        a = b.pick()
        inputs, params = (a,), {}
        out = _near(draw, True, _sw(b.fmt[a]) + 1, b.fmt[a].frac)
    else:   # CAST
        a = b.pick()
        fa = b.fmt[a]
        inputs, params = (a,), {}
        out = _near(draw, fa.signed, fa.width, fa.frac)
    return make(name, kind, inputs, qformat=out, rounding=_rounding(draw), overflow=_overflow(draw), **params)


def _slice(b: _Builder, name: str, src: str | None = None, max_bits: int = 8) -> Node:
    draw = b.draw
    one_bit = draw(st.integers(0, 3)) == 0      # a slice of a 1-bit value (a scalar wire)
    a = src or (one_bit and b.pick(lambda f: f.width == 1)) or b.pick()
    w = b.fmt[a].width
    if draw(st.integers(0, 4)) == 0:
        return make(name, Kind.SLICE, (a,), qformat=QFormat(False, 1, 0), hi=-1, lo=-1)
    lo = draw(st.integers(0, w - 1))
    hi = draw(st.integers(lo, min(w - 1, lo + max_bits - 1)))
    return make(name, Kind.SLICE, (a,), qformat=QFormat(False, hi - lo + 1, 0), hi=hi, lo=lo)


def _select(f: QFormat) -> bool:
    return not f.signed and f.frac == 0 and f.width <= 2


def _mux(b: _Builder, name: str) -> Node | None:
    draw = b.draw
    sel = b.pick(_select)
    if sel is None:
        sel = b.name(f"{name}_sel")
        node = _slice(b, sel, max_bits=2)
        if node is None or not b.add(node):
            return None
    # up to one data input per select code: a select beyond the last input picks the last one
    n = draw(st.integers(2, max(2, 1 << b.fmt[sel].width)))
    data = [b.pick() for _ in range(n)]
    f0 = b.fmt[data[0]]
    out = _near(draw, f0.signed, f0.width, f0.frac)
    return make(name, Kind.MUX, (sel, *data), qformat=out, rounding=_rounding(draw), overflow=_overflow(draw))


def _compare(b: _Builder, name: str) -> Node:
    a, c = b.pick(), b.pick()
    return make(name, Kind.COMPARE, (a, c), qformat=QFormat(False, 1, 0), op=b.draw(st.sampled_from(COMPARE_OPS)))


def _edge_value(draw, fin: QFormat) -> float:
    """A real value at, just beyond or far beyond the edges of the input's range."""
    lsb = fin.lsb
    return draw(st.sampled_from((fin.min_value, fin.max_value, fin.min_value - lsb, fin.max_value + lsb,
                                 fin.min_value - lsb / 2, fin.max_value + lsb / 2, fin.max_value + 0.75 * lsb,
                                 fin.min_value - 1e6 * lsb, fin.max_value * 1e6 + lsb, 1e300, -1e300)))


def _fsm_value(draw, fin: QFormat) -> float:
    return _edge_value(draw, fin) if draw(st.integers(0, 2)) == 0 else _grid_value(draw, fin)


def _grid_value(draw, fin: QFormat, spread: float = 1.0) -> float:
    """A real value on (or between points of) the input's grid, mostly inside its range."""
    lo, hi = fin.min_int, fin.max_int
    extra = int((hi - lo) * (spread - 1.0) / 2)
    k = draw(st.integers(lo - extra, hi + extra))
    return math.ldexp(k, -fin.frac) + draw(st.sampled_from((0.0, 0.0, 0.5, -0.25))) * fin.lsb


def _lut(b: _Builder, name: str) -> Node | None:
    draw = b.draw
    a = b.pick(lambda f: f.width <= 4) if draw(st.integers(0, 3)) == 0 else None   # narrower than the index
    a = a or b.pick()
    fin = b.fmt[a]
    expr = draw(st.sampled_from(LUT_EXPRS))
    ab = draw(st.integers(1, 5))
    interp = draw(st.booleans())
    periodic = draw(st.booleans())
    if periodic:
        s = draw(st.integers(0, 3))
        span = 1 << (ab + s)
        lo_i = draw(st.integers(-span, span))
        lo, hi, shift = math.ldexp(lo_i, -fin.frac), math.ldexp(lo_i + span, -fin.frac), s
    else:
        # the domain may start below the input's range and reach far beyond it
        room = fin.max_int - fin.min_int
        lo_i = draw(st.integers(fin.min_int - (room if draw(st.integers(0, 4)) == 0 else 0), fin.max_int))
        span = draw(st.integers(1, max(1, room * draw(st.sampled_from((1, 1, 1, 4))))))
        lo, reach = math.ldexp(lo_i, -fin.frac), math.ldexp(lo_i + span, -fin.frac)
        shift = lut_sem.grid_shift(lo, reach, ab, fin)
        last = (1 << ab) - (0 if interp else 1)
        hi = math.ldexp(lut_sem.lo_int(lo, fin) + (last << shift), -fin.frac)
    grid = lut_sem.grid_points(lo, ab, shift, fin, interp)
    ymax = float(max(abs(lut_sem.evaluate(expr, grid)).max(), 1e-3))
    signed = draw(st.integers(0, 3)) > 0       # an unsigned table clamps negative values to 0
    width = draw(st.integers(2 if signed else 1, 40))
    ibits = bits_for(ymax, signed) + draw(st.integers(-2, 1))
    fout = QFormat(signed, width, width - ibits)
    table = lut_sem.fill_table(expr, lo, ab, shift, fin, fout, interp, periodic)
    return make(name, Kind.LUT, (a,), qformat=fout, rounding=_rounding(draw), expr=expr, lo=lo, hi=hi,
                periodic=periodic, addr_bits=ab, interpolate=interp, shift=shift, table=table)


def _fsm(b: _Builder, name: str) -> Node:
    draw = b.draw
    a = b.pick()
    fin = b.fmt[a]
    n = draw(st.integers(2, 4))
    states = tuple(f"s{i}" for i in range(n))
    rules = []
    for _ in range(draw(st.integers(1, 5))):
        src = draw(st.sampled_from(("*",) + states))
        threshold = _fsm_value(draw, fin)
        rules.append((src, draw(st.sampled_from(("lt", "le", "gt", "ge"))), threshold, draw(st.sampled_from(states))))
    outputs = tuple(draw(st.integers(0, 15)) for _ in states)
    lo, hi = sorted((_fsm_value(draw, fin), _fsm_value(draw, fin)))
    if draw(st.booleans()):
        lo, hi = fin.min_value, fin.max_value
    return make(name, Kind.FSM, (a,), qformat=QFormat(False, output_width(outputs), 0), states=states,
                reset=draw(st.sampled_from(states)), transitions=tuple(rules), outputs=outputs, lo=lo, hi=hi)


def _draw_node(b: _Builder, name: str, kind: Kind) -> Node | None:
    if kind is Kind.CONST:
        return _const(b, name)
    if kind is Kind.MUX:
        return _mux(b, name)
    if kind is Kind.SLICE:
        return _slice(b, name)
    if kind is Kind.COMPARE:
        return _compare(b, name)
    if kind is Kind.LUT:
        return _lut(b, name)
    if kind is Kind.FSM:
        return _fsm(b, name)
    return _arith(b, name, kind)


def _live(nodes: list, outputs: list) -> set:
    return {n.name for n in live_nodes(nodes, outputs)}


def _inputs(draw, fmt: QFormat, steps: int) -> tuple:
    """Input integers: extremes, small values and uniform draws, held for a few steps at times
    (from a hypothesis-controlled random generator: one draw instead of one per step)."""
    rnd = draw(st.randoms(use_true_random=False))
    edge = (fmt.min_int, fmt.max_int, 0, min(1, fmt.max_int), max(-1, fmt.min_int), fmt.max_int // 2)
    out = []
    while len(out) < steps:
        v = rnd.choice(edge) if rnd.random() < 0.3 else rnd.randint(fmt.min_int, fmt.max_int)
        out.extend([v] * rnd.choice((1, 1, 1, 3)))
    return tuple(out[:steps])


SCHEDULES = (None, (math.inf, None), (4.0, None), (10.0, None), (10.0, 1), (10.0, 3), (25.0, 2))


@st.composite
def fuzz_cases(draw, max_nodes: int = 14, steps: int = 40) -> FuzzCase:
    """A random typed graph the core backend accepts, ``steps`` + 1 input integers and a schedule."""
    b = _Builder(draw)
    b.add(make("u", Kind.INPUT, qformat=qformats(draw), port="u"))
    registers = []
    for r in range(draw(st.integers(0, 3))):
        fmt = qformats(draw)
        reset = _grid_value(draw, fmt)
        name = b.name(f"r{r}")
        registers.append((name, fmt, reset))
        b.fmt[name] = fmt
        b.pool.append(name)
    for i in range(draw(st.integers(1, max_nodes))):
        node = _draw_node(b, b.name(f"n{i}"), draw(st.sampled_from(OP_KINDS)))
        if node is not None:
            b.add(node)
    # close the feedback loops: each register takes a (cast) value drawn from the whole graph
    for name, fmt, reset in registers:
        src = b.pick()
        nxt = name
        if src != name:
            cast = make(b.name(f"{name}_next"), Kind.CAST, (src,), qformat=fmt, rounding=_rounding(draw),
                        overflow=_overflow(draw))
            if b.add(cast):
                nxt = cast.name
        b.nodes.append(make(name, Kind.REGISTER, (nxt,), qformat=fmt, reset=reset))
    outputs = []
    values = [n for n in b.pool if n != "u" or draw(st.booleans())] or ["u"]
    for port in STATE_PORTS:
        src = values[len(values) - 1 - draw(st.integers(0, len(values) - 1))]
        probe = f"p_{port}"
        b.nodes.append(make(probe, Kind.REGISTER, (src,), qformat=b.fmt[src], reset=_grid_value(draw, b.fmt[src])))
        outputs.append((port, probe))
    flags = [n for n in b.pool if b.fmt[n] == QFormat(False, 1, 0)]
    for port in FLAG_PORTS[:-1]:      # the last one stays free for the sign of u (below)
        if flags and draw(st.booleans()):
            src = draw(st.sampled_from(flags))
            probe = f"p_{port}"
            b.nodes.append(make(probe, Kind.REGISTER, (src,), qformat=QFormat(False, 1, 0), reset=0.0))
            outputs.append((port, probe))
    live = _live(b.nodes, outputs)
    if "u" not in live:    # the core's input port must exist: show its sign bit on a flag port
        free = [p for p in FLAG_PORTS if all(p != q for q, _ in outputs)]
        sign = make("u_sign", Kind.SLICE, ("u",), qformat=QFormat(False, 1, 0), hi=-1, lo=-1)
        b.nodes += [sign,
                    make("p_u_sign", Kind.REGISTER, ("u_sign",), qformat=QFormat(False, 1, 0), reset=0.0)]
        outputs.append((free[0], "p_u_sign"))
        live = _live(b.nodes, outputs)
    graph = Graph.build("fuzz", [n for n in b.nodes if n.name in live], outputs)
    verify_mod.verify(graph, typed=True)
    u = _inputs(draw, graph["u"].qformat, steps + 1)
    schedule = draw(st.sampled_from(SCHEDULES))
    return FuzzCase(graph=graph, u=u, schedule=schedule)
