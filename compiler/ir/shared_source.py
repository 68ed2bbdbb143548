"""Fixed-point kernel source that shares machine code with a graph's earlier retyping.

The constant-baked kernel (:mod:`pendc.ir.compiled_source`) prints every shift, rounding
constant and saturation bound, and leaves out the range checks the formats prove idle, so
each change of format compiles new machine code (~7 s for a plant). The error budget retypes
one graph round after round, and its widening rounds change the same few nodes each time
(the state accumulators and what reads them). :func:`shared_kernel_source` prints the nodes
whose baked code equals a reference graph's as baked, and the others in a general form whose
numbers are read from the int64 argument ``qp``: rounds that differ from the reference in
the same nodes print the same source and share one compile, whatever their formats.
(Every node in the general form would share even more, but numba's compile cost per array
read and per variable makes that kernel 3-4x slower to compile than the baked one.)

The general requantisation is branch-free like the baked one and bit-identical to
:func:`pendc.ir.qformat.requantize`: for ``v`` at ``frac`` fraction bits into ``fmt``, with
``s = frac - fmt.frac``, ``rs = min(max(s, 0), 63)`` and ``ls = max(-s, 0)``,

* ``y = (v >> rs) + ((v >> rs1) & rb)``: floor(v / 2**rs), plus bit rs-1 when rounding to
  nearest (floor((v + half) / 2**rs) without forming v + half); ``rs1 = rb = 0`` when
  s <= 0, and ``rs = rs1 = 63, rb = 1`` when s >= 64 (the result is 0 for every int64);
* overflow iff ``y > up`` or ``y < down`` (``up = max_int >> ls``, ``down = -(-min_int >> ls)``);
* saturate: ``(clamp(y, down, up) << ls) + dh * (y > up) + dl * (y < down)`` where ``dh``
  (``dl``) lifts ``up << ls`` to ``max_int`` (``down << ls`` to ``min_int``);
* wrap: ``((y & keep) << (ls + sx)) >> sx & mask`` with ``sx = 64 - width`` for signed
  formats (sign extension), 0 and ``mask = 2**width - 1`` for unsigned; ``keep = 0`` once the
  shift leaves no bit (the wrapped value is then 0).
"""

from __future__ import annotations

from . import fsm as fsm_sem
from . import lut as lut_sem
from .compiled_source import _FixedGen
from .kernel_module import assemble
from .graph import Graph
from .qformat import Overflow, Rounding
from .requant_source import I64_MAX, I64_MIN


