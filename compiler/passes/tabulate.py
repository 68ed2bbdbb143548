"""LUT tabulation: give every table its domain and size, and, once formats are known, its contents.

Two steps, because the grid depends on the input's fixed-point format:

* :func:`tabulate_luts` (before Q-formats) fixes each non-periodic table's domain from
  the simulated range of its input plus a margin, and records the largest |value|
  the function takes on that domain, so the output format holds every entry.
* :func:`fill_lut_tables` (after Q-formats) picks the grid step as a power of two of
  input LSBs (the address is then a plain bit field), quantises the entries and sets
  ``hi`` to the last grid point, so the domain is exactly what the table covers.
"""

from __future__ import annotations

import numpy as np

from ..ir import lut as lut_sem
from ..ir.graph import Graph
from ..ir.nodes import Kind
from .ranges import Ranges


def tabulate_luts(graph: Graph, ranges: Ranges, margin: float = 0.125, addr_bits: int | None = None) -> Graph:
    """Set ``lo``/``hi`` of non-periodic LUTs from ``ranges`` (widened by ``margin`` of the
    largest |input|; inputs never negative keep lo = 0) and ``fmax``, the largest
    |f| on the domain. ``addr_bits`` overrides every table's size."""

    def one(node):
        if node.kind is not Kind.LUT:
            return node
        p = node.params if addr_bits is None else node.params.merged(addr_bits=addr_bits)
        lo, hi = p.lo, p.hi
        if not p.periodic:
            src = node.inputs[0]
            seen_lo, seen_hi = ranges.lo.get(src, 0.0), ranges.hi.get(src, 0.0)
            reach = max(abs(seen_lo), abs(seen_hi), 1e-9) * (1.0 + margin)
            lo = 0.0 if seen_lo >= 0.0 else -reach
            hi = reach
            if not _finite(p.expr, lo, lo + 2.0 * (hi - lo)):
                # a function not finite at zero (1/det of a mass matrix whose determinant depends
                # on several angles, addressed by the determinant): the seen range, widened by
                # the margin of its span either way, if the function is finite there
                span = max(seen_hi - seen_lo, 1e-9 * reach)
                lo, hi = seen_lo - margin * span, seen_hi + margin * span
                # ... but not across zero from an input seen on one side of it (1/t^2 of a gap
                # t >= 1 mm: a domain reaching t = 0 sized the table for 1e10 and read 33 N as 0)
                if seen_lo > 0.0:
                    lo = max(lo, seen_lo / (1.0 + margin))
                if seen_hi < 0.0:
                    hi = min(hi, seen_hi / (1.0 + margin))
        # the grid fitted later to the input's LSBs may reach up to twice the span: the
        # output format must hold the function there too
        reach = hi if p.periodic else lo + 2.0 * (hi - lo)
        grid = np.linspace(lo, reach, 64 * p.segments + 1)
        values = lut_sem.evaluate(p.expr, grid)
        if not np.all(np.isfinite(values)):
            raise ValueError(f"LUT '{node.name}': {p.expr} is not finite on [{lo}, {hi}]")
        return node.with_params(addr_bits=p.addr_bits, lo=lo, hi=hi, fmax=float(np.max(np.abs(values))))

    return graph.map_nodes(one)


def fill_lut_tables(graph: Graph) -> Graph:
    """Fill ``shift`` and ``table`` of every LUT from its input's and its own Q-format."""

    def one(node):
        if node.kind is not Kind.LUT:
            return node
        p = node.params
        fin = graph[node.inputs[0]].qformat
        shift = lut_sem.grid_shift(p.lo, p.hi, p.addr_bits, fin)
        if p.periodic and (1 << (p.addr_bits + shift)) != round(np.ldexp(p.hi - p.lo, fin.frac)):
            raise ValueError(f"LUT '{node.name}': period {p.hi - p.lo} is not 2**k LSBs of {fin}")
        table = lut_sem.fill_table(p.expr, p.lo, p.addr_bits, shift, fin, node.qformat, p.interpolate, p.periodic)
        changes = {"shift": shift, "table": table}
        if not p.periodic:   # the domain is the grid: float and fixed semantics then agree on it
            last = p.segments - (0 if p.interpolate else 1)
            changes["hi"] = float(np.ldexp(lut_sem.lo_int(p.lo, fin) + (last << shift), -fin.frac))
        return node.with_params(**changes)

    filled = graph.map_nodes(one)
    return filled.map_nodes(lambda n: _read_ahead_reset(filled, n))


def _read_ahead_reset(graph: Graph, node):
    """A register loaded from a periodic table (a table read a step ahead, lower_model's
    ``lookahead``) resets to the table's entry at turn 0, which is what a read at the reset
    state (every state zero) gives, to the bit; other nodes unchanged."""
    if node.kind is not Kind.REGISTER:
        return node
    src = graph[node.inputs[0]]
    if src.kind is not Kind.LUT or not src.param("periodic"):
        return node
    return node.with_params(reset=float(np.ldexp(src.param("table")[0], -src.qformat.frac)))


def _finite(expr: str, lo: float, hi: float) -> bool:
    with np.errstate(all="ignore"):
        return bool(np.all(np.isfinite(lut_sem.evaluate(expr, np.linspace(lo, hi, 257)))))
