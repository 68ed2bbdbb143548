"""The generic effect catalogue: kinds of physical effect that apply to any coordinate or input.

A plant file's ``[catalogue.NAME]`` names a ``kind`` and what it acts ``on`` (a coordinate, an
input, or a drive effect), and gives the kind's *roles* as expressions of the file's
parameters (``coefficient = "b"``, ``scale = "F_normal"``). :mod:`pendc.model.assemble` puts the
kinds into the equations in one fixed order of stages::

    input delay -> input shaping (dead zone, saturation on an input) -> drive laws
    -> drive shaping (saturation, dead zone on a drive) -> lags -> dry friction and its
    sticking rule -> other generalized forces -> velocity limits -> sensor offsets

so a model is exactly the plant plus the listed effects. The kinds, with their roles
(required first; the rest optional) and what they add:

======================  ==================================================================
drive (on: coordinate)  force [input, name]: the input's law, a generalized force
delay (on: input)       time: the plant sees the input ``time`` late
dead_zone (on: input    width [centre]: nothing within ``width`` of ``centre``, the input
or drive)               (or drive) shifted by ``width`` beyond it
saturation (on: input   limit, or low and high: the value clamped
or drive)
lag (on: drive)         time_constant [state, initial]: a first-order lag state behind the
                        drive's output
viscous                 coefficient: -c dq
coulomb                 level [scale]: moving friction -level scale sgn(dq)
static                  level [scale, stick_below]: the sticking rule: while
                        |dq| <= stick_below the coordinate sticks unless the drive exceeds
                        level scale
stribeck                coulomb, static, velocity, shape [scale, stick_below]: moving
                        friction -(C + (S - C) exp(-(|dq|/v)^shape)) scale sgn(dq) with
                        the sticking rule at S scale
asymmetric              ratio: moving friction times (1 + ratio sgn(dq))
quadratic_drag          coefficient: -c dq |dq|
spring                  stiffness [rest]: -k (q - rest)
force                   force: any generalized force, an expression of the state
velocity_limit          limit: |dq| clamped after every integration step
offset                  offset: the position's sensor reads q + offset (motion unchanged)
======================  ==================================================================
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import PendcError


@dataclass(frozen=True)
class KindSpec:
    """One kind: its roles (``required`` ones first), which are expressions (the rest are
    names), what ``on`` may name (``"coordinate"``, ``"input"``, ``"drive"``), and a line on
    each role for error messages."""

    name: str
    required: tuple
    optional: tuple
    on: tuple
    help: dict
    names: tuple = ()              # roles that are names, not expressions

    @property
    def roles(self) -> tuple:
        return self.required + self.optional

    @property
    def expressions(self) -> tuple:
        return tuple(r for r in self.roles if r not in self.names)

    def describe(self, role: str) -> str:
        return self.help.get(role, role)


def _k(name, required, optional, on, help, names=()):
    return KindSpec(name, tuple(required), tuple(optional), tuple(on), help, tuple(names))


COORD, INPUT, DRIVE = "coordinate", "input", "drive"
KINDS = {k.name: k for k in (
    _k("drive", ["force"], ["input", "name"], [COORD],
       {"force": "the generalized force the input produces, e.g. k*(u - u_0)",
        "input": "the input it reads (default: the plant's only input)",
        "name": "the name the equations bind the force to"}, names=("input", "name")),
    _k("delay", ["time"], [], [INPUT], {"time": "the transport delay in seconds"}),
    _k("dead_zone", ["width"], ["centre"], [INPUT, DRIVE],
       {"width": "half-width of the dead zone", "centre": "the value around which it lies (default 0)"}),
    _k("saturation", [], ["limit", "low", "high"], [INPUT, DRIVE],
       {"limit": "the largest magnitude", "low": "the lowest value", "high": "the highest value"}),
    _k("lag", ["time_constant"], ["state", "initial"], [DRIVE],
       {"time_constant": "the lag's time constant in seconds", "state": "the name of the lag's state",
        "initial": "its value at the start (default 0)"}, names=("state",)),
    _k("viscous", ["coefficient"], [], [COORD], {"coefficient": "c in -c dq"}),
    _k("coulomb", ["level"], ["scale"], [COORD],
       {"level": "the friction level (times scale)", "scale": "a common factor, e.g. the normal force"}),
    _k("static", ["level"], ["scale", "stick_below"], [COORD],
       {"level": "the static friction level (times scale)", "scale": "a common factor",
        "stick_below": "the speed below which the coordinate counts as stuck (default 0: an exact zero test)"}),
    _k("stribeck", ["coulomb", "static", "velocity", "shape"], ["scale", "stick_below"], [COORD],
       {"coulomb": "the Coulomb level", "static": "the static level", "velocity": "the Stribeck velocity",
        "shape": "the Stribeck form factor", "scale": "a common factor",
        "stick_below": "the speed below which the coordinate counts as stuck"}),
    _k("asymmetric", ["ratio"], [], [COORD], {"ratio": "d in (1 + d sgn(dq))"}),
    _k("quadratic_drag", ["coefficient"], [], [COORD], {"coefficient": "c in -c dq |dq|"}),
    _k("spring", ["stiffness"], ["rest"], [COORD], {"stiffness": "k in -k (q - rest)",
                                                     "rest": "the rest position (default 0)"}),
    _k("force", ["force"], [], [COORD], {"force": "the generalized force, an expression of the state"}),
    _k("velocity_limit", ["limit"], [], [COORD], {"limit": "the largest |dq|"}),
    _k("offset", ["offset"], [], [COORD], {"offset": "what the sensor reads at q = 0"}),
)}

MOVING = ("coulomb", "stribeck")       # kinds that give a coordinate's moving friction
STICKING = ("static", "stribeck")      # kinds that give its sticking rule
SHAPERS = ("dead_zone", "saturation")


def target_kind(definition, effect) -> str:
    """What ``effect.on`` names: "coordinate", "input" or "drive"."""
    if effect.on in definition.coordinate_names:
        return COORD
    if effect.on in {i.name for i in definition.inputs}:
        return INPUT
    other = definition.catalogue.get(effect.on)
    if other is not None and other.kind == "drive":
        return DRIVE
    return ""


def check_effect(definition, effect, where: str) -> None:
    """The effect's ``on`` names something its kind acts on, and its roles fit (one line if not)."""
    spec = KINDS[effect.kind]
    target = target_kind(definition, effect)
    if target not in spec.on:
        known = {COORD: definition.coordinate_names, INPUT: tuple(i.name for i in definition.inputs),
                 DRIVE: tuple(n for n, e in definition.catalogue.items() if e.kind == "drive")}
        choices = sorted({n for kind in spec.on for n in known[kind]})
        raise PendcError(f"{where}.on: '{effect.on}' is not a {' or '.join(spec.on)} of this plant "
                         f"(an effect of kind '{effect.kind}' acts on one of: {', '.join(choices) or 'nothing here'})")
    if effect.kind == "saturation":
        given = {role for role, _ in effect.roles}
        if given not in ({"limit"}, {"low", "high"}):
            raise PendcError(f"{where}: a saturation takes either limit = \"...\" or both low and high")
    if effect.kind == "drive":
        inputs = [i.name for i in definition.inputs]
        source = effect.role("input", inputs[0] if len(inputs) == 1 else None)
        if source not in inputs:
            raise PendcError(f"{where}.input: name the input the drive reads (one of: {', '.join(inputs)})")
    if definition.form == "state" and target == COORD and effect.kind != "offset":
        if definition.rate_of(effect.on) is None or not definition.coordinate(definition.rate_of(effect.on)).force:
            raise PendcError(f"{where}.on: '{effect.on}' has no rate state with a force = \"NAME\" that its "
                             f"derivative uses, so an effect of kind '{effect.kind}' cannot act on it")
    for alternatives in effect.requires:
        for name in alternatives:
            if name not in definition.catalogue:
                raise PendcError(f"{where}.requires: unknown effect '{name}'")


