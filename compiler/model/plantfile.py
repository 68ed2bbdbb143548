"""Read the physics tables of a plant file into a :class:`~pendc.model.definition.PlantDefinition`.

A plant file is TOML (``docs/plant_files.md`` is its reference). This module reads the tables
that describe the physics: ``[plant]`` (name, core, summary), ``[constants]``,
``[coordinates]`` and ``[bodies]`` with ``[mechanics]`` (mechanical form) or ``[states]``
(state-equation form), ``[inputs]``, ``[intermediates]``, ``[quantities]``, ``[sensors]``,
``[catalogue]``, ``[experiments]``, ``[identification]``, ``[operating_points]`` and
``[drawing]``. Values (``[plant]`` numbers, ``[effects]``) are :mod:`pendc.model.modelfile`'s.

Every mistake is a one-line :class:`~pendc.errors.PendcError` naming the file and the key.
Expressions are only checked for the names they use here (:mod:`pendc.model.expressions`
parses them without executing anything); :mod:`pendc.model.assemble` builds them.
"""

from __future__ import annotations

import json
from dataclasses import replace

from .definition import (BodyDecl, CoordinateDecl, EffectDecl, ExperimentDecl, InputDecl,
                         PlantDefinition, SensorDecl, StateDecl)
from .effect_kinds import KINDS, acts_on, check_effect, implied_requirements
from .equations import DEFAULT_EXPERIMENT
from .sensors import ADC, ENCODER, MAX_ADC_BITS
from .identification_table import read_constraints, read_identification_notes
from .name_checks import check_names
from .reference_formats import read_reference_formats
from .table_reader import TableReader, check_identifier, read_param, read_period, read_vector

PHYSICS = ("constants", "coordinates", "states", "mechanics", "bodies", "inputs", "intermediates", "quantities",
           "sensors", "catalogue", "experiments", "identification", "operating_points", "drawing", "reference_formats")
PLANT_META = ("name", "core", "summary", "source")


def read_definition(doc: dict, source: str) -> PlantDefinition:
    """The :class:`PlantDefinition` of a plant file's parsed TOML ``doc`` (``source`` names the
    file in errors). Raises :class:`PendcError` with one line on any mistake."""
    top = TableReader(source, "", doc)
    plant = top.sub("plant", required=True)
    name = plant.string("name", required=True)
    check_identifier(plant, name, "plant")
    core = plant.string("core", f"{name}_core")
    check_identifier(plant, core, "core", hdl=True)
    summary = plant.string("summary", name)

    constants = {}
    creader = top.sub("constants")
    if creader is not None:
        for cname in creader.table:
            constants[cname] = read_param(creader, cname, positive_default=True)
    inputs = _inputs(top)
    mech = "coordinates" in doc
    if mech == ("states" in doc):
        top.fail("declare the dynamics either as [coordinates] with [bodies] (mechanical) or as [states] "
                 "(state equations), exactly one of the two")
    coordinates = _coordinates(top) if mech else ()
    states = () if mech else _states(top)
    bodies, gravity, kinetic, potential, determinant = _mechanics(top) if mech else ((), (), "", "", "det")
    intermediates = _intermediates(top)
    quantities = _quantities(top)
    catalogue = _catalogue(top)
    position_names = [c.name for c in coordinates] + [s.name for s in states]
    rates = [f"d{c.name}" for c in coordinates]
    sensors = _sensors(top, position_names + [s.name for s in states], rates)
    experiments = _experiments(top, position_names, [b.name for b in bodies])
    notes = replace(read_identification_notes(top, catalogue), constraints=read_constraints(top, catalogue, constants))
    nodes = set(position_names) | set(rates) | {f"dd{c.name}" for c in coordinates} | {n for n, *_ in intermediates} \
        | {q[0] for q in quantities or ()}
    reference, reference_source = read_reference_formats(top, nodes)
    physics = {k: doc[k] for k in PHYSICS if k in doc} | {
        "plant": {k: v for k, v in doc["plant"].items() if k in PLANT_META}}
    definition = PlantDefinition(
        name=name, core=core, summary=summary, form="mechanical" if mech else "state", constants=constants,
        inputs=inputs, coordinates=coordinates, states=states, bodies=bodies, gravity=gravity, kinetic=kinetic,
        potential=potential, determinant=determinant, intermediates=intermediates, quantities=quantities,
        catalogue=catalogue, experiments=experiments, sensors=sensors, notes=notes,
        operating_points=_operating_points(top, position_names + rates), drawing=_drawing(top),
        source=plant.string("source", ""), reference_formats=reference, reference_source=reference_source,
        key=json.dumps(physics, sort_keys=True, default=repr), physics=physics)
    check_names(definition, source)
    for effect in catalogue.values():
        check_effect(definition, effect, f"{source}: catalogue.{effect.name}")
    seen = {n: replace(e, acts_on=acts_on(definition, e), requires=e.requires + implied_requirements(definition, e))
            for n, e in catalogue.items()}
    return replace(definition, catalogue=seen)


