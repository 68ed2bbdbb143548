"""The plant model: a plant definition plus the values of its parameters and active effects.

:class:`PlantModel` is the value that model files, the simulator, the identification
workbench and the compiler pass around. Its physics is its
:class:`~pendc.model.definition.PlantDefinition` (what the plant file declares: constants,
coordinates and bodies or state equations, inputs, sensors, the effect catalogue);
:mod:`pendc.model.assemble` turns it into an :class:`Equations` object: a short list of
named intermediate quantities (as the file names them) followed by the state derivatives.
Adding or removing an effect changes these equations and nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import math

from ..errors import PendcError
from .assemble import build_equations, build_interface
from .definition import PlantDefinition
from .equations import Equations
from .interface import PlantInterface, check_input_range, unit_name, with_unit
from .plantfile import DEFAULT_EXPERIMENT


@dataclass(frozen=True)
class PlantModel:
    """A plant definition, the values of its constants and active effects, and fit settings.

    ``definition`` is the plant's physics (:class:`~pendc.model.definition.PlantDefinition`,
    read from a plant file). ``plant`` holds the values of its constants; ``effects`` maps
    each active effect of its catalogue to ``{parameter: value}``, kept in catalogue order so
    that equal models produce identical equations and kernels. ``hardware`` holds the model
    file's ``[hardware]`` table (build options and per-node overrides) untouched.
    ``experiment`` selects the equations of one of the plant's experiments (a held axis, a
    removed body); it is never written to a model file. ``input_range`` is the model file's
    ``[input] range = [low, high]``: what the actuator takes, when the file overrides the
    input's declared range. Construction validates everything and raises
    :class:`PendcError` with a one-line reason.
    """

    plant: dict
    effects: dict
    free: tuple = ()
    source: str = field(default="", compare=False)
    hardware: dict = field(default_factory=dict)   # compiler options; the compiler validates them
    experiment: str = DEFAULT_EXPERIMENT
    definition: PlantDefinition | None = None
    input_range: tuple | None = None

    def __post_init__(self):
        d = self.definition
        if not isinstance(d, PlantDefinition):
            raise PendcError(f"{self._where()}a plant model needs its plant definition (read it with load_model "
                             f"or parse_model from a plant file)")
        if self.input_range is not None:
            pair = self.input_range
            if not isinstance(pair, (list, tuple)) or len(pair) != 2:
                raise PendcError(f"{self._where()}input.range must be [low, high], got {pair!r}")
            object.__setattr__(self, "input_range", check_input_range(*pair, f"{self._where()}input.range"))
        if self.experiment not in d.experiments:
            raise PendcError(f"unknown experiment '{self.experiment}' (known: {', '.join(d.experiments)})")
        object.__setattr__(self, "plant", _validate_plant(self.plant, self.source, d))
        object.__setattr__(self, "effects", _validate_effects(self.effects, self.source, d))
        names = self.parameter_names()
        for p in self.free:
            if p not in names:
                raise PendcError(f"{self._where()}[fit] free names unknown parameter '{p}' (known: {', '.join(names)})")

    def _where(self):
        return f"{self.source}: " if self.source else ""

    @property
    def body(self) -> str:
        """The plant's name (``[plant] name`` of its file)."""
        return self.definition.name

    @property
    def rigid_body(self) -> PlantDefinition:
        """The plant's definition (constants, catalogue, experiments, identification notes)."""
        return self.definition

    @property
    def catalogue(self) -> dict:
        """The plant's effect catalogue (name -> :class:`~pendc.model.definition.EffectDecl`)."""
        return self.definition.catalogue

    @property
    def experiments(self) -> dict:
        """The experiments the plant knows (name -> what was held or removed)."""
        return {name: e.meaning for name, e in self.definition.experiments.items()}

    def parameter_names(self) -> tuple:
        """Plant constants, then effect parameters in catalogue order."""
        return tuple(self.plant) + tuple(p for params in self.effects.values() for p in params)

    def parameter_values(self) -> dict:
        values = dict(self.plant)
        for params in self.effects.values():
            values.update(params)
        return values

    def for_experiment(self, name: str) -> "PlantModel":
        """The same model under experiment ``name`` (same parameters, other equations). One copy
        per experiment is kept with this model, so asking again reuses its derived equations."""
        if name == self.experiment:
            return self
        copies = self._experiment_copies
        if name not in copies:
            copies[name] = replace(self, experiment=name)
        return copies[name]

    @cached_property
    def _experiment_copies(self) -> dict:
        return {}

    def sensor_offset_values(self) -> dict:
        """``{state: offset}`` of the sensor offset effects at this model's parameter values (the
        states whose sensor reads state + offset; the others are absent)."""
        import sympy as sp

        eq = self.equations
        values = dict(zip(eq.params, self.parameter_vector()))
        out: dict = {}
        for name, expr in eq.sensor_offsets:
            out[name] = out.get(name, 0.0) + float(sp.sympify(expr).subs(values))
        return out

    def sensor_offsets_without_hardware(self) -> list:
        """The effects of kind ``offset`` on a position an encoder reads: applied by ``pendc simulate
        --quantize`` and identification, left out of the core and the HIL plants (an incremental
        encoder counts from where it was homed, so its offset is the homing's). A converter's offset
        is in the core: its thresholds are shifted (:func:`pendc.passes.lower_sensors.lower_adc`)."""
        converted = {s.state for s in self.interface.sensors if s.is_adc}
        return [n for n in self.effects if self.catalogue[n].kind == "offset"
                and self.catalogue[n].on not in converted]

    def derived(self, key: str, make):
        """``make(self)``, made once for this model and kept with it as its equations are: what
        other layers derive from it (the controllers' numeric equations, asked for by every
        design step of a run). A copy with other values or effects makes its own."""
        memo = self._derived
        if key not in memo:
            memo[key] = make(self)
        return memo[key]

    @cached_property
    def _derived(self) -> dict:
        return {}

    def with_params(self, values: dict) -> "PlantModel":
        """A copy with some parameters (bare names) set to new values."""
        unknown = set(values) - set(self.parameter_names())
        if unknown:
            raise PendcError(f"unknown parameter(s) {', '.join(sorted(unknown))} for this model")
        plant = {k: float(values.get(k, v)) for k, v in self.plant.items()}
        effects = {e: {k: float(values.get(k, v)) for k, v in ps.items()} for e, ps in self.effects.items()}
        copy = replace(self, plant=plant, effects=effects)
        # the equations are symbolic in the parameters (build_equations reads no value): the copy's
        # are these, already derived; a robust sweep's runs and a fit's results each derived them
        # again (0.3 s for the rig, 4 s for the double pendulum)
        if "equations" in self.__dict__:
            copy.__dict__["equations"] = self.__dict__["equations"]
        return copy

    def with_effect(self, name: str, params: dict | None = None) -> "PlantModel":
        """A copy with effect ``name`` added (catalogue defaults for parameters not given)."""
        catalogue = self.catalogue
        if name not in catalogue:
            raise PendcError(f"unknown effect '{name}' (known: {', '.join(catalogue)})")
        if name in self.effects:
            raise PendcError(f"the model has effect '{name}' already")
        values = {p.name: p.default for p in catalogue[name].params}
        values.update(params or {})
        return replace(self, effects={**self.effects, name: values})

    def without_effect(self, name: str) -> "PlantModel":
        if name not in self.effects:
            raise PendcError(f"the model has no effect '{name}'")
        effects = {k: v for k, v in self.effects.items() if k != name}
        free = tuple(p for p in self.free if p not in self.effects[name])
        return replace(self, effects=effects, free=free)

    @cached_property
    def equations(self) -> Equations:
        return build_equations(self)

    @cached_property
    def interface(self) -> PlantInterface:
        """What the compiler, golden model and testbench know of this plant (states, input,
        encoders, tolerances); see :mod:`pendc.model.interface`."""
        return build_interface(self)

    def parameter_vector(self):
        """Values in the order of ``self.equations.params``."""
        values = self.parameter_values()
        return [values[s.name] for s in self.equations.params]


