"""Compiled golden model: a graph printed as Python and compiled by numba.

Same semantics and same :class:`~pendc.ir.interpret.Trace` as the reference
interpreters, about two orders of magnitude faster, so range analysis, error
budgets and long verification runs can afford millions of steps. ``mode="fixed"``
is bit-identical to :class:`~pendc.ir.interpret.FixedInterpreter` (int64 arithmetic;
the verifier guarantees every exact intermediate fits), ``mode="float"`` mirrors
:class:`~pendc.ir.interpret.FloatInterpreter`.

The source (see :mod:`pendc.ir.kernel_module`) depends on the graph's structure and
constants only: LUT contents are an argument, so refilling tables reuses the machine
code; given ``like``, an earlier typing of the same graph, the nodes whose code differs
from it read their numbers from data too (:mod:`pendc.ir.shared_source`), so retypings
that differ alike share one compile. It is written to a cache file named by its hash
(``$PENDC_CACHE_DIR`` or ``~/.cache/pendc/kernels``) and compiled with numba's on-disk cache.
The kernels release the GIL, so independent runs go side by side on the machine's cores
(:func:`run_side_by_side`).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..codegen import cache_dir  # noqa: F401  (re-exported for callers)
from ..native.build import kernel_function

from .kernel_module import kernel_source
from .graph import Graph
from .interpret import Trace
from .nodes import Kind
from .qformat import QFormat
from .resumable import make_resumable, reset_state
from .shared_source import shared_kernel_source

# the signature lines of the baked and the shared fixed-point kernels (pendc.ir.kernel_module)
_SIGNATURE = {False: "def kernel(ins, steps, every, tab, rst, sel, out, track, mx, mn, ov):",
              True: "def kernel(ins, steps, every, tab, rst, qp, sel, out, track, mx, mn, ov):"}


def quantize(values, fmt: QFormat) -> np.ndarray:
    """Vectorised ``fmt.from_float`` (nearest, saturate): bit-identical to the scalar rule."""
    x = np.asarray(values, dtype=np.float64)
    y = np.floor(np.ldexp(x, fmt.frac) + 0.5)   # the same two IEEE operations as math.floor(ldexp(v, f) + 0.5)
    if not np.all(np.isfinite(y)):
        bad = x.flat[int(np.flatnonzero(~np.isfinite(y.ravel()))[0])]
        raise ValueError(f"input value {bad!r} cannot be quantised into {fmt}")
    top = float(1 << (fmt.width - 1 if fmt.signed else fmt.width))   # max_int + 1, a power of two
    over, under = y >= top, y < float(fmt.min_int)
    out = np.where(over | under, 0.0, y).astype(np.int64)
    out[over] = fmt.max_int
    out[under] = fmt.min_int
    return out


def record_buffer(columns: int, rows: int, dtype) -> np.ndarray:
    """An ``out`` array for a kernel recording ``rows`` rows of ``columns`` nodes (``out[column,
    row]``), its rows padded so that consecutive columns do not start a multiple of 4 KiB apart:
    there they all map to one set of the CPU's L1 cache, and a step writing one value into each
    evicts the others (a power-of-two piece of the segmented comparison, 16384 steps, is exactly
    that: recording its 13-21 columns took 15-17 % longer). Read ``out[:, :rows]``."""
    width = -(-rows // 8) * 8               # whole 64-byte lines
    if (width // 8) % 2 == 0:               # an odd number of lines apart: columns fall on every set in turn
        width += 8
    return np.empty((columns, width), dtype)


class CompiledGraph:
    """A graph compiled for ``mode`` "fixed" (every node must be typed) or "float"."""

    def __init__(self, graph: Graph, mode: str = "fixed", like: Graph | None = None):
        if mode not in ("fixed", "float"):
            raise ValueError(f"mode must be 'fixed' or 'float', got {mode!r}")
        if mode == "fixed":
            untyped = [n.name for n in graph.nodes if n.qformat is None]
            if untyped:
                raise ValueError(f"graph is not typed (no Q-format): {', '.join(untyped[:5])}")
            wide = [n.name for n in graph.nodes if not n.qformat.signed and n.qformat.width == 64]
            if wide:
                raise ValueError(f"UFIX64 does not fit the int64 golden model: {', '.join(wide[:5])}")
        self.graph, self.mode = graph, mode
        self.index = {n.name: i for i, n in enumerate(graph.nodes)}
        # ``like``: an earlier typing of the same graph; the nodes whose code differs from its
        # read their numbers from ``params``, so later typings that differ in the same nodes (the
        # error budget's widening rounds) share this kernel's machine code
        source, offsets, params = shared_kernel_source(graph, like) if like is not None and mode == "fixed" \
            else (None, None, [])
        if not params:
            source, offsets = kernel_source(graph, mode, runtime_data=True)
        # one compile for runs from reset and runs resumed (pendc.ir.resumable), in both modes
        source = make_resumable(source, graph, "pendc.ir.compiled", _SIGNATURE[bool(params)])
        self.start = reset_state(graph, mode)
        self.start.setflags(write=False)
        self.source, self.params = source, np.asarray(params, dtype=np.int64) if params else None
        tables = [np.asarray(graph[name].params.table, dtype=np.int64) for name in offsets]
        self.tables = np.concatenate(tables) if tables else np.zeros(0, np.int64)
        self.tables.setflags(write=False)
        # register resets are kernel arguments (a graph that differs only in a reset, like the
        # spinning-pendulum training run, reuses the machine code)
        dtype = np.int64 if mode == "fixed" else np.float64
        self.resets = np.zeros(len(graph.nodes), dtype)
        for i, n in enumerate(graph.nodes):
            if n.kind is Kind.REGISTER:
                value = float(n.params.reset)
                self.resets[i] = n.qformat.from_float(value) if mode == "fixed" else value
        self.resets.setflags(write=False)
        self._kernel = kernel_function(self.source, "pendc_ir")

    def _input_matrix(self, inputs: dict, steps: int | None) -> tuple[np.ndarray, int]:
        nodes = [n for n in self.graph.nodes if n.kind is Kind.INPUT]
        ports = {n.params.port for n in nodes}
        missing = ports - set(inputs)
        if missing:
            raise ValueError(f"no values for input port(s) {', '.join(sorted(missing))}")
        arrays = {p: np.asarray(inputs[p]) for p in ports}
        n = min(len(a) for a in arrays.values()) if arrays else (steps or 0)
        steps = n if steps is None else min(steps, n) if arrays else steps
        dtype = np.int64 if self.mode == "fixed" else np.float64
        ins = np.empty((len(nodes), steps), dtype)
        for j, node in enumerate(nodes):
            a = arrays[node.params.port][:steps]
            if self.mode == "float":
                ins[j] = a.astype(np.float64)
            elif a.dtype.kind in "iu":
                ins[j] = a.astype(np.int64)
            elif a.dtype == object:
                ins[j] = [int(v) if isinstance(v, (int, np.integer)) else node.qformat.from_float(float(v)) for v in a]
            else:
                ins[j] = quantize(a, node.qformat)
        return ins, steps

    def call(self, ins, steps: int, every: int, sel, out, ov, st, k0: int, track: bool = False, mx=None, mn=None):
        """The kernel itself: ``steps`` steps of ``ins`` from the state ``st`` (updated in place;
        :func:`pendc.ir.resumable.state_indices` order; int64 in fixed point, float64 in float)
        counting steps from ``k0``, every ``every``-th row of the nodes ``sel`` into
        ``out[column, row]`` (C-contiguous: another array layout is another numba signature,
        another compile); returns the rows written."""
        if mx is None:
            if self.mode == "fixed":
                mx = mn = np.zeros(len(self.graph.nodes), np.int64)
            else:
                mx, mn = np.full(len(self.graph.nodes), -np.inf), np.full(len(self.graph.nodes), np.inf)
        data = (self.tables, self.resets) if self.params is None else (self.tables, self.resets, self.params)
        return self._kernel(ins, steps, every, *data, sel, out, track, mx, mn, ov, st, k0)

    def run(self, inputs: dict, steps: int | None = None, every: int = 1, track_max: bool = False,
            record: tuple = ()) -> Trace:
        """Run ``steps`` steps (default: as many as input values), recording every ``every``-th row.

        ``record`` names internal nodes to return as well, under their own names in
        ``Trace.outputs``, as if they were outputs."""
        if int(every) < 1:
            raise ValueError(f"every must be >= 1, got {every}")
        every = int(every)
        ports = dict(self.graph.outputs)
        for name in record:
            if name not in self.index:
                raise ValueError(f"cannot record unknown node '{name}'")
            if name in ports and ports[name] != name:
                raise ValueError(f"recorded node '{name}' clashes with output port '{name}'")
        columns = [p for p, _ in self.graph.outputs] + [n for n in record if n not in ports]
        sel = np.array([self.index[ports.get(c, c)] for c in columns], dtype=np.int64)
        ins, steps = self._input_matrix(inputs, steps)
        n = len(self.graph.nodes)
        dtype = np.int64 if self.mode == "fixed" else np.float64
        rows = (steps + every - 1) // every
        out = record_buffer(len(columns), rows, dtype)      # a row per column: no copies
        if self.mode == "fixed":
            mx, mn = np.zeros(n, dtype), np.zeros(n, dtype)
        else:
            mx, mn = np.full(n, -np.inf), np.full(n, np.inf)
        ov = np.full(n, -1, np.int64)
        self.call(ins, steps, every, sel, out, ov, self.start.copy(), 0, track=bool(track_max), mx=mx, mn=mn)
        outputs = {c: out[j, :rows] for j, c in enumerate(columns)}
        nodes = self.graph.nodes
        extremes = {}
        if not track_max:
            maxima = {}
        elif self.mode == "fixed":
            maxima = {nd.name: float(max(abs(int(mx[i])), abs(int(mn[i])))) for i, nd in enumerate(nodes)}
        elif steps == 0:
            maxima = {nd.name: 0.0 for nd in nodes}
        else:
            peak = np.maximum(np.abs(mx), np.abs(mn))       # NaN-propagating, as the old max |v| was
            maxima = {nd.name: float(peak[i]) for i, nd in enumerate(nodes)}
            extremes = {nd.name: (float(mn[i]), float(mx[i])) for i, nd in enumerate(nodes)}
        overflows = {nd.name: int(ov[i]) for i, nd in enumerate(nodes) if ov[i] >= 0}
        return Trace(outputs=outputs, max_abs=maxima, overflows=overflows, steps=steps, extremes=extremes)


def run_side_by_side(calls: list) -> list:
    """The results of the zero-argument ``calls`` (kernel runs: they release the GIL), in order,
    run on as many threads as there are cores and calls. A call's exception is raised here."""
    workers = min(len(calls), os.cpu_count() or 1)
    if workers <= 1:
        return [call() for call in calls]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(lambda call: call(), calls))
