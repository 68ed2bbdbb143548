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
something happens (the cart meeting a stop), and a spread over unequal segments would
call that noise.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import t as student_t

TIE_FLOOR = 0.01     # score differences below 1 % of the held-out error are not evidence
CONFIDENCE = 0.95

# The experiment that shows each effect on its own: what a rig engineer would run to
# separate it from a rival that explains the same data.
SEPARATED_BY = {
    "x_offset": "a constant-voltage run of the cart into the end stops (with end_stops in the model): the stops "
                "are fixed to the track, so where the cart meets them reads the sensor's zero",
    "theta_offset": "the pendulum left hanging at rest with the cart held: its reading there is the angle "
                    "sensor's zero",
    "asymmetric_cart": "cart-alone runs at the same constant voltage each way: only direction-dependent friction "
                       "gives different speeds left and right",
    "viscous_cart": "cart-alone runs at several constant voltages: the steady speed against the force is a line "
                    "whose slope is the viscous friction",
    "coulomb_cart": "cart-alone runs at several constant voltages: dry friction offsets the steady speed against "
                    "force line by a constant",
    "stribeck_cart": "cart-alone runs at several small constant voltages: the Stribeck dip shows in the steady "
                     "speed at low speeds",
    "static_cart": "a slow voltage ramp from rest: the voltage at which the cart breaks away is the static friction",
    "viscous_pendulum": "a long free swing with the cart held, from a large angle: viscous damping makes the "
                        "amplitude decay exponentially",
    "coulomb_pendulum": "a long free swing with the cart held, from a large angle: dry friction makes the amplitude "
                        "decay linearly and stop",
    "quadratic_pendulum": "a long free swing with the cart held, from a large angle: air drag takes the amplitude "
                          "down fastest while it is large",
    "drive_deadzone": "small constant voltages around V_off: inside a dead zone the cart does not move at all",
    "force_limit": "large voltage steps: a current limit caps the acceleration",
    "motor_lag": "fast voltage steps sampled at 1 kHz or faster: behind a lag the force rises smoothly",
    "input_delay": "fast voltage steps sampled at 1 kHz or faster: a delay is a dead time before any motion",
    "velocity_limit": "long runs at high voltage: a speed limit makes the speed plateau",
    "cart_spring": "the cart released at rest at several positions with zero voltage: a spring pulls it back "
                   "towards one place",
    "end_stops": "a run into the end stops",
}


# Pairs whose own experiments (above) would not separate them, because one mimics the other
# there too: what does. With a centring spring an offset of x is a constant force on the
# cart, and so is direction-dependent friction while the cart moves, in every run each way.
PAIR_SEPARATED_BY = {
    frozenset({"x_offset", "asymmetric_cart"}): "a run of the cart into the end stops (with end_stops in the "
                                                "model): where it meets them reads the sensor's zero, which "
                                                "friction does not move",
    frozenset({"x_offset", "cart_spring"}): "a run of the cart into the end stops (with end_stops in the model): "
                                            "where it meets them reads the sensor's zero",
    frozenset({"viscous_pendulum", "quadratic_pendulum"}): "a free swing with the cart held in which the "
                                                           "amplitude falls several-fold, fitted with the period "
                                                           "right (free I or L as well): air drag takes the "
                                                           "amplitude down fastest while it is large, viscous "
                                                           "damping at a constant rate",
    frozenset({"viscous_pendulum", "coulomb_pendulum"}): "a free swing with the cart held in which the amplitude "
                                                         "falls several-fold, fitted with the period right (free I "
                                                         "or L as well): the amplitude decays exponentially with "
                                                         "viscous damping, linearly to a stop with dry friction",
    frozenset({"input_delay", "motor_lag"}): "fast voltage steps sampled at 1 kHz or faster: a delay is a dead "
                                             "time before any motion, a lag a smooth rise",
}


def separating_experiment(names: list) -> str:
    """What would separate the tied ``names``: the pair's own entry when there is one, else
    each effect's experiment."""
    if len(names) == 2 and frozenset(names) in PAIR_SEPARATED_BY:
        return PAIR_SEPARATED_BY[frozenset(names)]
    how = {n: SEPARATED_BY.get(n, f"an experiment that excites {n} alone") for n in names}
    ways = list(dict.fromkeys(how.values()))
    if len(ways) == 1:
        return ways[0]
    return "; ".join(f"for {n}, {how[n]}" for n in names)


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
    return max(noise, float(student_t.ppf(0.5 + CONFIDENCE / 2, d.size - 1)) * se)


def separated(best, other, floor: float = 0.0) -> bool:
    """Whether the data prefer ``best`` over ``other`` beyond the noise of the score."""
    return best.score - other.score > noise_of_difference(best, other, floor)


def find_tie(candidates, floor: float = 0.0) -> dict | None:
    """The candidates (best first) that the data cannot separate from the best, as a JSON-ready
    dict with the message and the experiments that would separate them, or None. ``floor``:
    the share of the held-out error the measurement chain alone leaves."""
    if len(candidates) < 2 or candidates[0].score <= 0:
        return None
    best = candidates[0]
    tied = [c for c in candidates[1:] if c.score > 0 and not separated(best, c, floor)]
    if not tied:
        return None
    margin = max(noise_of_difference(best, c, floor) for c in tied)
    names = [best.effect] + [c.effect for c in tied]
    scores = [best.score] + [c.score for c in tied]
    advice = separating_experiment(names)
    return {"effects": names, "scores": scores, "noise": margin, "confidence": CONFIDENCE, "separate_by": advice,
            "message": tie_message(names, scores, margin, advice)}


def tie_message(names: list, scores: list, margin: float, advice: str) -> str:
    """``A and B explain the error equally well (0.913 vs 0.913, ...) ... To separate them: <advice>.``"""
    who = ", ".join(names[:-1]) + " and " + names[-1]
    values = " vs ".join(f"{s:.3f}" for s in scores)
    return (f"{who} explain the error equally well ({values}, a difference within the noise of the score, "
            f"±{margin:.3f}): the data cannot separate them. To separate them: {advice}.")
