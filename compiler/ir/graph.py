"""The dataflow graph: an immutable, topologically ordered tuple of nodes plus named outputs.

Registers and FSMs break cycles: a register's output is available at the start of a step,
its input is taken at the end. ``Graph.build`` orders the combinational nodes
topologically (stable with respect to the order given), so equal inputs always
give an identical graph and an identical text form.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

from .nodes import SOURCE_KINDS, GraphError, Kind, Node

__all__ = ["Graph", "GraphError"]


@dataclass(frozen=True)
class Graph:
    """Nodes in evaluation order and the graph's outputs as ``(port, node name)`` pairs."""

    name: str
    nodes: tuple
    outputs: tuple
    info: tuple = field(default=(), compare=False)   # (key, value) notes carried for reports

    @staticmethod
    def build(name: str, nodes, outputs, info=()) -> "Graph":
        """Order ``nodes`` for evaluation: sources and registers first, then combinational
        nodes after their inputs, keeping the given order wherever dependencies allow."""
        nodes = list(nodes)
        by_name = {}
        for n in nodes:
            if n.name in by_name:
                raise GraphError(f"duplicate node name '{n.name}'")
            by_name[n.name] = n
        for n in nodes:
            for i in n.inputs:
                if i not in by_name:
                    raise GraphError(f"node '{n.name}' reads undefined node '{i}'")
        placed, order = set(), []
        for n in nodes:
            if n.kind in SOURCE_KINDS:
                order.append(n)
                placed.add(n.name)
        pending = [n for n in nodes if n.name not in placed]
        while pending:
            progress = []
            for n in pending:
                if all(i in placed for i in n.inputs):
                    order.append(n)
                    placed.add(n.name)
                    progress.append(n.name)
            if not progress:
                stuck = ", ".join(n.name for n in pending[:5])
                raise GraphError(f"combinational cycle (not broken by a register) through: {stuck}")
            pending = [n for n in pending if n.name not in placed]
        for port, node in outputs:
            if node not in by_name:
                raise GraphError(f"output '{port}' names undefined node '{node}'")
        return Graph(name=name, nodes=tuple(order), outputs=tuple(outputs), info=tuple(info))

    @cached_property
    def by_name(self) -> dict:
        return {n.name: n for n in self.nodes}

    def __getitem__(self, name: str) -> Node:
        return self.by_name[name]

    def __contains__(self, name: str) -> bool:
        return name in self.by_name

    @cached_property
    def memo(self) -> dict:
        """Facts a pass derives from this graph, by the pass's own key: the graph is immutable, so
        they never go stale (a schedule search asks every product's widths once per clock goal)."""
        return {}

    @cached_property
    def consumers(self) -> dict:
        """Node name -> names of the nodes that read it."""
        out = {n.name: [] for n in self.nodes}
        for n in self.nodes:
            for i in n.inputs:
                out[i].append(n.name)
        return {k: tuple(v) for k, v in out.items()}

    def of_kind(self, *kinds: Kind) -> tuple:
        return tuple(n for n in self.nodes if n.kind in kinds)

    def output(self, port: str) -> Node:
        for p, n in self.outputs:
            if p == port:
                return self.by_name[n]
        raise KeyError(port)

    def with_nodes(self, nodes, outputs=None) -> "Graph":
        """A new graph from a replacement node list (re-ordered and checked for cycles)."""
        return Graph.build(self.name, nodes, self.outputs if outputs is None else outputs, self.info)

    def replace_node(self, node: Node) -> "Graph":
        return replace(self, nodes=tuple(node if n.name == node.name else n for n in self.nodes))

    def map_nodes(self, fn) -> "Graph":
        """Apply ``fn`` to every node (it must keep names and inputs); order is unchanged."""
        return replace(self, nodes=tuple(fn(n) for n in self.nodes))

    def text(self) -> str:
        """Deterministic text form, one node per line, in evaluation order; params print in
        their legacy key=value form, sorted by key (a table as its size)."""
        lines = [f"graph {self.name}"]
        for n in self.nodes:
            items = n.params.items()
            params = "".join(f" {k}={_fmt(v)}" for k, v in items if k != "table")
            table = dict(items).get("table")
            if table is not None:
                params += f" table=<{len(table)} entries>"
            fmt = f" : {n.qformat} {n.rounding.value} {n.overflow.value}" if n.qformat else " : ?"
            meaning = f"  # {n.meaning}" if n.meaning else ""
            lines.append(f"  {n.name} = {n.kind.value}({', '.join(n.inputs)}){params}{fmt}{meaning}")
        for port, node in self.outputs:
            lines.append(f"  output {port} = {node}")
        return "\n".join(lines) + "\n"

    def __str__(self) -> str:
        return self.text()


def name_allocator(taken):
    """A function giving ``base``, else ``base_2``, ``base_3``... : the first name not in ``taken``
    (the names of the graph a pass adds nodes to), recording each it gives."""
    used = set(taken)

    def fresh(base: str) -> str:
        name, i = base, 1
        while name in used:
            i += 1
            name = f"{base}_{i}"
        used.add(name)
        return name
    return fresh


def _fmt(v) -> str:
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, tuple):
        return "(" + ",".join(_fmt(x) for x in v) + ")"
    return str(v)
