"""The kernel made resumable: its state is an argument, read at the start and written back.

Every kernel :class:`~pendc.ir.compiled.CompiledGraph` compiles has this form, so one
compile serves a run from reset (the state argument holds the reset values), a run continued from
where another stopped (:class:`pendc.golden.GoldenStepper`, the HIL golden plant, windows of the
cocotb vectors) and the error budget's check runs; before, a stepping golden model compiled a
second kernel of the same graph (about 8 s of numba per model). A float kernel's state is float64
(FSM states too, as whole numbers): the error budget's segmented check
(:mod:`pendc.passes.segmented_error`) runs a graph and its float twin side by side in pieces.

The rewrite of the printed kernel: the state variables (registers, FSM states) start from ``st``
(in :func:`state_indices` order) instead of their resets, and are written back to ``st`` before
the kernel returns; a range check records its step as ``k0 + k`` (a resumed run counts steps from
where it stopped). It is checked line by line, so a change of the kernel's shape fails loudly here
instead of miscompiling.
"""

from __future__ import annotations

import re

import numpy as np

from ..errors import PendcError
from .graph import Graph
from .nodes import Kind


def state_indices(graph: Graph) -> list:
    """Node indices of the graph's state (registers and FSMs), in ``st`` order."""
    return [i for i, n in enumerate(graph.nodes) if n.kind.stateful]


def reset_state(graph: Graph, mode: str = "fixed") -> np.ndarray:
    """What ``st`` holds at reset: in fixed point the integers (register resets in their formats,
    FSM reset states), in float the register resets and FSM reset states as float64."""
    fixed = mode == "fixed"
    st = np.empty(len(state_indices(graph)), np.int64 if fixed else np.float64)
    for p, i in enumerate(state_indices(graph)):
        n = graph.nodes[i]
        if n.kind is Kind.FSM:
            st[p] = n.params.reset_index
        else:
            st[p] = n.qformat.from_float(float(n.params.reset)) if fixed else float(n.params.reset)
    return st


def make_resumable(source: str, graph: Graph, header: str, signature: str) -> str:
    """Kernel ``source`` of ``graph`` (its signature line ``signature``) with ``st, k0`` added as
    the module docstring says, its header naming ``header`` as its maker."""
    state_idx = state_indices(graph)
    lines = source.split("\n")
    try:
        head = lines.index(signature)
        loop = lines.index("    for k in range(steps):")
        ret = len(lines) - 1 - lines[::-1].index("    return row")
    except ValueError:
        raise PendcError("internal error: the compiled kernel's source has an unexpected shape") from None
    lines[head] = signature.replace("ov):", "ov, st, k0):")
    seen = []
    for j in range(head + 1, loop):
        m = re.fullmatch(r"    s(\d+) = (.+)", lines[j])
        if m:
            seen.append(int(m.group(1)))
            lines[j] = f"    s{m.group(1)} = st[{state_idx.index(int(m.group(1)))}]"
    if seen != state_idx:
        raise PendcError("internal error: the compiled kernel does not initialise the states it should")
    for j in range(loop, ret):
        lines[j] = re.sub(r"(ov\[(?:\d+|i)\] = )k$", r"\1k0 + k", lines[j])
        # a split kernel's parts record their checks at the step number they are given
        lines[j] = re.sub(r"^(\s+part\d+\(k, )k, ", r"\1k0 + k, ", lines[j])
    lines[ret:ret] = [f"    st[{p}] = s{i}" for p, i in enumerate(state_idx)]
    return "\n".join(lines).replace("pendc.ir.kernel_module", header)
