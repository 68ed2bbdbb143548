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
what the candidate adds says in physical terms why it fits. Before blaming a missing
effect, the residual is compared with what the measurement chain alone would leave
(:mod:`.noise`): at that level there is "nothing systematic left". When the residual
is above it and no candidate removes most of it, the diagnosis says so and lists what
the residual correlates with (x-dependent signals included: a rail ripple shows there).
Only candidates that a compared output can see are tested (an effect on the cart is
invisible in a held-cart swing).
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
from .noise import NOISE_FACTOR, noise_ratio
from .outputs import experiment_of, plan_outputs
from .shooting import ShootingProblem

EXPLAINED = 0.5     # a candidate that removes at least half the held-out error explains it
NEAR_END = 0.8      # end stops are tested only when the cart comes this close to x_end


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
    """Ranked candidates and the verdict: explained, at the noise level, or unexplained."""

    candidates: tuple     # best first
    unexplained: bool     # above the noise level and no candidate explains it
    correlations: list    # what the residual correlates with: [{"signal", "target", "r"}]
    baseline_cost: float
    noise_ratio: dict = None     # output -> residual / noise-only residual (mean squares)
    at_noise_level: bool = False  # nothing systematic left for an effect to explain
    notes: tuple = ()

    def to_json(self) -> dict:
        """A JSON-ready dict of the whole diagnosis."""
        return {"candidates": [c.to_json() for c in self.candidates], "unexplained": self.unexplained,
                "at_noise_level": self.at_noise_level, "noise_ratio": self.noise_ratio,
                "correlations": self.correlations, "baseline_cost": self.baseline_cost, "notes": list(self.notes)}


def visible_parts(datasets: list, outputs=None) -> set:
    """What the compared outputs of ``datasets`` can see: "cart", "pendulum", "x", "theta"."""
    plan = plan_outputs(datasets, outputs)
    seen = set()
    for data, used in zip(datasets, plan.outputs):
        seen |= set(used)
        if experiment_of(data) == "free":
            seen |= {"cart", "pendulum"}    # coupled: each part moves the other
        else:
            seen |= {"pendulum"} if "theta" in used else {"cart"}
    return seen


def candidate_effects(model: PlantModel, datasets: list | None = None, outputs=None) -> list:
    """Catalogue effects the model lacks and could take (no conflict, requirements met) and,
    given data, that the data could show."""
    seen = visible_parts(datasets, outputs) if datasets else None
    reach = max((float(np.max(np.abs(d.column("x")))) for d in datasets), default=0.0) if datasets else None
    out = []
    for name, cls in CATALOGUE.items():
        if name in model.effects:
            continue
        if seen is not None and cls.acts_on not in seen:
            continue
        if name == "end_stops" and reach is not None and reach < NEAR_END * 0.375:
            continue
        if any(name in (a, b) and (b if name == a else a) in model.effects for a, b, _ in CONFLICTS):
            continue
        if any(not any(r in model.effects for r in alts) for alts in cls.requires):
            continue
        out.append(name)
    return out


def free_parameters(effect: str) -> list:
    """The parameters a fit of ``effect`` moves (optional ones keep their defaults)."""
    return [p.name for p in CATALOGUE[effect].params if not p.optional]


def _test_candidate(args) -> Candidate:
    model, datasets, effect, dt, segment, outputs = args
    started = time.perf_counter()
    trial = model.with_effect(effect)
    free = free_parameters(effect)
    fit = fit_parameters(trial, datasets, free, dt=dt, segment=segment, subset="even", outputs=outputs)
    held = ShootingProblem(fit.model, datasets, free, dt=dt, segment=segment, subset="odd", outputs=outputs)
    base = ShootingProblem(model, datasets, [], dt=dt, segment=segment, subset="odd", outputs=outputs)
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
             workers: int = 1, progress=None, outputs=None) -> Diagnosis:
    """Rank the missing-effect hypotheses for ``model`` on ``datasets`` (Measurements).

    ``outputs`` restricts the compared outputs (e.g. ``("theta",)``); ``workers`` > 1 tests
    candidates in parallel processes; ``progress(done, total, name)`` is called after each
    candidate."""
    names = candidate_effects(model, datasets, outputs)
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
    results.sort(key=lambda c: (-c.score, c.effect))
    problem = ShootingProblem(model, datasets, [], dt=dt, segment=segment, outputs=outputs)
    base_cost = problem.cost(np.array([]))
    ratio = noise_ratio(model, datasets, dt=dt, segment=segment, outputs=outputs)
    explained = bool(results) and results[0].score >= EXPLAINED
    quiet = not explained and all(r <= NOISE_FACTOR for r in ratio.values())
    unexplained = not explained and not quiet
    return Diagnosis(candidates=tuple(results), unexplained=unexplained,
                     correlations=residual_correlations(model, datasets) if unexplained else [],
                     baseline_cost=base_cost, noise_ratio=ratio, at_noise_level=quiet, notes=problem.notes)
