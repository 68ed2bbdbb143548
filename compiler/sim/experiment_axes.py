"""Which signals an experiment makes irrelevant, read off the model's equations.

An experiment holds or removes part of the plant (a plant file's ``[experiments]``): a position
its equations no longer report is not measured (a clamped cart's position), and an input its
equations no longer contain drives nothing (the drive of a clamped cart). A file of such an
experiment may lack those columns; they are filled and listed as missing.
"""

from __future__ import annotations

from ..errors import PendcError
from ..model.equations import DEFAULT_EXPERIMENT
from .signals import signals_of


def _model(plant):
    """The plant model ``plant`` stands for (None: the default model; an interface: None)."""
    if plant is None:
        from ..model.modelfile import load_model

        return load_model()
    return plant if hasattr(plant, "for_experiment") else None


def experiments_of(model) -> dict:
    """The experiments ``model``'s plant knows (the default model's without a model)."""
    from ..model.modelfile import load_model

    return dict(getattr(model, "experiments", None) or load_model().experiments)


def _uses_input(equations) -> bool:
    """Whether the state derivatives depend on the input (through any assignment)."""
    need = set().union(*(d.free_symbols for d in equations.derivatives if hasattr(d, "free_symbols")))
    for sym, expr in reversed(equations.assignments):
        if sym in need:
            need |= expr.free_symbols
    return equations.input in need


def irrelevant_axes(plant, experiment: str) -> set:
    """Signals (positions, the input) that ``experiment`` of ``plant`` does not measure or use."""
    model = _model(plant)
    known = experiments_of(model)
    if experiment not in known:
        raise PendcError(f"unknown experiment '{experiment}' (known: {', '.join(known)})")
    if model is None or experiment == DEFAULT_EXPERIMENT:
        return set()
    equations = model.for_experiment(experiment).equations
    sig = signals_of(model)
    out = {p for p in sig.positions if p not in equations.measured}
    if not _uses_input(equations):
        out.add(sig.input)
    return out


def missing_hint(plant, name: str) -> str:
    """How to read a file without signal ``name``: the experiments that make it irrelevant, or
    ``--missing`` for the input; empty when there is none."""
    model = _model(plant)
    if model is None:
        return ""
    sig = signals_of(model)
    held = [e for e in experiments_of(model) if e != DEFAULT_EXPERIMENT and name in irrelevant_axes(model, e)]
    ways = [f"--experiment {e}" for e in held] + ([f"--missing {name}"] if name == sig.input else [])
    if not ways:
        return ""
    what = f"a run without {sig.label(name) if name != sig.input else 'the input'}"
    return f"{what}: {' or '.join(ways)}"


HELD_STEPS = 2.0    # a position that never moves more than this many resolution steps is held


def is_flat(values, resolution: float | None) -> bool:
    """Whether a position's values never move beyond HELD_STEPS resolution steps (exactly
    constant when the resolution is unknown)."""
    import numpy as np

    return float(np.ptp(np.asarray(values, float))) <= HELD_STEPS * (resolution or 0.0)


def held_experiment_of(plant, columns: dict, resolution: dict) -> str | None:
    """The one experiment of ``plant`` that holds exactly the positions that do not move in
    ``columns`` (a clamped cart's file read without ``--experiment``), or None."""
    model = _model(plant)
    if model is None:
        return None
    positions = signals_of(model).positions
    flat = {p for p in positions if p in columns and is_flat(columns[p], resolution.get(p))}
    if not flat:
        return None
    matches = [e for e in experiments_of(model)
               if e != DEFAULT_EXPERIMENT and irrelevant_axes(model, e) & set(positions) == flat]
    return matches[0] if len(matches) == 1 else None
