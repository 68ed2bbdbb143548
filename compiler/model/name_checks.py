"""The names a plant file's expressions use: each one declared, intermediates in order.

:mod:`pendc.model.plantfile` reads the tables; :func:`check_names` then walks every expression
of the definition and fails with one line on the first name the file does not declare, and on
an intermediate that uses itself (an algebraic loop, named as its cycle) or a later one.
"""

from __future__ import annotations

from ..errors import PendcError
from .definition import PlantDefinition
from .effect_kinds import KINDS
from .expressions import free_names


def _check_intermediate_order(d: PlantDefinition, source: str) -> None:
    """Intermediates are evaluated in file order: one that uses itself or a later one is either an
    algebraic loop (named as its cycle) or out of order (one line saying which to move)."""
    order = [n for n, *_ in d.intermediates]
    uses = {n: free_names(text, f"{source}: intermediates.{n}") & set(order) for n, text, *_ in d.intermediates}
    for i, name in enumerate(order):
        ahead = sorted(uses[name] - set(order[:i]), key=order.index)
        if not ahead:
            continue
        path = _cycle_from(name, uses)
        if path:
            raise PendcError(f"{source}: intermediates.{name}: algebraic loop {' -> '.join(path)} (an intermediate "
                             "cannot depend on itself; solve the loop by hand or make one of them a state)")
        raise PendcError(f"{source}: intermediates.{name}: uses '{ahead[0]}' before it is defined (intermediates "
                         f"are evaluated in file order: move '{ahead[0]}' above '{name}')")


def _cycle_from(start: str, uses: dict) -> list:
    """A path start -> ... -> start through ``uses``, or [] (depth-first)."""
    stack, seen = [(start, [start])], set()
    while stack:
        node, path = stack.pop()
        for nxt in sorted(uses[node]):
            if nxt == start:
                return path + [start]
            if nxt not in seen:
                seen.add(nxt)
                stack.append((nxt, path + [nxt]))
    return []


def _check_unique(d: PlantDefinition, source: str) -> None:
    """A name means one thing: a constant, input, intermediate, coordinate (and its rate), state,
    generalized force or effect parameter declared twice under different roles is one line
    naming both places (an effect's Coulomb level named like the coordinate's force made the
    force's equation refer to itself). Effects may share a parameter (one name, one value), and
    coordinates or states a generalized force."""
    seen = {}

    def declare(name, where, shared=None):
        if not name:
            return
        first = seen.get(name)
        if first is None:
            seen[name] = (where, shared)
        elif shared is None or shared != first[1]:
            raise PendcError(f"{source}: {where}: the name {name} is already {first[0]}")

    for n in d.constants:
        declare(n, f"constants.{n}")
    for i in d.inputs:
        declare(i.name, f"inputs.{i.name}")
    for n, *_ in d.intermediates:
        declare(n, f"intermediates.{n}")
    for c in d.coordinates:
        declare(c.name, f"coordinates.{c.name}")
        declare(f"d{c.name}", f"coordinates.{c.name} (its rate)")
        declare(c.force, f"coordinates.{c.name}.force", shared="force")
    for s in d.states:
        declare(s.name, f"states.{s.name}")
        declare(s.force, f"states.{s.name}.force", shared="force")
    for e in d.catalogue.values():
        for p in e.params:
            declare(p.name, f"catalogue.{e.name}.params.{p.name}", shared="parameter")
    for e in d.catalogue.values():          # what an effect defines: a drive's force, a lag's state
        for role, text in e.roles:
            if role in ("name", "state"):
                declare(text, f"catalogue.{e.name}.{role}")


def check_names(d: PlantDefinition, source: str) -> None:
    """Every expression uses only names the file declares (one line naming the first stray), and
    each name is declared once (:func:`_check_unique`)."""
    _check_unique(d, source)
    known = set(d.constants) | {i.name for i in d.inputs} | {n for n, *_ in d.intermediates}
    for c in d.coordinates:
        known |= {c.name, f"d{c.name}", c.force}
    for s in d.states:
        known.add(s.name)
        if s.force:
            known.add(s.force)
    for e in d.catalogue.values():
        known |= {p.name for p in e.params}
        for role, text in e.roles:
            if role == "name" or role == "state":
                known.add(text)
    known |= {"t", "pi"}

    def check(text, where):
        for n in sorted(free_names(text, where)):
            if n not in known:
                raise PendcError(f"{where}: unknown symbol '{n}' (declare it in [constants], [intermediates], "
                                 f"an effect's params or as a coordinate, state or input)")

    _check_intermediate_order(d, source)
    for name, text, _, _ in d.intermediates:
        check(text, f"{source}: intermediates.{name}")
    for s in d.states:
        check(s.derivative, f"{source}: states.{s.name}.derivative")
        check(s.initial, f"{source}: states.{s.name}.initial")
    for b in d.bodies:
        for key in ("mass", "inertia", "rotation"):
            if getattr(b, key):
                check(getattr(b, key), f"{source}: bodies.{b.name}.{key}")
        for key in ("position", "start", "end"):
            for i, text in enumerate(getattr(b, key)):
                check(text, f"{source}: bodies.{b.name}.{key}[{i}]")
    for i, text in enumerate(d.gravity):
        check(text, f"{source}: mechanics.gravity[{i}]")
    for key in ("kinetic", "potential"):
        if getattr(d, key):
            check(getattr(d, key), f"{source}: mechanics.{key}")
    for e in d.catalogue.values():
        for role, text in e.roles:
            if role in KINDS[e.kind].expressions:
                check(text, f"{source}: catalogue.{e.name}.{role}")
    for name, pairs in d.operating_points.items():
        for k, text in pairs:
            check(text, f"{source}: operating_points.{name}.{k}")
    for name, vector in (d.drawing or {}).get("points", {}).items():   # checked here, not first by animate
        for i, text in enumerate(vector):
            check(str(text), f"{source}: drawing.points.{name}[{i}]")