def driven_coordinate(definition, effect) -> str:
    """The coordinate an effect finally acts on (through a drive for drive shapers and lags;
    inputs act on every coordinate their drives drive: the first is named)."""
    target = target_kind(definition, effect)
    if target == COORD:
        return effect.on
    if target == DRIVE:
        return definition.catalogue[effect.on].on
    drives = [e.on for e in definition.catalogue.values() if e.kind == "drive"
              and e.role("input", definition.inputs[0].name) == effect.on]
    return drives[0] if drives else ""


def acts_on(definition, effect) -> str:
    """What identification can see the effect through: the moving body's name, or the
    position's name for a sensor offset."""
    if effect.kind == "offset":
        return effect.on
    coordinate = driven_coordinate(definition, effect)
    return definition.body_of(coordinate) if coordinate else effect.on


def implied_requirements(definition, effect) -> tuple:
    """What the effect needs besides its own ``requires``: the drive it shapes or lags, and
    for ``asymmetric`` a moving friction on its coordinate."""
    out = []
    if target_kind(definition, effect) == DRIVE:
        out.append((effect.on,))
    if effect.kind == "asymmetric":
        out.append(tuple(n for n, e in definition.catalogue.items() if e.kind in MOVING and e.on == effect.on))
    return tuple(out)


def conflicts_of(definition) -> tuple:
    """Pairs of catalogue effects that define the same part: two moving frictions or two
    sticking rules of one coordinate, two velocity limits or two drives of one coordinate."""
    out = []
    names = list(definition.catalogue)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            ea, eb = definition.catalogue[a], definition.catalogue[b]
            if ea.on != eb.on:
                continue
            for group, what in ((MOVING, "moving-branch friction"), (STICKING, "sticking rule"),
                                (("velocity_limit",), "velocity limit"), (("drive",), "drive"),
                                (("delay",), "input delay"), (("lag",), "lag")):
                if ea.kind in group and eb.kind in group:
                    out.append((a, b, what))
                    break
    return tuple(out)
