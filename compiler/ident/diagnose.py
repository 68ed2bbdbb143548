"""Which physical effect is missing? Test every catalogue effect the model lacks.

For each candidate the effect is added, its parameters are fitted on half of the data
segments (even ones), and the candidate is scored on the other half (odd ones) as the
fraction of the held-out simulation error it removes:

    score = 1 - RSS_after(odd) / RSS_before(odd)

A flexible effect that only bends to the fitting data does not lower the held-out
error, so it cannot win by flexibility (the penalty the Bayesian information
criterion would give is also reported). The evidence sentence comes from the
equation error: accelerations estimated from the data give the generalized force on
each coordinate that the model leaves unexplained, and their correlation with
what the candidate adds says in physical terms why it fits. Before blaming a missing
effect, the residual is compared with what the measurement chain alone would leave
(:mod:`.noise`): at that level there is "nothing systematic left". When the residual
is above it and no candidate removes most of it, the diagnosis says so and lists what
the residual correlates with (position-dependent signals included: a ripple along a rail
shows there). Only candidates that a compared output can see are tested (an effect on a
coordinate the experiment holds is invisible), and a sensor offset only where something in
the model depends on the absolute position it shifts (without a force that acts beyond a
threshold of the position, such as end stops, or a spring, an offset of a translation
changes no residual: the note says so rather than guessing). When the best
candidates' scores differ by less than the noise of the score, the diagnosis says that the
data cannot separate them and which experiment would (:mod:`.ties`).
"""

from __future__ import annotations

import math
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..errors import PendcError
from ..model.interface import with_unit
from ..model.plant import PlantModel
from ..sim.signals import signals_of
from .evidence import describe_candidate, residual_correlations
from .fit import PINNED, fit_parameters
from .noise import NOISE_FACTOR, noise_ratio
from .outputs import experiment_of, plan_outputs
from .plant_roles import engagement
from .shooting import ShootingProblem
from .ties import find_tie, free_run_separation

EXPLAINED = 0.5     # a candidate that removes at least half the held-out error explains it
NEAR_END = 0.8      # a threshold force is tested only when the data come this close to its threshold


@dataclass(frozen=True)
class Candidate:
    effect: str
    params: dict
    ci95: dict
    score: float
    delta_bic: float
    cost_fit: tuple       # (before, after) on the fitting half
    cost_heldout: tuple   # (before, after) on the held-out half
    evidence: str
    seconds: float = 0.0  # time spent testing this candidate
    heldout_before: tuple = ()   # per held-out segment: cost without the candidate
    heldout_after: tuple = ()    # per held-out segment: cost with it (what ties are judged on)
    at_bound: str = ""    # why its fitted value is not credible: a parameter pinned on its bound ('' if none)

    def to_json(self) -> dict:
        """A JSON-ready dict (the per-segment costs are left out: they serve the tie test)."""
        out = {k: v for k, v in self.__dict__.items() if k not in ("heldout_before", "heldout_after")}
        return dict(out, cost_fit=list(self.cost_fit), cost_heldout=list(self.cost_heldout))


@dataclass(frozen=True)
class Diagnosis:
    """Ranked candidates and the verdict: explained, at the noise level, or unexplained."""

    candidates: tuple     # best first
    unexplained: bool     # above the noise level and no candidate explains it
    correlations: list    # what the residual correlates with: [{"signal", "target", "r"}]
    baseline_cost: float
    noise_ratio: dict = None     # output -> residual / noise-only residual (mean squares)
    at_noise_level: bool = False  # nothing systematic left for an effect to explain
    notes: tuple = ()
    tie: dict | None = None       # the best candidates the data cannot separate (see :mod:`.ties`)

    def to_json(self) -> dict:
        """A JSON-ready dict of the whole diagnosis."""
        return {"candidates": [c.to_json() for c in self.candidates], "unexplained": self.unexplained,
                "at_noise_level": self.at_noise_level, "noise_ratio": self.noise_ratio,
                "correlations": self.correlations, "baseline_cost": self.baseline_cost, "notes": list(self.notes),
                "tie": self.tie}


