"""When the data cannot tell the best candidates apart, and which experiment would.

Diagnose scores every candidate on the same held-out segments, so two candidates are
compared *pairwise*, segment by segment: the score difference is the sum over held-out
segments of ``D_j = (cost_B,j - cost_A,j) / cost_before``. Two sources of noise can make
such a difference:

* the measurement chain: what encoder quantisation and input noise alone leave of the
  held-out error (:mod:`pendc.ident.noise` measures it: ``floor``, as a fraction of the
  error before) is error that no physics removes, so two candidates that both reach it
  differ by at most that much; a difference below ``max(floor, TIE_FLOOR)`` is a tie
  (``TIE_FLOOR``, 1 % of the held-out error, is the optimiser's own tolerance on costs);
* the choice of segments: when segments disagree (some prefer B by more than the
  measurement noise can explain), the held-out segments are the independent pieces of
  evidence (as :mod:`pendc.ident.fit` assumes for its intervals) and the noise of the sum
  is their spread: a paired t-interval, ``t_0.975(n - 1) * sqrt(n) * sd(D)``. A difference
  inside it is a tie.

When no segment prefers B beyond the measurement noise, the segments do not disagree and
the t-interval does not apply: evidence often sits in the two or three segments where
something happens (a body meeting a stop), and a spread over unequal segments would
call that noise.

Which experiment would separate two effects is physics of the body: its
:class:`~pendc.model.definition.IdentificationNotes` of the plant file say.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.definition import IdentificationNotes

TIE_FLOOR = 0.01     # score differences below 1 % of the held-out error are not evidence
CONFIDENCE = 0.95

def separating_experiment(names: list, notes: IdentificationNotes | None = None) -> str:
    """What would separate the tied ``names``, from the body's ``notes`` (default: the default
    model's body): the pair's own entry when there is one, else each effect's experiment."""
    if notes is None:
        from ..model.modelfile import load_model

        notes = load_model().definition.notes
    return notes.separating_experiment(names)


def segment_differences(best, other) -> np.ndarray:
    """``D_j``: per held-out segment, how much more of the held-out error ``best`` removes
    than ``other`` (fractions of the whole held-out error before; they sum to the score
    difference)."""
    before = float(np.sum(best.heldout_before))
    a, b = np.asarray(best.heldout_after, float), np.asarray(other.heldout_after, float)
    if before <= 0 or a.shape != b.shape or a.size == 0:
        return np.array([best.score - other.score])
    return (b - a) / before


def noise_of_difference(best, other, floor: float = 0.0) -> float:
    """Half-width of the interval within which the score difference of ``best`` over
    ``other`` is noise (see the module docstring); ``floor`` is the measurement chain's
    share of the held-out error."""
    noise = max(TIE_FLOOR, floor)
    d = segment_differences(best, other)
    against = -float(np.sum(np.minimum(d, 0.0)))
    if d.size < 2 or against <= noise:
        return noise
    se = math.sqrt(d.size) * float(np.std(d, ddof=1))
    from scipy.stats import t as student_t     # here: scipy.stats takes half a second to import

    return max(noise, float(student_t.ppf(0.5 + CONFIDENCE / 2, d.size - 1)) * se)


def separated(best, other, floor: float = 0.0) -> bool:
    """Whether the data prefer ``best`` over ``other`` beyond the noise of the score."""
    return best.score - other.score > noise_of_difference(best, other, floor)


def find_tie(candidates, floor: float = 0.0, notes: IdentificationNotes | None = None) -> dict | None:
    """The candidates (best first) that the data cannot separate from the best, as a JSON-ready
    dict with the message and the experiments that would separate them, or None. ``floor``:
    the share of the held-out error the measurement chain alone leaves; ``notes``: the
    identification notes of the model's body (what separates its effects; default: the
    default model's body)."""
    if len(candidates) < 2 or candidates[0].score <= 0:
        return None
    best = candidates[0]
    tied = [c for c in candidates[1:] if c.score > 0 and not separated(best, c, floor)]
    if not tied:
        return None
    margin = max(noise_of_difference(best, c, floor) for c in tied)
    names = [best.effect] + [c.effect for c in tied]
    scores = [best.score] + [c.score for c in tied]
    advice = separating_experiment(names, notes)
    return {"effects": names, "scores": scores, "noise": margin, "confidence": CONFIDENCE, "separate_by": advice,
            "message": tie_message(names, scores, margin, advice)}


def tie_message(names: list, scores: list, margin: float, advice: str) -> str:
    """``A and B explain the error equally well (0.913 vs 0.913, ...) ... To separate them: <advice>.``"""
    who = ", ".join(names[:-1]) + " and " + names[-1]
    values = " vs ".join(f"{s:.3f}" for s in scores)
    return (f"{who} explain the error equally well ({values}, a difference within the noise of the score, "
            f"±{margin:.3f}): the data cannot separate them. To separate them: {advice}.")


FREE_RUN_RATIO = 3.0   # a tied candidate whose free-run error is this many times the best's is separated


def free_run_separation(model, datasets: list, tied: list, outputs=None, dt: float = 1e-4):
    """``(winner, words)`` when the free run separates the ``tied`` candidates (Candidates, best
    first) that the horizon's segments could not: on the records whose free run is meaningful
    (the headline test of :mod:`.headline`, on the best candidate's model), one candidate's
    free-run error (pooled, every compared output, relative to each output's spread) is
    :data:`FREE_RUN_RATIO` times smaller than each other's. Each is fitted with one parameter set
    on the same data, so the comparison is fair. None when no record's free run is meaningful or
    no candidate stands out. (Round F's crane: pivot damping and dry friction tied at 0.5 s, their
    fitted models' free-run errors on a 20 s swing were 0.71 and 7.37 mrad.)"""
    from .compare import headline_of
    from .figures import free_run_figures
    from .headline import FREE_RUN

    first = model.with_effect(tied[0].effect, tied[0].params)
    usable = [d for d in datasets if headline_of(first, d, dt=dt, outputs=outputs).metric == FREE_RUN]
    if not usable:
        return None
    error = {}
    for c in tied:
        pooled = free_run_figures(model.with_effect(c.effect, c.params), usable, dt=dt, outputs=outputs)["pooled"]
        if not pooled or not all(math.isfinite(v) for v in pooled.values()):
            return None
        error[c.effect] = math.sqrt(sum((1.0 - v / 100.0) ** 2 for v in pooled.values()))
    winner = min(error, key=error.get)
    others = [e for e in error if e != winner]
    if not others or not all(error[e] >= FREE_RUN_RATIO * error[winner] for e in others):
        return None
    files = ", ".join(getattr(d, "source", "<data>") for d in usable)
    words = (f"the horizon's segments could not separate {' and '.join(error)}, the free run on {files} does: "
             f"{winner}'s error is " + ", ".join(f"{error[e] / error[winner]:.1f} times smaller than {e}'s"
                                                   for e in others))
    return winner, words