class _DataGen(_FixedGen):
    """Bit-accurate int64 printer of the general form: ``qp[k]`` where the baked one prints a number.

    The baked printer's visits serve as they are: its numbers, operand alignments and
    requantisations go through :meth:`lit`, :meth:`aligned` and :meth:`rq`, overridden here. What
    else is overridden prints text that must not depend on the numbers (it is shared by retypings
    that differ in them), where the baked printer leaves out what its numbers make idle."""

    def __init__(self, graph: Graph):
        super().__init__(graph, runtime_resets=True, share_lut_index=False)
        self.params: list[int] = []

    def comment(self, node) -> str:
        # no Q-format: the comment is part of the shared text, and the formats differ
        return " ".join(f"# {node.name} = {node.kind.value}({', '.join(node.inputs)})".split())

    def lit(self, value: int) -> str:
        """A new kernel datum ``value``: the expression that reads it."""
        value = int(value)
        if not I64_MIN <= value <= I64_MAX:
            raise ValueError(f"constant {value} does not fit the 64-bit golden model")
        k = len(self.params)
        self.params.append(value)
        return f"qp[{k}]"

    def threshold_test(self, v, op, x, fin) -> str:
        # every test printed: the baked one folds a test its input's format decides
        return f"{v} {op.symbol} {self.lit(fsm_sem.threshold_int(x, fin))}"

    def aligned(self, name: str, frac: int) -> tuple:
        # the shift printed even when it is 0 (the baked form then prints the bare value)
        lo, hi = self.bounds(name)
        n = frac - self.g[name].qformat.frac
        return f"(v{self.idx[name]} << {self.lit(n)})", (lo << n, hi << n)

    def rq(self, i, node, expr, rng, frac, tgt="", flag="") -> list:
        """Lines assigning ``requantize(expr, frac, node's format, ...)`` to ``tgt`` (default
        ``v<i>``) and its overflow to ``flag`` (default ``b<i>``, then noted as the node's check).
        Every check is printed: ``rng``, the bounds that let the baked form leave one out, is unused."""
        fmt = node.qformat
        if not flag:
            self.flags.append(i)
        tgt, flag = tgt or f"v{i}", flag or f"b{i}"
        t, y = "t" + tgt[1:], "r" + tgt[1:]
        shift = frac - fmt.frac
        ls = max(-shift, 0)
        lines = [f"{t} = {expr}"]
        if node.rounding is Rounding.NEAREST:
            rs, rs1, rb = (63, 63, 1) if shift >= 64 else (shift, shift - 1, 1) if shift > 0 else (0, 0, 0)
            lines.append(f"{y} = ({t} >> {self.lit(rs)}) + (({t} >> {self.lit(rs1)}) & {self.lit(rb)})")
        else:
            lines.append(f"{y} = {t} >> {self.lit(min(max(shift, 0), 63))}")
        up, down = fmt.max_int >> ls, -((-fmt.min_int) >> ls)
        pu, pd = self.lit(up), self.lit(down)
        lines.append(f"{flag} = ({y} > {pu}) | ({y} < {pd})")
        if node.overflow is Overflow.SATURATE:
            lines.append(f"{tgt} = (min(max({y}, {pd}), {pu}) << {self.lit(min(ls, 63))})"
                         f" + {self.lit(fmt.max_int - (up << ls))} * ({y} > {pu})"
                         f" + {self.lit(fmt.min_int - (down << ls))} * ({y} < {pd})")
        else:
            sx = 64 - fmt.width if fmt.signed else 0
            mask = -1 if fmt.signed else (1 << fmt.width) - 1
            keep = -1 if ls + sx < 64 else 0
            lines.append(f"{tgt} = ((({y} & {self.lit(keep)}) << {self.lit(min(ls + sx, 63))}) >> {self.lit(sx)})"
                         f" & {self.lit(mask)}")
        return lines

    def visit_lut(self, node, i):
        # every step printed, interpolation and range check alike: the baked one leaves out the
        # interpolation of a zero shift and computes a group's address once
        p = node.params
        fin = self.g[node.inputs[0]].qformat
        table, shift, bits, interp = p.table, p.shift, p.addr_bits, bool(p.interpolate)
        seg = 1 << bits
        if table is None or shift is None:
            raise ValueError(f"LUT '{node.name}' has no table yet (run fill_lut_tables)")
        if len(table) != seg + interp:
            raise ValueError(f"LUT '{node.name}': table has {len(table)} entries, expected {seg + interp}")
        self.offsets[node.name] = self.tab_len
        off = self.lit(self.tab_len)
        self.tab_len += len(table)
        d, j, f, jj, ff, y0 = (f"{x}{i}" for x in ("d", "j", "f", "jj", "ff", "y"))
        sh = self.lit(min(shift, 63))
        lines = [f"{d} = v{self.idx[node.inputs[0]]} - {self.lit(lut_sem.lo_int(p.lo, fin))}", f"{j} = {d} >> {sh}",
                 f"{f} = {d} & {self.lit((1 << shift) - 1)}"]
        if p.periodic:
            lines += [f"{jj} = {j} & {self.lit(seg - 1)}", f"{ff} = {f}"]
            nxt = f"{jj} + 1"
        else:   # beyond the domain: the end entry, no interpolation (flagged unless exactly the end)
            last = self.lit(seg if interp else seg - 1)
            out = (f"({j} < 0) | ({j} > {last}) | (({j} == {last}) & ({f} != 0))" if interp
                   else f"({j} < 0) | ({j} > {last})")
            lines += [f"b{i} = {out}", f"{jj} = min(max({j}, 0), {last})", f"{ff} = {f} * (1 - b{i})"]
            self.flags.append(i)
            nxt = f"min({jj} + 1, {last})"
        if not interp:
            return lines + [f"v{i} = tab[{off} + {jj}]"]
        # with shift 0, ff is 0 and so is the rounding half: the interpolation adds nothing
        step = f"(tab[{off} + {nxt}] - {y0}) * {ff}"
        if node.rounding is Rounding.NEAREST:
            step = f"({step} + {self.lit(1 << (shift - 1) if shift else 0)})"
        return lines + [f"{y0} = tab[{off} + {jj}]", f"v{i} = {y0} + ({step} >> {sh})"]