def _inputs(top: TableReader) -> tuple:
    r = top.sub("inputs", required=True)
    if not r.table:
        r.fail("declares no input")
    out = []
    for name in r.table:
        check_identifier(r, name, "input", hdl=True)
        i = r.sub(name)
        i.only(("unit", "meaning", "range", "neutral"))
        lo, hi = i.pair("range", required=True)
        neutral = i.number("neutral")
        if neutral is not None and not lo <= neutral <= hi:
            i.fail(f"neutral {neutral:g} lies outside the range [{lo:g}, {hi:g}]", "neutral")
        out.append(InputDecl(name, i.string("unit", required=True), i.string("meaning", required=True), lo, hi,
                             neutral))
    if len(out) > 1:
        # one input port carries the core's step; a second actuator is the next plant format's
        r.fail(f"declares {len(out)} inputs ({', '.join(d.name for d in out)}); a plant has one input, the core's "
               f"input port: keep the one a controller drives and make the others [constants] it holds")
    return tuple(out)


_POSITION_KEYS = ("unit", "meaning", "body", "quantity", "force", "force_unit", "friction", "period", "turns",
                  "budget", "rate", "range")


def _entries(top: TableReader, key: str, what: str):
    """``(name, reader)`` of each entry of table ``key`` (at least one, each a valid name)."""
    r = top.sub(key)
    if not r.table:
        r.fail(f"declares no {what}")
    for name in r.table:
        check_identifier(r, name, what, hdl=True)
        yield name, r.sub(name)


def _position(e: TableReader, name: str, body: str, quantity: str, force: str) -> dict:
    """The fields every position declares (:class:`PositionDecl`), with these defaults."""
    return dict(name=name, unit=e.string("unit", required=True), meaning=e.string("meaning", required=True),
                body=e.string("body", body), quantity=e.string("quantity", quantity),
                force=e.string("force", force), friction=e.string("friction", ""), period=read_period(e),
                turns=e.integer("turns"), budget=e.number("budget", positive=True), working_range=e.pair("range"))


def _coordinates(top: TableReader) -> tuple:
    out = []
    for name, c in _entries(top, "coordinates", "coordinate"):
        c.only(_POSITION_KEYS)
        rate = c.sub("rate") or TableReader(c.source, c.path + ".rate", {})
        rate.only(("unit", "meaning", "quantity", "training_rate"))
        fields = _position(c, name, name, "position", f"Q_{name}")
        out.append(CoordinateDecl(
            **fields, training_rate=rate.number("training_rate", positive=True),
            rate_unit=rate.string("unit", f"{fields['unit']}/s"), rate_meaning=rate.string("meaning", f"rate of {name}"),
            rate_quantity=rate.string("quantity", "rate"), force_unit=c.string("force_unit", "")))
    return tuple(out)


def _states(top: TableReader) -> tuple:
    r = top.sub("states")
    out = []
    for name, s in _entries(top, "states", "state"):
        s.only(("unit", "meaning", "derivative", "initial", "body", "quantity", "rate_of", "force", "friction",
                "period", "turns", "budget", "training_rate", "output", "range"))
        output = s.table.get("output", True)
        if not isinstance(output, bool):
            s.fail("must be true or false", "output")
        fields = _position(s, name, "", "", "")
        fields["period"] = None if fields["period"] == "none" else fields["period"]
        if "training_rate" in s.table and not s.table.get("rate_of"):
            s.fail("is for a rate state (one with rate_of); where a position works is its range = [low, high]",
                   "training_rate")
        out.append(StateDecl(
            **fields, training_rate=s.number("training_rate", positive=True),
            derivative=s.text("derivative", required=True), initial=s.text("initial", "0"),
            rate_of=s.string("rate_of", ""), output=output))
    names = [s.name for s in out]
    for s in out:
        if s.rate_of and s.rate_of not in names:
            r.fail(f"rate_of names unknown state '{s.rate_of}'", f"{s.name}.rate_of")
    return tuple(out)


