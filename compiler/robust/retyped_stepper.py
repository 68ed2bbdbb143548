"""The golden plant of a retyped core, stepped by machine code shared by every sample of a sweep.

:class:`pendc.golden.GoldenStepper` compiles a kernel with every constant baked in, so each
sample's core (:mod:`pendc.robust.golden_retype`: other constants and tables in the nominal
formats) would cost two numba compiles (about 10 s together on this machine) before its run.
Here the kernel is the shared form of :func:`pendc.ir.shared_source.shared_kernel_source` against
the nominal core: the nodes a sample changes read their numbers from the ``qp`` argument, so
every sample of a sweep prints the same source and a worker compiles it once. The source is made
resumable exactly as :func:`pendc.golden.resumable_source` makes the baked one (states from and
back to ``st``, overflow steps counted from ``k0``), and checked line by line the same way. The
integers are the same as the baked kernel's (the general requantisation is bit-identical;
``tests/test_robust_golden_retype.py`` compares the two plants on a sample). Imports pendc's IR,
golden model and HIL golden plant.
"""

from __future__ import annotations

import numpy as np

from ..errors import PendcError
from ..golden import OVERFLOW_CHOICES, GoldenStepper, make_resumable
from ..hil.core_ports import CorePorts
from ..hil.golden_plant import GoldenPlant, check_initial
from ..ir.compiled import CompiledGraph

_SIGNATURE = "def kernel(ins, steps, every, tab, rst, qp, sel, out, track, mx, mn, ov):"


def resumable_shared_source(source: str, graph) -> tuple[str, list]:
    """The shared kernel ``source`` with its state made an argument (``st``, ``k0``), and the
    node indices of the states in ``st`` order (:func:`pendc.golden.make_resumable`)."""
    return make_resumable(source, graph, "pendc.robust.retyped_stepper", signature=_SIGNATURE)


class SharedGoldenStepper(GoldenStepper):
    """:class:`pendc.golden.GoldenStepper` (its ``reset`` and start state) over the shared kernel of
    ``graph`` against ``like``: its own constructor, kernel call and ``advance``."""

    def __init__(self, graph, like):
        from ..codegen import load_source

        self.graph = graph
        self.compiled = CompiledGraph(graph, "fixed", like=like)
        if self.compiled.params is None:
            raise PendcError("internal error: the retyped core shares no kernel with the nominal one")
        source, self.state_idx = resumable_shared_source(self.compiled.source, graph)
        self._kernel = load_source(source, "pendc_robust_step").kernel
        self.ports = [p for p, _ in graph.outputs]
        index = {n.name: i for i, n in enumerate(graph.nodes)}
        self._sel = np.array([index[node] for _, node in graph.outputs], dtype=np.int64)
        self._reset_state = self._initial_state()
        self._mx = np.zeros(len(graph.nodes), np.int64)
        self._mn = np.zeros(len(graph.nodes), np.int64)
        self.reset()

    def _run(self, ins, n, every, out, ov, k0):
        c = self.compiled
        self._kernel(ins, n, every, c.tables, c.resets, c.params, self._sel, out, False, self._mx, self._mn, ov,
                     self.state, k0)

    def advance(self, u_int: int, n: int, every_step: bool = True) -> np.ndarray:
        """As :meth:`pendc.golden.GoldenStepper.advance`: (n + 1) x ports output integers (2 rows
        without ``every_step``)."""
        ins = np.full((1, n + 1), int(u_int), dtype=np.int64)
        rows = n + 1 if every_step else 2
        out = np.empty((len(self._sel), rows), np.int64)      # the shared form writes out[column, row]
        ov = np.full(len(self.graph.nodes), -1, np.int64)
        self._run(ins, n, 1 if every_step else n, out, ov, self.k)
        after_n = self.state.copy()
        # the last row: one more step whose update is discarded, so its outputs are the state after n
        self._run(ins[:, n:], 1, 1, out[:, rows - 1:], np.full(len(self.graph.nodes), -1, np.int64), self.k + n)
        self.state = after_n
        for i in np.flatnonzero(ov >= 0):
            self.overflows.setdefault(self.graph.nodes[int(i)].name, int(ov[i]))
        self.k += n
        return out.T


class RetypedGoldenPlant(GoldenPlant):
    """:class:`~pendc.hil.golden_plant.GoldenPlant` on a retyped core, stepped by the shared kernel."""

    def __init__(self, model, build, like, on_overflow: str = "error", initial: tuple | None = None):
        if on_overflow not in OVERFLOW_CHOICES:
            raise PendcError(f"on_overflow must be one of {', '.join(OVERFLOW_CHOICES)}, got {on_overflow!r}")
        self.build = build
        self.model, self.dt, self.on_overflow = model, float(build.options.dt), on_overflow
        graph = build.graph
        try:
            self.ports = CorePorts.of_graph(graph)
        except ValueError as exc:
            raise PendcError(str(exc)) from None
        self.stepper = SharedGoldenStepper(graph, like)
        self._col = {p: self.stepper.ports.index(p) for p in self.ports.outputs}
        self._lsb = {p: graph.output(p).qformat.lsb for p in self.ports.states + self.ports.codes}
        self._u_format = graph[self.ports.input].qformat
        self.initial = check_initial(self.ports, initial)
        self.reset()