def visible_parts(datasets: list, outputs=None, model=None) -> set:
    """What the compared outputs of ``datasets`` can see: the positions compared and the
    bodies they belong to (the names the plant file declares), and with nothing held the input
    (an effect on it, a dead zone, moves every part)."""
    from ..model.equations import DEFAULT_EXPERIMENT

    plan = plan_outputs(datasets, outputs, model)
    sig = signals_of(model)
    seen = set()
    for data, used in zip(datasets, plan.outputs):
        seen |= set(used)
        if experiment_of(data, model) == DEFAULT_EXPERIMENT:
            seen |= {sig.body_of(p) for p in sig.positions}    # coupled: each part moves the other
            seen |= {i.name for i in model.interface.inputs}   # the input drives them all: its effects show
        else:
            seen |= {sig.body_of(p) for p in used}
    return seen


def _catalogue(model) -> dict:
    return getattr(model, "catalogue", None) or {}


def _conflicts(model) -> tuple:
    return getattr(getattr(model, "rigid_body", None), "conflicts", ())


def candidate_effects(model: PlantModel, datasets: list | None = None, outputs=None) -> list:
    """Catalogue effects the model lacks and could take (no conflict, requirements met) and,
    given data, that the data could show (a sensor offset only where :func:`offset_blindness`
    finds physics that reveals it)."""
    return [name for name, why in exclusions(model, datasets, outputs).items() if why is None]


def exclusions(model: PlantModel, datasets: list | None = None, outputs=None) -> dict:
    """Every catalogue effect -> why :func:`candidate_effects` leaves it out (None: a candidate)."""
    seen = visible_parts(datasets, outputs, model) if datasets else None
    reach = _reach(datasets, model)
    positions = signals_of(model).positions
    out = {}
    for name, cls in _catalogue(model).items():
        why = None
        if name in model.effects:
            why = "the model has it already"
        elif seen is not None and cls.acts_on not in seen:
            why = f"it acts on {cls.acts_on}, which the data do not show"
        elif _out_of_reach(model, name, datasets):
            why = "it acts beyond a threshold the data never come near"
        elif any(name in (a, b) and (b if name == a else a) in model.effects for a, b, _ in _conflicts(model)):
            why = "it conflicts with an effect the model has"
        elif any(not any(r in model.effects for r in alts) for alts in cls.requires):
            why = "it needs an effect the model lacks"
        elif cls.acts_on in positions and datasets and offset_blindness(model, datasets, cls.acts_on, reach):
            why = f"nothing in the data reveals an offset of {cls.acts_on}"
        out[name] = why
    return out


def _out_of_reach(model, name: str, datasets) -> bool:
    """Whether effect ``name`` acts only beyond a threshold of a position
    (:func:`~pendc.ident.plant_roles.engagement`) that the data never come near."""
    found = engagement(model, name)
    if found is None or not datasets:
        return False
    reach = _reach(datasets, model, found[0])
    return reach is not None and reach < NEAR_END * found[2]


def _reach(datasets, model, position: str | None = None) -> float | None:
    """The largest |position| the data read of ``position``, default of any translation (a
    position that does not wrap: how near a body comes to the ends of its travel); None
    without data."""
    if not datasets:
        return None
    sig = signals_of(model)
    lines = [position] if position else [p for p in sig.positions if sig.period(p) is None]
    return max((float(np.max(np.abs(d.column(p)))) for d in datasets for p in lines
                if d.columns.get(p) is not None), default=0.0)


def offset_notes(model: PlantModel, datasets: list, outputs=None) -> list:
    """One note per sensor-offset effect that is left untested because the data cannot show it."""
    seen = visible_parts(datasets, outputs, model)
    positions = signals_of(model).positions
    notes = []
    for name, cls in _catalogue(model).items():
        if cls.acts_on in positions and cls.acts_on in seen and name not in model.effects:
            why = offset_blindness(model, datasets, cls.acts_on, _reach(datasets, model))
            if why:
                notes.append(f"{name} is not tested: {why}")
    return notes


def _depends_on(model: PlantModel, experiment: str, state: int) -> bool:
    """Whether the dynamics of ``model`` in ``experiment`` involve the absolute value of
    the state at index ``state`` of the state vector."""
    eq = model.for_experiment(experiment).equations
    used = set().union(*(e.free_symbols for _, e in eq.assignments), *(d.free_symbols for d in eq.derivatives))
    return eq.states[state] in used


