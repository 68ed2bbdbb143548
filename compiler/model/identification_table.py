"""Read a plant file's ``[identification]`` table: effect pairs and how they are separated,
hints for the diagnosis, and orderings a fit keeps (``constraints``).

Part of reading a plant file (:mod:`pendc.model.plantfile`); every mistake is a one-line
:class:`~pendc.errors.PendcError` naming the file and the key.
"""

from __future__ import annotations

from .definition import IdentificationNotes
from .table_reader import TableReader


def read_identification_notes(top: TableReader, catalogue: dict) -> IdentificationNotes:
    r = top.sub("identification") or TableReader(top.source, "identification", {})
    r.only(("pairs", "hints", "constraints"))
    pairs = {}
    for i, item in enumerate(r.table.get("pairs", [])):
        p = TableReader(r.source, f"identification.pairs[{i}]", item)
        p.only(("effects", "separated_by"))
        names = p.names("effects")
        if len(names) != 2 or any(n not in catalogue for n in names):
            p.fail("effects must name two effects of the catalogue", "effects")
        pairs[frozenset(names)] = p.string("separated_by", required=True)
    hints = []
    for i, item in enumerate(r.table.get("hints", [])):
        h = TableReader(r.source, f"identification.hints[{i}]", item)
        h.only(("body", "signal", "free", "reason", "also"))
        signal = h.string("signal", required=True)
        if signal not in ("angle", "rate", "input"):
            h.fail(f"must be angle, rate or input, got '{signal}'", "signal")
        hints.append((h.string("body", required=True), signal, ",".join(h.names("free")),
                      h.string("reason", required=True), ",".join(h.names("also"))))
    evidence = {n: e.evidence for n, e in catalogue.items() if e.evidence}
    separated = {n: e.separated_by for n, e in catalogue.items() if e.separated_by}
    return IdentificationNotes(evidence, separated, pairs, tuple(hints))


def read_constraints(top: TableReader, catalogue: dict, constants: dict) -> tuple:
    """``[identification] constraints = [{ parameter, at_least, reason }]``: orderings a fit
    keeps, as ``((parameter, at_least, reason), ...)``. Both names are parameters of the file
    (constants or catalogue params); a parameter has at most one lower one, and the orderings
    form no loop."""
    r = top.sub("identification") or TableReader(top.source, "identification", {})
    items = r.table.get("constraints", [])
    if not isinstance(items, list):
        r.fail("must be a list of { parameter, at_least, reason } tables", "constraints")
    known = set(constants) | {p.name for e in catalogue.values() for p in e.params}
    out, below = [], {}
    for i, item in enumerate(items):
        c = TableReader(r.source, f"identification.constraints[{i}]", item if isinstance(item, dict) else {})
        if not isinstance(item, dict):
            c.fail("must be a table { parameter, at_least, reason }")
        c.only(("parameter", "at_least", "reason"))
        upper, lower = c.string("parameter", required=True), c.string("at_least", required=True)
        for key, name in (("parameter", upper), ("at_least", lower)):
            if name not in known:
                c.fail(f"names unknown parameter '{name}' (a constant or a catalogue effect's parameter)", key)
        if upper == lower or upper in below:
            c.fail(f"'{upper}' already has a lower bound or is bounded by itself", "parameter")
        below[upper] = lower
        seen, step = {upper}, lower
        while step in below:
            if below[step] in seen:
                c.fail(f"the constraints on '{upper}' form a loop", "at_least")
            seen.add(step)
            step = below[step]
        out.append((upper, lower, c.string("reason", "")))
    return tuple(out)