def _mechanics(top: TableReader):
    m = top.sub("mechanics") or TableReader(top.source, "mechanics", {})
    m.only(("gravity", "kinetic", "potential", "determinant"))
    gravity = read_vector(m, "gravity")
    kinetic, potential = m.text("kinetic", ""), m.text("potential", "")
    determinant = m.string("determinant", "det")
    r = top.sub("bodies")
    bodies = []
    if r is not None:
        for name in r.table:
            check_identifier(r, name, "body")
            b = r.sub(name)
            kind = b.string("kind", "point")
            if kind == "point":
                b.only(("kind", "mass", "inertia", "rotation", "position"))
                body = BodyDecl(name, kind, mass=b.text("mass", ""), inertia=b.text("inertia", ""),
                                rotation=b.text("rotation", ""), position=read_vector(b, "position"))
                if not body.mass and not body.inertia:
                    b.fail("has neither a mass nor an inertia, so it adds nothing to the motion: give it mass = "
                           "\"...\" (with a position) and/or inertia = \"...\" (with a rotation), or remove it")
                if body.inertia and not body.rotation:
                    b.fail("an inertia needs the angle it turns with: rotation = \"...\"", "rotation")
                if body.mass and not body.position:
                    b.fail("a mass needs its position: position = [x, y] or [x, y, z]", "position")
            elif kind == "rod":
                b.only(("kind", "mass", "start", "end"))
                body = BodyDecl(name, kind, mass=b.text("mass", required=True), start=read_vector(b, "start", True),
                                end=read_vector(b, "end", True))
            else:
                b.fail(f"unknown body kind '{kind}' (known: point, rod)", "kind")
            bodies.append(body)
    if not bodies and not kinetic:
        top.fail("a mechanical plant needs [bodies] or [mechanics] kinetic = \"...\" (its kinetic energy)")
    if bodies and (kinetic or potential):
        m.fail("give either [bodies] or the energies kinetic/potential, not both")
    if gravity and not bodies:
        m.fail("acts on [bodies]; with the energies given, write gravity's part into potential", "gravity")
    dims = {len(v) for b in bodies for v in (b.position, b.start, b.end) if v}
    if len(dims) > 1 or (gravity and dims and len(gravity) not in dims):
        sizes = ", ".join(f"bodies.{b.name} {len(v)}-D" for b in bodies for v in (b.position or b.start,) if v)
        given = f"gravity is {len(gravity)}-D; " if gravity else ""
        m.fail(f"bodies and gravity must be all 2-D or all 3-D vectors ({given}{sizes})", "gravity")
    if bodies and any(b.mass for b in bodies) and not gravity:
        m.fail("is missing: gravity = [0, \"-g\"] (or [0, 0, 0] for none)", "gravity")
    return tuple(bodies), gravity, kinetic, potential, determinant


def _intermediates(top: TableReader) -> tuple:
    r = top.sub("intermediates")
    if r is None:
        return ()
    out = []
    for name in r.table:
        check_identifier(r, name, "intermediate")
        v = r.table[name]
        if isinstance(v, dict):
            i = r.sub(name)
            i.only(("value", "unit", "meaning"))
            out.append((name, i.text("value", required=True), i.string("unit", ""), i.string("meaning", "")))
        else:
            out.append((name, r.text(name), "", ""))
    return tuple(out)


def _quantities(top: TableReader):
    r = top.sub("quantities")
    if r is None:
        return None
    out = []
    for name in r.table:
        q = r.sub(name)
        q.only(("unit", "meaning"))
        out.append((name, q.string("unit", required=True), q.string("meaning", required=True)))
    return tuple(out)


def _catalogue(top: TableReader) -> dict:
    r = top.sub("catalogue")
    out = {}
    if r is None:
        return out
    for name in r.table:
        check_identifier(r, name, "effect")
        e = r.sub(name)
        kind = e.string("kind", required=True)
        if kind not in KINDS:
            e.fail(f"unknown effect kind '{kind}' (known: {', '.join(KINDS)})", "kind")
        spec = KINDS[kind]
        e.only(("kind", "on", "summary", "params", "evidence", "separated_by", "requires", "doc") + spec.roles)
        params = ()
        preader = e.sub("params")
        if preader is not None:
            params = tuple(read_param(preader, p, positive_default=False) for p in preader.table)
        roles = tuple((role, e.text(role)) for role in spec.roles if role in e.table)
        for role in spec.required:
            if role not in e.table:
                e.fail(f"an effect of kind '{kind}' needs {role} = \"...\" ({spec.describe(role)})", role)
        requires = e.table.get("requires", [])
        if not isinstance(requires, list) or not all(
                isinstance(a, str) or (isinstance(a, list) and all(isinstance(x, str) for x in a)) for a in requires):
            e.fail("must be a list of effect names (or of lists of alternatives)", "requires")
        out[name] = EffectDecl(
            name=name, kind=kind, on=e.string("on", required=True), summary=e.string("summary", kind),
            params=params, roles=roles, requires=tuple((a,) if isinstance(a, str) else tuple(a) for a in requires),
            evidence=e.string("evidence", ""), separated_by=e.string("separated_by", ""), doc=e.string("doc", ""))
    return out