def offset_blindness(model: PlantModel, datasets: list, output: str, reach: float | None = None) -> str:
    """Why an offset of sensor ``output`` cannot show in ``datasets`` ('' when it can).

    Shooting starts every segment from the measured state, so a constant offset of a
    sensor changes the residual only through physics that depends on the absolute
    position: gravity for an angle; for a translation a spring, or a force that acts only
    beyond a threshold of it (:func:`~pendc.ident.plant_roles.engagement`, e.g. end stops).
    What would show the offset is the offset effect's ``separated_by`` in the plant file."""
    sig = signals_of(model)
    state = sig.index(output)
    translation = sig.period(output) is None
    experiments = {experiment_of(d, model) for d in datasets}
    body, unit = sig.body_of(output), sig.unit(output)
    shown_by = f"what would show an offset of the position sensor: {_offset_experiment(model, output)}"
    if any(_depends_on(model, e, state) for e in experiments):
        limits = [(n, found) for n in model.effects if (found := engagement(model, n)) and found[0] == output]
        if translation and limits and reach is not None:
            without = model
            for n, _ in limits:
                without = without.without_effect(n)
            if not any(_depends_on(without, e, state) for e in experiments):
                name, (_, _, threshold) = min(limits, key=lambda item: item[1][2])
                if reach < NEAR_END * threshold:
                    words = name.replace("_", " ")
                    near, beyond = with_unit(f"{reach:.3g}", unit), with_unit(f"{threshold:g}", unit)
                    return (f"the {body} never comes near the {words} (|{output}| <= {near}, "
                            f"{name} acts beyond {beyond}), the only place where the model depends "
                            f"on its absolute position; {shown_by}")
        return ""
    if translation:
        return (f"nothing in the model depends on where the {body} is along its travel (no spring, no force "
                "beyond a threshold of its position), so an offset of the position sensor changes no residual: "
                f"it is not identifiable from these data; {shown_by}")
    return ("nothing in the model depends on the absolute angle in these experiments, so an offset of the angle "
            f"sensor changes no residual; a swing of the {body} would show it")


def _offset_experiment(model, output: str) -> str:
    """What shows an offset of the sensor of translation ``output``: the plant file's
    ``separated_by`` of its offset effect, else a run to the ends of its travel."""
    for decl in _catalogue(model).values():
        if decl.kind == "offset" and decl.on == output and decl.separated_by:
            return decl.separated_by
    return f"a run of the {signals_of(model).body_of(output)} to the ends of its travel"


def free_parameters(effect: str, model=None) -> list:
    """The parameters a fit of ``effect`` moves (optional ones keep their defaults), from the
    catalogue of ``model``'s plant (the default model's without a model)."""
    from ..model.modelfile import load_model

    catalogue = _catalogue(model if model is not None else load_model())
    if effect not in catalogue:
        raise PendcError(f"unknown effect '{effect}' (the catalogue has: {', '.join(catalogue)})")
    return [p.name for p in catalogue[effect].params if not p.optional]


def _test_candidate(args) -> Candidate:
    model, datasets, effect, dt, segment, outputs = args
    started = time.perf_counter()
    trial = model.with_effect(effect)
    free = free_parameters(effect, model)
    fit = fit_parameters(trial, datasets, free, dt=dt, segment=segment, subset="even", outputs=outputs)
    held = ShootingProblem(fit.model, datasets, free, dt=dt, segment=segment, subset="odd", outputs=outputs)
    base = ShootingProblem(model, datasets, [], dt=dt, segment=segment, subset="odd", outputs=outputs)
    rb, ra = base.residual(np.array([])), held.residual(held.start_values())
    blocks = base.segment_blocks()
    seg_before = tuple(0.5 * float(rb[a:b] @ rb[a:b]) for a, b in blocks)
    seg_after = tuple(0.5 * float(ra[a:b] @ ra[a:b]) for a, b in blocks)
    before, after = 0.5 * float(rb @ rb), 0.5 * float(ra @ ra)
    n = held.size
    bic = lambda cost, k: n * math.log(max(2 * cost, 1e-300) / n) + k * math.log(n)
    score = 1.0 - after / before if before > 0 else 0.0
    pinned = next((f"{p} at its {why.split(':')[0].removeprefix('it sits at its ')}"
                   for p, why in fit.unidentifiable.items() if PINNED in why), "")
    return Candidate(effect=effect, params=fit.values, ci95=fit.ci95, score=float(score), at_bound=pinned,
                     delta_bic=float(bic(before, 0) - bic(after, len(free))),
                     cost_fit=(fit.cost_before, fit.cost_after), cost_heldout=(before, after),
                     evidence=describe_candidate(model, fit.model, effect, datasets, score),
                     seconds=time.perf_counter() - started, heldout_before=seg_before, heldout_after=seg_after)


