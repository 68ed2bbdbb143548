"""A plant's definition: what its plant file declares, parsed and checked, as frozen values.

:mod:`pendc.model.plantfile` reads the physics tables of a plant file into a
:class:`PlantDefinition`; :mod:`pendc.model.assemble` turns a definition and a set of
parameter values into the state equations and the plant interface. Nothing here is
specific to one plant: the SCT cart-pendulum and the QUBE's Furuta pendulum are two files
in ``models/``, not two code paths. ``docs/plant_files.md`` is the reference of the format.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property


@dataclass(frozen=True)
class Param:
    """One parameter: SI unit, default (a fit's starting value) and physical bounds ``lo`` ..
    ``hi``, ends included. ``optional`` parameters may be left out of a file's values (the
    default holds). ``positive``: a constant declared without bounds, whose value must be above
    ``lo`` = 0 (a file allows 0 by declaring bounds that hold it)."""

    name: str
    unit: str
    default: float
    lo: float
    hi: float
    description: str
    optional: bool = False
    positive: bool = False


@dataclass(frozen=True)
class EffectDecl:
    """One entry of a plant's effect catalogue.

    ``kind`` names a generic kind of :mod:`pendc.model.effect_kinds` (viscous, coulomb,
    stribeck, spring, drive, saturation, ...); ``on`` the coordinate, input or effect it acts
    on; ``roles`` the kind's expressions as written in the file (role -> text); ``params`` the
    parameters it brings. ``acts_on`` says what identification can see it through: the moving
    body's name, or a position's name for a sensor-only effect. ``requires`` lists sets of
    alternatives of which one must be in the model; ``evidence`` and ``separated_by`` are what
    identification says of it (what it adds to the residual; which experiment shows it alone)."""

    name: str
    kind: str
    on: str
    summary: str
    params: tuple
    roles: tuple = ()              # ((role, text), ...), file order
    acts_on: str = ""
    requires: tuple = ()
    evidence: str = ""
    separated_by: str = ""
    doc: str = ""

    def role(self, name: str, default=None):
        """The text of role ``name`` (``default`` when the file leaves it out)."""
        return dict(self.roles).get(name, default)


@dataclass(frozen=True)
class PositionDecl:
    """What a coordinate (mechanical form) and a state (state-equation form) both declare:
    words for reports, the name of the generalized force effects add to (``force``) and of its
    dry friction when bound on its own (``friction``), and how the hardware holds it: ``period``
    (declared; a mechanism's is read off its geometry), ``turns`` (whole periods either way a
    periodic register holds), ``budget`` (the error budget; default half a count of its
    sensor), ``training_rate`` (a rate range analysis also starts from), ``working_range`` (the
    file's ``range``: where the state works, range analysis also starting there)."""

    name: str
    unit: str
    meaning: str
    body: str = ""
    quantity: str = ""
    force: str = ""
    friction: str = ""
    period: object = None          # a number, "none", or None (mechanical: read off the geometry)
    turns: int | None = None
    budget: float | None = None
    training_rate: float | None = None
    working_range: tuple | None = None


@dataclass(frozen=True)
class CoordinateDecl(PositionDecl):
    """A generalized coordinate ``name`` of a mechanism: it gets a rate ``d<name>`` (described by
    the ``rate_*`` fields) and an acceleration ``dd<name>``; ``force_unit`` is its generalized
    force's."""

    rate_unit: str = ""
    rate_meaning: str = ""
    rate_quantity: str = ""
    force_unit: str = ""


@dataclass(frozen=True)
class StateDecl(PositionDecl):
    """A state of a state-equation plant: its ``derivative`` (expression text) and ``initial``
    value. ``rate_of`` marks a state that is the rate of another (its derivative then takes the
    position's generalized force ``force``, which effects add to); ``output`` whether the
    hardware reports it every step."""

    derivative: str = ""
    initial: str = "0"
    rate_of: str = ""
    output: bool = True


@dataclass(frozen=True)
class BodyDecl:
    """A body of a mechanism: ``kind`` "point" (mass at ``position``, plus ``inertia`` about it
    turning with ``rotation``) or "rod" (a uniform thin rod of ``mass`` from ``start`` to
    ``end``). Expressions are texts; vectors have 2 or 3 components (the last one up)."""

    name: str
    kind: str
    mass: str = ""
    inertia: str = ""
    rotation: str = ""
    position: tuple = ()
    start: tuple = ()
    end: tuple = ()


@dataclass(frozen=True)
class InputDecl:
    """An input port: unit, meaning, the range its actuator takes and where it is idle
    (``neutral``: None for the default, see :class:`~pendc.model.interface.InputSpec`)."""

    name: str
    unit: str
    meaning: str
    lo: float
    hi: float
    neutral: float | None = None


@dataclass(frozen=True)
class SensorDecl:
    """A sensor reading a state. A quadrature encoder (``kind`` ``"quadrature_encoder"``):
    ``band`` is the motion of one light or dark band, ``lines`` and ``bands_per_rev`` the
    disk's. A sampled converter (``kind`` ``"adc"``): ``bits`` and the range ``lo`` .. ``hi``
    it spans (see :class:`~pendc.model.sensors.SensorSpec`)."""

    name: str
    state: str
    kind: str
    band: float = 0.0
    lines: int = 0
    bands_per_rev: int = 0
    bits: int = 0
    lo: float = 0.0
    hi: float = 0.0

    @property
    def budget(self) -> float:
        """The default error budget of the state it reads: half a count (an encoder's ×4 count
        is half a band), half an LSB (a converter)."""
        if self.kind == "adc":
            return (self.hi - self.lo) / (1 << self.bits) / 2
        return self.band / 4

    def spec(self, body: str):
        """The plant interface's :class:`~pendc.model.sensors.SensorSpec` of this sensor."""
        from .sensors import SensorSpec
        return SensorSpec(self.name, self.state, body, self.band, self.lines, self.bands_per_rev, self.kind,
                          self.bits, self.lo, self.hi)


@dataclass(frozen=True)
class ExperimentDecl:
    """What an experiment held (coordinates that do not move) or removed (bodies taken off),
    and which positions it measures (empty: every sensed position that moves)."""

    name: str
    meaning: str
    held: tuple = ()
    removed: tuple = ()
    measured: tuple = ()


@dataclass(frozen=True)
class IdentificationNotes:
    """A plant's identification texts.

    ``evidence``: effect -> what it adds to the residual, in words. ``separated_by``: effect ->
    the experiment that shows it on its own. ``pair_separated_by``: frozenset of two effects ->
    what separates that pair when their own experiments would not. ``parameter_hints``:
    ``(body, signal kind, parameters, reason, also)``: when the unexplained acceleration of
    ``body`` follows a signal of that kind ("angle", "rate", "input"), the comma-separated
    ``parameters`` are the constants to free, and ``also`` (comma-separated, may be empty) the
    other constants that set the same thing, proposed when a fit has freed ``parameters``
    already; a hint applies only to a model that has every parameter it names. ``constraints``: ``(parameter, at_least, reason)``: a fit that frees
    both keeps ``parameter >= at_least``."""

    evidence: dict
    separated_by: dict
    pair_separated_by: dict
    parameter_hints: tuple
    constraints: tuple = ()        # ((parameter, at_least, reason), ...): orderings a fit keeps

    def separating_experiment(self, names: list) -> str:
        """What would separate the tied effects ``names``: the pair's own entry when there is
        one, else each effect's experiment."""
        if len(names) == 2 and frozenset(names) in self.pair_separated_by:
            return self.pair_separated_by[frozenset(names)]
        if not any(n in self.separated_by for n in names):
            return (f"the plant file names no experiment for them (its catalogue's separated_by); a longer "
                    f"--horizon, a few periods of the motion they act on, lets effects that act differently "
                    f"over time (damping and dry friction) show it, as does a free decay of that motion")
        how = {n: self.separated_by.get(n, f"the plant file names none for {n} (separated_by)") for n in names}
        ways = list(dict.fromkeys(how.values()))
        if len(ways) == 1:
            return ways[0]
        return "; ".join(f"for {n}, {how[n]}" for n in names)


EMPTY_NOTES = IdentificationNotes({}, {}, {}, ())


@dataclass(frozen=True)
class PlantDefinition:
    """Everything a plant file declares about the physics (values aside).

    ``constants`` (name -> :class:`Param`) are the plant's own parameters, in file order;
    ``coordinates`` (mechanical form) or ``states`` (state-equation form) the dynamics;
    ``catalogue`` (name -> :class:`EffectDecl`) the effects a model of it may have;
    ``physics`` the file's physics tables as read (canonical JSON in ``key``), from which
    :mod:`pendc.model.modelfile` writes it back and fingerprints it."""

    name: str
    core: str
    summary: str
    form: str                          # "mechanical" or "state"
    constants: dict
    inputs: tuple
    coordinates: tuple = ()
    states: tuple = ()
    bodies: tuple = ()
    gravity: tuple = ()
    kinetic: str = ""
    potential: str = ""
    determinant: str = "det"
    intermediates: tuple = ()          # ((name, text, unit, meaning), ...)
    quantities: tuple | None = None    # ((name, unit, meaning), ...) when the file lists them
    catalogue: dict = field(default_factory=dict)
    experiments: dict = field(default_factory=dict)
    sensors: tuple = ()
    notes: IdentificationNotes = EMPTY_NOTES
    operating_points: dict = field(default_factory=dict)
    drawing: dict = field(default_factory=dict)
    source: str = ""
    reference_formats: dict = field(default_factory=dict)   # node -> {"format", "max"}: a published design's
    reference_source: str = ""         # where those formats are printed
    key: str = ""                      # canonical JSON of the physics tables
    physics: dict = field(default_factory=dict, compare=False, hash=False)

    def __hash__(self):
        return hash(self.key)

    def __eq__(self, other):
        return isinstance(other, PlantDefinition) and other.key == self.key

    @cached_property
    def conflicts(self) -> tuple:
        """Pairs of catalogue effects that define the same part: ``(a, b, what)``."""
        from .effect_kinds import conflicts_of

        return conflicts_of(self)

    @property
    def coordinate_names(self) -> tuple:
        """The positions: mechanical coordinates, or the states that are not rates."""
        if self.form == "mechanical":
            return tuple(c.name for c in self.coordinates)
        rates = {s.name for s in self.states if s.rate_of}
        return tuple(s.name for s in self.states if s.name not in rates)

    def coordinate(self, name: str):
        """The declaration of coordinate or state ``name`` (KeyError if none)."""
        for c in (*self.coordinates, *self.states):
            if c.name == name:
                return c
        raise KeyError(name)

    def rate_of(self, name: str) -> str | None:
        """The name of the rate of position ``name`` (None when it has none)."""
        if self.form == "mechanical":
            return f"d{name}" if name in self.coordinate_names else None
        return next((s.name for s in self.states if s.rate_of == name), None)

    def body_of(self, name: str) -> str:
        """The body a coordinate (or its rate) belongs to, in words ("cart"), else the name."""
        for c in (*self.coordinates, *self.states):
            if c.name == name or self.rate_of(c.name) == name:
                return c.body or c.name
        return name
