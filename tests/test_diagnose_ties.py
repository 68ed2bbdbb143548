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


@pytest.fixture(scope="module")
def crane_swing():
    """20 s of the round F gantry crane's payload swinging freely from 0.6 rad (the trolley free,
    no force), with pivot damping b_phi = 0.01, read by its encoders."""
    from pathlib import Path

    import numpy as np

    from pendc.ident.datagen import encoder_readings
    from pendc.model.modelfile import load_model
    from pendc.sim.measurements import format_csv, parse_measurements
    from pendc.sim.readers import ReadOptions
    from pendc.sim.signals import signals_of
    from pendc.sim.simulator import Simulator

    model = load_model(Path(__file__).parent / "data" / "gantry_crane.toml")
    t = np.arange(20001) * 1e-3
    run = Simulator(model.with_effect("pivot_viscous", {"b_phi": 0.01}), dt=1e-4, method="rk4")(
        t, np.zeros_like(t), x0=(0.0, 0.0, 0.6, 0.0))
    read = encoder_readings(signals_of(model), {"x": run["x"], "phi": run["phi"]})
    text = format_csv({"t": t, "F": np.zeros_like(t), "x": read["x"], "phi": read["phi"]})
    return model, parse_measurements(text, "swing.csv", options=ReadOptions(plant=model, plausible=True))


def test_a_meaningful_free_run_separates_what_the_segments_tied(crane_swing):
    """Round F: pivot damping and pivot dry friction tied on 0.5 s segments (less than half of the
    crane's 1.4 s swing), while their fitted models' free runs differed tenfold: a tie is put to the
    free run where the data make one meaningful."""
    from pendc.ident.ties import free_run_separation
    model, swing = crane_swing
    viscous = _Fitted("pivot_viscous", {"b_phi": 0.0097}, 0.84)
    coulomb = _Fitted("pivot_coulomb", {"tau_c": 0.0054}, 0.64)
    for order in ([viscous, coulomb], [coulomb, viscous]):
        winner, words = free_run_separation(model, [swing], order)
        assert winner == "pivot_viscous" and "times smaller than pivot_coulomb's" in words
    # candidates whose free runs are alike are not separated
    near = _Fitted("pivot_coulomb", {"tau_c": 0.0004}, 0.6)
    assert free_run_separation(model, [swing], [_Fitted("pivot_viscous", {"b_phi": 0.0011}, 0.8), near]) is None


@dataclass(frozen=True)
class _Fitted:
    effect: str
    params: dict
    score: float
