"""The tie criterion of diagnose (pendc.ident.ties) on hand-made per-segment costs, where the
right verdict is known: concentrated evidence separates, disagreeing segments do not, and a
difference below the measurement noise never does."""

from dataclasses import dataclass

import pytest

from pendc.ident.ties import TIE_FLOOR, find_tie, noise_of_difference, separated


@dataclass(frozen=True)
class Scored:
    effect: str
    heldout_before: tuple
    heldout_after: tuple

    @property
    def score(self) -> float:
        return 1.0 - sum(self.heldout_after) / sum(self.heldout_before)


BEFORE = (1.0, 10.0, 1.0, 1.0, 10.0, 1.0, 1.0)     # two segments where something happens


def test_evidence_in_a_few_segments_separates():
    # the best removes the error of the two eventful segments, the other does not; elsewhere
    # both leave the same small error (a t-interval over these unequal segments would call it noise)
    best = Scored("x_offset", BEFORE, (0.01,) * 7)
    other = Scored("force_limit", BEFORE, (0.01, 10.0, 0.01, 0.01, 10.0, 0.01, 0.01))
    assert separated(best, other)
    assert find_tie([best, other]) is None


def test_segments_that_disagree_are_a_tie():
    best = Scored("viscous_pendulum", BEFORE, (0.1, 0.5, 0.5, 0.1, 1.4, 0.1, 0.1))
    other = Scored("quadratic_pendulum", BEFORE, (0.1, 2.5, 0.1, 0.1, 0.4, 0.1, 0.1))
    assert best.score > other.score + TIE_FLOOR       # better overall, but not in every segment
    assert not separated(best, other)
    tie = find_tie([best, other])
    assert tie["effects"] == ["viscous_pendulum", "quadratic_pendulum"]
    assert tie["noise"] == pytest.approx(noise_of_difference(best, other)) and tie["noise"] > best.score - other.score
    assert "cannot separate" in tie["message"] and "falls several-fold" in tie["separate_by"]


def test_differences_below_the_measurement_noise_are_a_tie():
    best = Scored("x_offset", BEFORE, (0.01,) * 7)
    other = Scored("asymmetric_cart", BEFORE, (0.01, 0.3, 0.01, 0.01, 0.3, 0.01, 0.01))
    assert separated(best, other)                    # 2 % of the error, every segment agreeing
    assert not separated(best, other, floor=0.05)    # but the measurement chain leaves 5 %
    assert "end stops" in find_tie([best, other], floor=0.05)["message"]
    assert not separated(best, Scored("b", BEFORE, (0.01,) * 6 + (0.1,)))   # below TIE_FLOOR


def test_no_tie_without_a_positive_runner_up():
    best = Scored("a", BEFORE, (0.01,) * 7)
    worse = Scored("b", BEFORE, tuple(2 * b for b in BEFORE))
    assert find_tie([best, worse]) is None and find_tie([best]) is None