def noise_share(model: PlantModel, datasets: list, ratio: dict, dt: float, segment: float, outputs) -> float:
    """The share of the held-out error (odd segments) that the measurement chain alone leaves:
    per output, its part of the cost divided by its noise ratio (capped at all of it)."""
    problem = ShootingProblem(model, datasets, [], dt=dt, segment=segment, subset="odd", outputs=outputs)
    cost = {}
    for rec, segs in zip(problem.records, problem.errors(np.array([]))):
        for (a, b), e in zip(rec.bounds, segs):
            for o in rec.outputs:
                r = np.full(b - a, 1e3) if e is None else e[o] / problem.scales[o]
                cost[o] = cost.get(o, 0.0) + 0.5 * float(r @ r)
    total = sum(cost.values())
    if total <= 0:
        return 0.0
    noise = sum(c / max(ratio.get(o, math.inf), 1.0) for o, c in cost.items())
    return float(noise / total)


def diagnose(model: PlantModel, datasets: list, dt: float = 1e-4, segment: float = 0.5,
             workers: int = 1, progress=None, outputs=None, effects=None) -> Diagnosis:
    """Rank the missing-effect hypotheses for ``model`` on ``datasets`` (Measurements).

    ``outputs`` restricts the compared outputs (a tuple of position names); ``effects`` restricts
    the candidates to those named (each still subject to the checks of
    :func:`candidate_effects`); ``workers`` > 1 tests candidates in parallel processes;
    ``progress(done, total, name)`` is called after each candidate."""
    why = exclusions(model, datasets, outputs)
    names, skipped = [n for n, w in why.items() if w is None], offset_notes(model, datasets, outputs)
    if effects is not None:
        catalogue = _catalogue(model)
        unknown = [e for e in effects if e not in catalogue]
        if unknown:
            raise PendcError(f"unknown effect(s) {', '.join(unknown)} (the catalogue has: {', '.join(catalogue)})")
        names = [n for n in names if n in effects]
        skipped = [n for n in skipped if n.split(" ", 1)[0] in effects]
        # an effect asked for by name and left out is said, never silently dropped
        skipped += [f"{e} is not tested: {why[e]}" for e in effects
                    if e not in names and why.get(e) and not any(n.split(" ", 1)[0] == e for n in skipped)]
    jobs = [(model, datasets, name, dt, segment, outputs) for name in names]
    results = []
    if workers > 1 and len(jobs) > 1:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            for i, cand in enumerate(pool.map(_test_candidate, jobs)):
                results.append(cand)
                if progress:
                    progress(i + 1, len(jobs), cand.effect)
    else:
        for i, job in enumerate(jobs):
            results.append(_test_candidate(job))
            if progress:
                progress(i + 1, len(jobs), job[2])
    # a candidate that helps only with a value pinned on its bound explains nothing: it goes last
    results.sort(key=lambda c: (bool(c.at_bound), -c.score, c.effect))
    problem = ShootingProblem(model, datasets, [], dt=dt, segment=segment, outputs=outputs)
    base_cost = problem.cost(np.array([]))
    ratio = noise_ratio(model, datasets, dt=dt, segment=segment, outputs=outputs)
    explained = bool(results) and results[0].score >= EXPLAINED and not results[0].at_bound
    floor = noise_share(model, datasets, ratio, dt, segment, outputs) if explained else 0.0
    quiet = not explained and all(r <= NOISE_FACTOR for r in ratio.values())
    unexplained = not explained and not quiet
    tie = find_tie(results, floor, model.rigid_body.notes) if explained else None
    separation = ()
    if tie is not None:   # what the segments cannot tell apart, a meaningful free run may
        tied = [c for c in results if c.effect in tie["effects"]]
        found = free_run_separation(model, datasets, tied, outputs=outputs, dt=dt)
        if found is not None:
            winner, words = found
            results.sort(key=lambda c: c.effect != winner)      # stable: the rest keep their order
            tie, separation = None, (words,)
    return Diagnosis(candidates=tuple(results), unexplained=unexplained,
                     correlations=residual_correlations(model, datasets) if unexplained else [],
                     baseline_cost=base_cost, noise_ratio=ratio, at_noise_level=quiet,
                     notes=tuple(problem.notes) + tuple(skipped) + separation, tie=tie)