def _check_value(where: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PendcError(f"{where} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise PendcError(f"{where} must be finite, got {value!r}")
    return float(value)


def _validate_plant(plant: dict, source: str, rigid: PlantDefinition) -> dict:
    pre = f"{source}: " if source else ""
    if not isinstance(plant, dict):
        raise PendcError(f"{pre}[plant] must be a table")
    constants = rigid.constants
    unknown = set(plant) - set(constants)
    if unknown:
        from .plantfile import PLANT_META

        raise PendcError(f"{pre}[plant] has unknown constant(s) {', '.join(sorted(unknown))} "
                         f"(known for plant '{rigid.name}': {' '.join(constants)}; and the keys "
                         f"{', '.join(PLANT_META)})")
    missing = [k for k in constants if k not in plant]
    if missing:
        raise PendcError(f"{pre}[plant] lacks {', '.join(missing)} (plant '{rigid.name}': "
                         + "; ".join(f"{k}, {constants[k].description} ({unit_name(constants[k].unit)})"
                                     for k in missing) + ")")
    out = {}
    for k in constants:
        v = _check_value(f"{pre}plant.{k}", plant[k])
        c = constants[k]
        bounds = with_unit(f"[{c.lo:g}, {c.hi:g}]", c.unit)
        if c.positive and v <= 0:
            raise PendcError(f"{pre}plant.{k} must be positive, got {v}: a constant declared without bounds is "
                             f"positive; to allow {v:g}, declare its bounds (constants.{k}.bounds = [low, high])")
        if v <= 0 < c.lo:
            raise PendcError(f"{pre}plant.{k} must be positive, got {v}: its bounds are {bounds}")
        if not c.lo <= v <= c.hi:
            raise PendcError(f"{pre}plant.{k} = {v} is outside its bounds {bounds}")
        out[k] = v
    return out


def _validate_effects(effects: dict, source: str, rigid: PlantDefinition) -> dict:
    pre = f"{source}: " if source else ""
    catalogue = rigid.catalogue
    if not isinstance(effects, dict):
        raise PendcError(f"{pre}[effects] must be a table of effect tables")
    of_body = f" for plant '{rigid.name}'"
    for name in effects:
        if name not in catalogue:
            raise PendcError(f"{pre}unknown effect '{name}'{of_body} (known: {', '.join(catalogue)})")
    out = {}
    for name, cls in catalogue.items():  # catalogue order: equal models give identical equations
        if name not in effects:
            continue
        given = effects[name]
        if not isinstance(given, dict):
            raise PendcError(f"{pre}[effects.{name}] must be a table")
        known = {p.name: p for p in cls.params}
        for k in given:
            if k not in known:
                raise PendcError(f"{pre}effect '{name}' has no parameter '{k}' (its parameters: {', '.join(known)})")
        values = {}
        for p in cls.params:
            if p.name not in given:
                if not p.optional:
                    raise PendcError(f"{pre}[effects.{name}] lacks parameter '{p.name}' "
                                     f"({p.description}, {unit_name(p.unit)})")
                values[p.name] = p.default
                continue
            v = _check_value(f"{pre}{name}.{p.name}", given[p.name])
            if not p.lo <= v <= p.hi:
                raise PendcError(f"{pre}{name}.{p.name} = {v} is outside its physical range "
                                 f"{with_unit(f'[{p.lo:g}, {p.hi:g}]', p.unit)}")
            values[p.name] = v
        out[name] = values
    for a, b, what in rigid.conflicts:
        if a in out and b in out:
            raise PendcError(f"{pre}effects '{a}' and '{b}' both define the {what}; keep one")
    for name in out:
        for alternatives in catalogue[name].requires:
            if not any(a in out for a in alternatives):
                raise PendcError(f"{pre}effect '{name}' needs one of: {', '.join(alternatives)}")
    return out
