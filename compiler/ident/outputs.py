"""Which measured outputs identification compares, and how each is weighted.

Why this exists: an output that the data do not excite (the constant position of a
clamped body, a column the file did not have) carries no information, yet scaled by its
tiny spread it used to outweigh everything else (a micrometre of modelled creep of a
clamped cart beat the whole swing of its pendulum). So each output is scaled by the larger of
its spread and its measurement resolution (the encoder count, or the quantisation step
the file declares or shows), and outputs that are held, constant, missing, outside the
experiment or not asked for are dropped, each with a one-line note for the user.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import PendcError
from ..model.equations import DEFAULT_EXPERIMENT
from ..sim.experiment_axes import HELD_STEPS, experiments_of, irrelevant_axes, is_flat
from ..sim.signals import signals_of

FINEST = 1e-12      # the resolution of a position no sensor reads and the data do not show


def experiment_of(data, model=None) -> str:
    """The experiment a measurement declares (``free`` when it says nothing): its
    ``experiment`` attribute, else a ``# experiment: NAME`` metadata line; it must be one of
    ``model``'s experiments (the default model's without a model)."""
    meta = getattr(data, "meta", None) or {}
    name = getattr(data, "experiment", None) or meta.get("experiment") or DEFAULT_EXPERIMENT
    known = experiments_of(model)
    if name not in known and name not in experiments_of(None):
        raise PendcError(f"{getattr(data, 'source', '<data>')}: unknown experiment '{name}' "
                         f"(known: {', '.join(known)})")
    return name


def _looks_quantised(y: np.ndarray, step: float) -> bool:
    """Most sample-to-sample changes are whole multiples of ``step``."""
    d = np.abs(np.diff(y))
    d = d[d > 0]
    if d.size < 10:
        return False
    k = d / step
    return float(np.mean(np.abs(k - np.round(k)) < 0.05)) > 0.9


def signals_for(data):
    """The plant signals a measurement was read for (the default model's for other objects)."""
    return signals_of(getattr(data, "signals", None))


def resolution_of(data, name: str) -> float:
    """Measurement resolution of column ``name``: as the file or user gives it, else the
    quantisation step the data show, else one count of the plant's encoder on it (the x4
    count of the sensor its plant file declares)."""
    given = (getattr(data, "resolution", None) or {}).get(name)
    if given is not None and np.isfinite(given) and given > 0:
        return float(given)
    y = np.asarray(data.column(name), float)
    d = np.abs(np.diff(y))
    d = d[d > 0]
    if d.size >= 10:
        step = float(np.min(d))
        if step > 0 and _looks_quantised(y, step):
            return max(step, 1e-12)
    return signals_for(data).resolution(name) or FINEST


@dataclass(frozen=True)
class OutputPlan:
    """Per data set, the outputs compared; per output, its scale; and notes on what was dropped."""

    outputs: tuple        # per data set: tuple of output names
    scales: dict          # output name -> scale (max of spread and resolution)
    resolution: dict      # output name -> resolution (the finest over the data sets)
    notes: tuple


def plan_outputs(datasets: list, requested=None, model=None) -> OutputPlan:
    """Choose and weight the outputs of ``datasets`` (the positions of their plant);
    ``requested`` (a tuple of position names) restricts them; ``model`` (default: the default
    model) says which positions each experiment holds. Raises PendcError when nothing is
    left to compare."""
    positions = signals_for(datasets[0]).positions if datasets else signals_of(model).positions
    if requested is not None:
        requested = tuple(requested)
        bad = [o for o in requested if o not in positions]
        if bad:
            raise PendcError(f"unknown output(s) {', '.join(bad)} (choose from: {', '.join(positions)})")
    per_set, notes = [], []
    values = {o: [] for o in positions}
    resolution = {}
    for data in datasets:
        exp = experiment_of(data, model)
        source = getattr(data, "source", "<data>")
        missing = set(getattr(data, "missing", ()) or ())
        held = irrelevant_axes(model, exp)
        used, why = [], {}
        for o in positions:
            if requested is not None and o not in requested:
                continue
            if o in missing:
                notes.append(f"{source}: no {o} column: {o} is not compared")
                why[o] = "missing"
                continue
            if o in held:
                why[o] = f"held in experiment {exp}"
                continue
            y = np.asarray(data.column(o), float)
            res = resolution_of(data, o)
            if is_flat(y, res):
                hint = _held_hint(model, o) if exp == DEFAULT_EXPERIMENT else ""
                notes.append(f"{source}: {o} does not move beyond {HELD_STEPS:g} resolution steps "
                             f"({res:.3g}): {o} is not compared{hint}")
                why[o] = f"moves less than {HELD_STEPS:g} resolution steps"
                continue
            used.append(o)
            values[o].append(y)
            resolution[o] = min(res, resolution.get(o, np.inf))
        if not used:
            reasons = "; ".join(f"{o} {why.get(o, 'not asked for')}" for o in positions)
            raise PendcError(f"{source}: no output left to compare (experiment {exp}: {reasons})")
        per_set.append(tuple(used))
    scales = {o: max(float(np.std(np.concatenate(v))), resolution[o]) for o, v in values.items() if v}
    return OutputPlan(outputs=tuple(per_set), scales=scales, resolution=resolution, notes=tuple(notes))


def _held_hint(model, position: str) -> str:
    """`` (the <body> looks held: --experiment <name>)``: the plant file's experiment that holds
    ``position``."""
    from ..sim.experiment_axes import _model

    plant = _model(model)
    if plant is None:
        return ""
    held = [e for e in experiments_of(plant) if e != DEFAULT_EXPERIMENT and position in irrelevant_axes(plant, e)]
    if not held:
        return ""
    return f" (the {signals_of(plant).body_of(position)} looks held: --experiment {held[0]})"


def parse_outputs(text: str | None, plant=None):
    """``--outputs NAME`` or ``NAME,NAME`` (positions of ``plant``, default the default model) ->
    tuple, or None for "all"."""
    if not text:
        return None
    positions = signals_of(plant).positions
    names = tuple(o.strip() for o in text.split(",") if o.strip())
    bad = [o for o in names if o not in positions]
    if bad or not names:
        raise PendcError(f"--outputs takes {', '.join(positions)} or a comma-separated list of them, got '{text}'")
    return names
