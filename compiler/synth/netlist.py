"""Reading Yosys' output: cell counts from ``stat -json`` and the logic depth of a mapped netlist.

Yosys' own ``ltp`` walks through flip-flops of the mapped library, so the depth is
computed here: the longest chain of combinational cells between sequential cells
(flip-flops, block RAMs) or ports, every mapped cell one level (a carry cell too, as
the thesis counted its 431 levels).
"""

from __future__ import annotations

import sys


def cell_counts(stat: dict, top: str) -> dict:
    """Cell type -> count of the whole (flattened) design from ``stat -json``."""
    design = stat.get("design") or stat.get("modules", {}).get(f"\\{top}") or {}
    return {str(k): int(v) for k, v in design.get("num_cells_by_type", {}).items()}


def logic_depth(netlist: dict, top: str, sequential: tuple) -> tuple[int, list]:
    """(levels, a few cell names along the path) of the longest combinational path of ``top``."""
    module = netlist.get("modules", {}).get(top)
    if module is None:
        return 0, []
    driver: dict = {}
    cells = module.get("cells", {})
    inputs: dict = {}
    for name, cell in cells.items():
        dirs = cell.get("port_directions", {})
        ins = []
        for port, bits in cell.get("connections", {}).items():
            for b in bits:
                if not isinstance(b, int):
                    continue                    # constant bit
                if dirs.get(port) == "output":
                    driver[b] = name
                else:
                    ins.append(b)
        inputs[name] = ins
    comb = {n for n, c in cells.items() if not str(c.get("type", "")).startswith(sequential)}
    depth: dict = {}
    prev: dict = {}
    limit = sys.getrecursionlimit()
    for start in comb:                              # iterative DFS, memoised
        if start in depth:
            continue
        stack = [(start, False)]
        while stack:
            name, done = stack.pop()
            if name in depth:
                continue
            preds = {driver[b] for b in inputs[name] if b in driver and driver[b] in comb}
            if not done:
                stack.append((name, True))
                stack.extend((p, False) for p in preds if p not in depth)
                if len(stack) > 50 * limit:
                    break
                continue
            best = max(preds, key=lambda p: depth.get(p, 0), default=None)
            depth[name] = 1 + (depth.get(best, 0) if best else 0)
            prev[name] = best
    if not depth:
        return 0, []
    end = max(depth, key=lambda k: (depth[k], k))
    path = []
    while end is not None and len(path) <= len(depth):
        path.append(end)
        end = prev.get(end)
    path.reverse()
    shown = path if len(path) <= 8 else path[:4] + ["..."] + path[-3:]
    return depth[path[-1]], shown
