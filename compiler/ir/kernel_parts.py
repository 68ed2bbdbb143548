"""A large graph's kernel printed as several step functions (parts) instead of one.

numba's compile time grows faster than linearly with the size of one function: its
reaching-definition and liveness analyses visit every variable of every block, so a
538-node graph's 4,500-line step loop took about 100 s to compile, most of it in those
passes. Split into parts of a few hundred lines each, the same statements compile several
times faster, and run as fast (a part is a function call per step, its values pass through
the ``buf`` array every kernel already fills for tracking).

The parts compute exactly the statements of the one-function kernel, in the same order, so
the results are the same bits: values cross between parts through ``buf`` (int64 or float64,
the nodes' own types), nothing is recomputed or reassociated.

Layout: ``part<p>(k, step, ins, tab, <data args>buf, ov)`` holds the statements of consecutive
nodes of step ``k`` (the column of ``ins``); it reads the values of earlier nodes from ``buf``,
writes its own nodes' values there, and records the step number ``step`` in ``ov`` where its
range checks fire first (a resumed kernel counts steps from where it stopped). The kernel keeps the
state: registers and FSM outputs (functions of the state alone) are computed at the top of
each step, the FSMs' range checks and the state updates at its end, from ``buf``.
"""

from __future__ import annotations

import re

PART_LINES = 300          # statements per part: numba compiles parts of this size quickly
SPLIT_ABOVE = 1000        # a step loop this long (statements) is split; the SCT's (about 700) stays one function
_VALUE = re.compile(r"\bv(\d+)\b")
# nogil: independent runs of a kernel go side by side on threads (pendc.ir.compiled.run_side_by_side)
DECORATOR = '@njit(cache=True, nogil=True, error_model="numpy")'


def split_groups(groups: list) -> list:
    """Consecutive runs of ``(node indices, lines)`` groups of about PART_LINES lines each."""
    parts, current, size = [], [], 0
    for group in groups:
        current.append(group)
        size += len(group[1])
        if size >= PART_LINES:
            parts.append(current)
            current, size = [], 0
    return parts + ([current] if current else [])


def _loads(lines: list, defined: set) -> list:
    """``v<j> = buf[j]`` for every value ``lines`` read that they do not define."""
    used = sorted({int(m) for line in lines for m in _VALUE.findall(line)} - defined)
    return [f"v{j} = buf[{j}]" for j in used]


def part_source(p: int, groups: list, flags: list, data_args: str) -> str:
    """The function ``part<p>``: the groups' statements between loads from and stores to ``buf``,
    then one rarely taken branch recording the checks of ``flags`` that fired."""
    defined = sorted(i for nodes, _ in groups for i in nodes)
    body = [s for _, lines in groups for s in lines]
    own = [i for i in flags if i in set(defined)]
    lines = _loads(body, set(defined)) + body + [f"buf[{i}] = v{i}" for i in defined]
    if own:
        lines += [f"if {' | '.join(f'b{i}' for i in own)}:"]
        for i in own:
            lines += [f"    if b{i} & (ov[{i}] < 0):", f"        ov[{i}] = step"]
    return (f"{DECORATOR}\ndef part{p}(k, step, ins, tab, {data_args}buf, ov):\n"
            + "".join(f"    {s}\n" for s in lines) + "\n\n")


def split_step(gen, groups: list, data_args: str) -> tuple:
    """(the parts' source, the kernel's step statements before its recording, the flags the kernel
    itself checks) for a step whose node statements are ``groups`` [(node indices they compute, lines)].

    Registers and FSM outputs stay in the kernel (they read its state variables); every other
    node goes to a part, in order."""
    nodes = gen.g.nodes
    stateful = [(ids, lines) for ids, lines in groups if nodes[ids[0]].kind.stateful]
    rest = [(ids, lines) for ids, lines in groups if not nodes[ids[0]].kind.stateful]
    parts = split_groups(rest)
    in_parts = {i for ids, _ in rest for i in ids}
    source = "".join(part_source(p, part, gen.flags, data_args) for p, part in enumerate(parts))
    step = [s for ids, lines in stateful for s in lines + [f"buf[{i}] = v{i}" for i in ids]]
    step += [f"part{p}(k, k, ins, tab, {data_args}buf, ov)" for p in range(len(parts))]
    tail = gen.late + gen.update
    step += _loads(tail, {i for ids, _ in stateful for i in ids}) + gen.late
    return source, step, [i for i in gen.flags if i not in in_parts]