# the keys of a sensor of each kind (the default kind is the quadrature encoder)
SENSOR_KEYS = {ENCODER: ("kind", "state", "band", "lines", "bands_per_rev"), ADC: ("kind", "state", "bits", "range")}


def _sensors(top: TableReader, states, rates=()) -> tuple:
    """``[sensors.NAME]``: encoders read positions (``states``), converters any state
    (``states`` or ``rates``)."""
    states, rates = list(states), [r for r in rates if r not in states]
    r = top.sub("sensors")
    out = []
    if r is None:
        return ()
    for name in r.table:
        check_identifier(r, name, "sensor", hdl=True)
        s = r.sub(name)
        kind = s.string("kind", ENCODER)
        if kind not in SENSOR_KEYS:
            s.fail(f"unknown sensor kind '{kind}' (known: {', '.join(SENSOR_KEYS)})", "kind")
        s.only(SENSOR_KEYS[kind])
        state = s.string("state", required=True)
        if kind == ADC:
            if state not in states + rates:
                s.fail(f"names unknown state '{state}' (known: {', '.join(dict.fromkeys(states + rates))})", "state")
            bits = s.integer("bits", required=True)
            if bits > MAX_ADC_BITS:
                s.fail(f"must be at most {MAX_ADC_BITS}, got {bits}", "bits")
            lo, hi = s.pair("range", required=True)
            out.append(SensorDecl(name, state, kind, bits=bits, lo=lo, hi=hi))
            continue
        if state not in states:
            s.fail(f"names unknown position '{state}' (known: {', '.join(states)})", "state")
        out.append(SensorDecl(name, state, kind, s.number("band", required=True, positive=True),
                              s.integer("lines", required=True), s.integer("bands_per_rev", required=True)))
    seen = {}
    for s in out:
        if s.state in seen:
            r.fail(f"{seen[s.state]} and {s.name} both read '{s.state}' (one sensor a state)")
        seen[s.state] = s.name
    return tuple(out)


def _experiments(top: TableReader, positions, bodies) -> dict:
    r = top.sub("experiments") or TableReader(top.source, "experiments", {})
    out = {DEFAULT_EXPERIMENT: ExperimentDecl(DEFAULT_EXPERIMENT, "everything moves: the full model")}
    for name in r.table:
        check_identifier(r, name, "experiment")
        e = r.sub(name)
        e.only(("meaning", "held", "removed", "measured"))
        held, removed, measured = e.names("held"), e.names("removed"), e.names("measured")
        for h in (*held, *measured):
            if h not in positions:
                e.fail(f"names unknown coordinate '{h}' (known: {', '.join(positions)})")
        for b in removed:
            if b not in bodies:
                e.fail(f"names unknown body '{b}' (known: {', '.join(bodies)})", "removed")
        if name == DEFAULT_EXPERIMENT and (held or removed):
            e.fail("the free experiment holds and removes nothing")
        out[name] = ExperimentDecl(name, e.string("meaning", required=True), held, removed, measured)
    return out


def _operating_points(top: TableReader, names) -> dict:
    r = top.sub("operating_points")
    out = {}
    if r is None:
        return out
    for name in r.table:
        o = r.sub(name)
        for k in o.table:
            if k not in names:
                o.fail(f"names unknown state '{k}' (known: {', '.join(names)})", k)
        out[name] = tuple((k, o.text(k)) for k in o.table)
    return out


def _drawing(top: TableReader) -> dict:
    r = top.sub("drawing")
    if r is None:
        return {}
    r.only(("points", "lines"))
    points = r.sub("points", required=True)
    pts = {}
    for name in points.table:
        pts[name] = read_vector(points, name, True)
    lines = r.table.get("lines", [])
    if not isinstance(lines, list) or not all(isinstance(line, list) and len(line) == 2 for line in lines):
        r.fail("must be a list of [point, point] pairs naming drawing points", "lines")
    for line in lines:
        stray = next((p for p in line if p not in pts), None)
        if stray is not None:
            r.fail(f"{line!r} names unknown point {stray!r} (points: {', '.join(pts)})", "lines")
    return {"points": pts, "lines": tuple(tuple(line) for line in lines)}
