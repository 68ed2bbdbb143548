"""Which physical effect is missing? Test every catalogue effect the model lacks.

For each candidate the effect is added, its parameters are fitted on half of the data
segments (even ones), and the candidate is scored on the other half (odd ones) as the
fraction of the held-out simulation error it removes:

    score = 1 - RSS_after(odd) / RSS_before(odd)

A flexible effect that only bends to the fitting data does not lower the held-out
error, so it cannot win by flexibility (the penalty the Bayesian information
criterion would give is also reported). The evidence sentence comes from the
equation error: accelerations estimated from the data give the force on the cart and
the torque at the pivot that the model leaves unexplained, and their correlation with
what the candidate adds says in physical terms why it fits. When no candidate removes
most of the error, the diagnosis says so and lists what the residual correlates with.
"""

from __future__ import annotations

import math
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..model.effects import CATALOGUE, CONFLICTS
from ..model.plant import PlantModel
from .evidence import describe_candidate, residual_correlations
from .fit import fit_parameters
from .shooting import ShootingProblem

EXPLAINED = 0.5     # a candidate that removes at least half the held-out error explains it


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

    def to_json(self) -> dict:
        return dict(self.__dict__, cost_fit=list(self.cost_fit), cost_heldout=list(self.cost_heldout))


@dataclass(frozen=True)
class Diagnosis:
    candidates: tuple     # best first
    unexplained: bool
    correlations: list    # what the residual correlates with: [{"signal", "target", "r"}]
    baseline_cost: float

    def to_json(self) -> dict:
        return {"candidates": [c.to_json() for c in self.candidates], "unexplained": self.unexplained,
                "correlations": self.correlations, "baseline_cost": self.baseline_cost}


def candidate_effects(model: PlantModel) -> list:
    """Catalogue effects the model lacks and could take (no conflict, requirements met)."""
    out = []
    for name, cls in CATALOGUE.items():
        if name in model.effects:
            continue
        if any(name in (a, b) and (b if name == a else a) in model.effects for a, b, _ in CONFLICTS):
            continue
        if any(not any(r in model.effects for r in alts) for alts in cls.requires):
            continue
        out.append(name)
    return out


def free_parameters(effect: str) -> list:
    return [p.name for p in CATALOGUE[effect].params if not p.optional]


def _test_candidate(args) -> Candidate:
    model, datasets, effect, dt, segment = args
    started = time.perf_counter()
    trial = model.with_effect(effect)
    free = free_parameters(effect)
    fit = fit_parameters(trial, datasets, free, dt=dt, segment=segment, subset="even")
    held = ShootingProblem(fit.model, datasets, free, dt=dt, segment=segment, subset="odd")
    base = ShootingProblem(model, datasets, [], dt=dt, segment=segment, subset="odd")
    before, after = base.cost(np.array([])), held.cost(held.start_values())
    n = held.size
    bic = lambda cost, k: n * math.log(max(2 * cost, 1e-300) / n) + k * math.log(n)
    score = 1.0 - after / before if before > 0 else 0.0
    return Candidate(effect=effect, params=fit.values, ci95=fit.ci95, score=float(score),
                     delta_bic=float(bic(before, 0) - bic(after, len(free))),
                     cost_fit=(fit.cost_before, fit.cost_after), cost_heldout=(before, after),
                     evidence=describe_candidate(model, fit.model, effect, datasets, score),
                     seconds=time.perf_counter() - started)


def diagnose(model: PlantModel, datasets: list, dt: float = 1e-4, segment: float = 0.5,
             workers: int = 1, progress=None) -> Diagnosis:
    """Rank the missing-effect hypotheses for ``model`` on ``datasets`` (Measurements).

    ``workers`` > 1 tests candidates in parallel processes; ``progress(done, total, name)``
    is called after each candidate."""
    names = candidate_effects(model)
    jobs = [(model, datasets, name, dt, segment) for name in names]
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
    results.sort(key=lambda c: (-c.score, c.effect))
    base_cost = ShootingProblem(model, datasets, [], dt=dt, segment=segment).cost(np.array([]))
    unexplained = not results or results[0].score < EXPLAINED
    return Diagnosis(candidates=tuple(results), unexplained=unexplained,
                     correlations=residual_correlations(model, datasets) if unexplained else [],
                     baseline_cost=base_cost)
