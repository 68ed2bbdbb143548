"""A sampled model's golden plant without a build per sample: the nominal build, retyped.

A full build (range analysis, Q-formats, the error budget) takes a minute or more per parameter
set. A sampled model has the nominal model's structure: lowering it (under a second) gives the
same datapath with other constants, gains and table functions. :class:`RetypeTemplate` keeps the
nominal build's typed graph and, per sample, puts the sampled numbers into it: every node keeps
the nominal build's Q-format and every table its domain, grid and output format; only CONST
values, GAIN constants and LUT contents change (refilled by :func:`pendc.passes.tabulate.
fill_lut_tables`). A constant the nominal constant format cannot hold gets the integer bits it
needs at the same width, as the format pass would give it. This is the core a build of the nominal
model's formats with the sample's numbers makes: its golden model is bit-exact with that Verilog,
and an intermediate the sample drives beyond the nominal ranges raises the sticky overflow, which
the run reports (a real core built for the nominal plant would overflow there too).

The two graphs are matched by node name, a constant through the nodes that read it (lowering
names a constant after its value; :func:`match_structure`). A sampled value that changes the
structure (a parameter folding to 0 or 1, an exponent of 1) is a one-line error naming the node. Imports pendc's passes, IR and HIL golden plant.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from ..errors import PendcError
from ..ir.nodes import Kind
from ..ir.qformat import QFormat

NUMERIC_KINDS = (Kind.CONST, Kind.GAIN, Kind.LUT)   # the kinds whose numbers a sample may change


def lowered(model, options):
    """``model`` lowered, folded and CSE'd as :func:`pendc.passes.pipeline.compile_model` does it."""
    from ..passes.eliminate_common import eliminate_common_subexpressions
    from ..passes.fold_constants import fold_constants
    from ..passes.lower import lower_model

    return eliminate_common_subexpressions(fold_constants(lower_model(model, dt=options.dt)))


def match_structure(nominal, sampled) -> dict:
    """{nominal node name: sampled node name} of every node whose numbers the sample sets.

    Lowering names every node by what it computes except a constant, named by its value; so the
    two graphs must have the same other names with the same kinds and the same non-numeric
    parameters (else a :class:`PendcError` names the first that differs), and a constant is found
    through the nodes that read it: the k-th constant input of a node is the twin of the k-th
    constant input of the same-named node. (The order in which a sum's terms are accumulated may
    differ; the nominal core's order is kept, as a core whose constants are reloaded keeps it.)"""
    named_a = {n.name: n for n in nominal.nodes if n.kind is not Kind.CONST}
    named_b = {n.name: n for n in sampled.nodes if n.kind is not Kind.CONST}
    for name, na in named_a.items():
        nb = named_b.get(name)
        if nb is None or nb.kind is not na.kind:
            raise PendcError(f"the sampled values change the core's structure at node '{name}' (a parameter folds "
                             f"differently, e.g. to 0 or 1); the golden plant needs a build of its own: use --plant float")
        if na.kind not in NUMERIC_KINDS and na.params != nb.params:
            raise PendcError(f"the sampled values change the {na.kind.value} node '{name}', which the nominal build "
                             f"fixes; the golden plant needs a build of its own: use --plant float")
    extra = sorted(set(named_b) - set(named_a))
    if extra:
        raise PendcError(f"the sampled values add node '{extra[0]}' to the core; the golden plant needs a build of "
                         f"its own: use --plant float")
    pairs = {name: name for name, na in named_a.items() if na.kind in NUMERIC_KINDS}
    for name, na in named_a.items():
        consts_a = [i for i in na.inputs if nominal[i].kind is Kind.CONST]
        consts_b = [i for i in named_b[name].inputs if sampled[i].kind is Kind.CONST]
        if len(consts_a) != len(consts_b):
            raise PendcError(f"the sampled values change which constants node '{name}' reads; the golden plant needs "
                             f"a build of its own: use --plant float")
        for a, b in zip(consts_a, consts_b):
            if pairs.setdefault(a, b) != b and sampled[pairs[a]].params.value != sampled[b].params.value:
                raise PendcError(f"the sampled values split the shared constant '{a}' into two; the golden plant "
                                 f"needs a build of its own: use --plant float")
    return pairs


def fitting_format(value: float, fmt: QFormat) -> QFormat:
    """``fmt``, or the same width with fewer fraction bits when ``value`` does not fit it."""
    if fmt.min_value <= value <= fmt.max_value:
        return fmt
    need = math.frexp(abs(value))[1] + (1 if fmt.signed else 0)      # integer bits, sign included
    return QFormat(fmt.signed, fmt.width, fmt.width - need)


@dataclass(frozen=True)
class RetypeTemplate:
    """The nominal build and its untyped graph: what every sample's core is made from."""

    build: object

    @classmethod
    def of(cls, model) -> "RetypeTemplate":
        """The template of ``model``'s build (compiled once, then read from the build cache)."""
        from ..passes.pipeline import core_step
        from ..hil.plants.golden_plant import build_for

        build = build_for(model, core_step(model))
        if build.options.short_chain:
            raise PendcError("--plant golden sweeps retype the default arithmetic; this model's [hardware] asks "
                             "for the short chain (short_chain = true)")
        return cls(build)

    def graph_for(self, sampled_model):
        """The nominal typed graph with ``sampled_model``'s constants, gains and tables."""
        from ..ir.verify import verify
        from ..passes.tabulate import fill_lut_tables

        sampled = lowered(sampled_model, self.build.options)
        pairs = match_structure(self.build.untyped, sampled)
        nodes = []
        for node in self.build.graph.nodes:
            twin = sampled.by_name.get(pairs.get(node.name, ""))
            if twin is None or node.kind not in NUMERIC_KINDS:
                nodes.append(node)
            elif node.kind is Kind.CONST:
                nodes.append(replace(node, params=replace(node.params, value=twin.params.value),
                                     qformat=fitting_format(twin.params.value, node.qformat)))
            elif node.kind is Kind.GAIN:
                nodes.append(node.with_params(value=twin.params.value,
                                              cfmt=fitting_format(twin.params.value, node.params.cfmt)))
            else:
                nodes.append(node.with_params(expr=twin.params.expr, table=None))
        graph = fill_lut_tables(replace(self.build.graph, nodes=tuple(nodes)))
        verify(graph, typed=True)
        return graph

    def plant(self, params: dict, shared: bool = True, **options):
        """The golden plant of the nominal model with ``params``: stepped by the kernel every
        sample shares (the nodes a sample changes read their numbers from data: see
        :mod:`pendc.ir.shared_source`; the integers are the baked kernel's), or with
        ``shared=False`` by the baked kernel (compiled per sample)."""
        from ..hil.plants.golden_plant import GoldenPlant

        model = self.build.model.with_params(params)
        build = replace(self.build, model=model, graph=self.graph_for(model))
        like = self.build.graph if shared else None
        return GoldenPlant(model, dt=build.options.dt, build=build, like=like, **options)