def _baked_lines(graph: Graph) -> dict:
    """Per node, everything the baked printer emits for it (code, head, update, checks)."""
    # node by node: no LUT prints its group's lines
    gen, out = _FixedGen(graph, runtime_resets=True, share_lut_index=False), {}
    for i, n in enumerate(graph.nodes):
        marks = len(gen.head), len(gen.update), len(gen.late), len(gen.flags)
        lines = gen.visit(n, i)
        parts = (gen.head, gen.update, gen.late, gen.flags)
        out[n.name] = (i, gen.comment(n), tuple(lines)) + tuple(tuple(p[m:]) for p, m in zip(parts, marks))
    return out


def same_structure(a: Graph, b: Graph) -> bool:
    """Same nodes (names, kinds, inputs, modes) in the same order: formats and numbers may differ."""
    def key(g):
        return [(n.name, n.kind, n.inputs, n.rounding, n.overflow) for n in g.nodes]
    return a.name == b.name and key(a) == key(b) and a.outputs == b.outputs


class _SharedGen:
    """The printer :func:`pendc.ir.kernel_module.assemble` drives: baked nodes by the baked
    printer, the ``general`` ones by :class:`_DataGen`, into the same kernel."""

    fixed = True

    def __init__(self, graph: Graph, general: set):
        self.g, self.general = graph, general
        self.baked, self.data = _FixedGen(graph, runtime_resets=True, share_lut_index=False), _DataGen(graph)
        for part in ("head", "update", "late", "flags", "offsets"):
            setattr(self.data, part, getattr(self.baked, part))
        self.head, self.update, self.late, self.flags = self.baked.head, self.baked.update, self.baked.late, \
            self.baked.flags
        self.offsets = self.baked.offsets

    def _gen(self, node):
        return self.data if node.name in self.general else self.baked

    def comment(self, node) -> str:
        return self._gen(node).comment(node)

    def defined_by(self, i: int) -> list:
        return [i]      # node by node (share_lut_index=False)

    def visit(self, node, i):
        gen = self._gen(node)
        gen.tab_len = max(self.baked.tab_len, self.data.tab_len)
        return gen.visit(node, i)


def shared_kernel_source(graph: Graph, like: Graph | None = None) -> tuple[str, dict, list]:
    """(kernel module source, {LUT node name: table offset}, the ``qp`` data) of a typed graph:
    nodes whose baked code equals ``like``'s (same structure) are baked, the others read their
    numbers from ``qp``. Without ``like``, or of another structure, every node is baked.

    The kernel takes ``rst`` and ``qp`` after ``tab`` and indexes ``out`` [column, row] (the
    ``runtime_data`` form of :func:`pendc.ir.kernel_module.kernel_source`)."""
    general = set()
    if like is not None and same_structure(graph, like):
        mine, theirs = _baked_lines(graph), _baked_lines(like)
        general = {name for name in mine if mine[name] != theirs[name]}
    gen = _SharedGen(graph, general)
    note = f", {len(general)} nodes' formats as data (qp)" if general else ""
    src = assemble(gen, True, data_args="qp, ", note=note)
    return src, dict(gen.offsets), list(gen.data.params)
