"""pendc.robust.sensitivity: the ranking finds the parameter that decides failure."""

import numpy as np

from pendc.robust.sensitivity import rank_parameters


def _design(n, seed=0):
    from scipy.stats import qmc
    return qmc.LatinHypercube(3, seed=seed).random(n)


def test_the_parameter_that_decides_failure_ranks_first():
    X = _design(200)
    failed = X[:, 1] > 0.7
    ranking = rank_parameters(["a", "b", "c"], X, failed, None, "worst")
    assert ranking.top == "b" and ranking.outcome.startswith("failure")
    assert ranking.entries[0][1] > 0.5 > max(abs(e[1]) for e in ranking.entries[1:])


def test_when_every_run_passes_the_criterion_figure_is_ranked():
    X = _design(60, seed=1)
    figure = 0.01 + 0.1 * X[:, 2] ** 2
    ranking = rank_parameters(["a", "b", "c"], X, np.zeros(60, bool), figure, "worst_last_3s_rad")
    assert ranking.top == "c" and ranking.outcome == "worst_last_3s_rad (every run passed)"


def test_no_ranking_without_enough_runs_or_variation():
    X = _design(7)
    assert rank_parameters(["a", "b", "c"], X, X[:, 0] > 0.5, None, "w") is None
    X = _design(20)
    assert rank_parameters(["a", "b", "c"], X, np.zeros(20, bool), None, "w") is None
    assert rank_parameters(["a", "b", "c"], X, np.zeros(20, bool), np.ones(20), "w") is None


def test_a_handful_of_failures_ranks_the_figure_instead():
    X = _design(100, seed=2)
    figure = 0.5 + X[:, 0]                    # the figure follows a, the three failures happen along c
    failed = np.zeros(100, bool)
    failed[np.argsort(X[:, 2])[-3:]] = True
    ranking = rank_parameters(["a", "b", "c"], X, failed, figure, "margin")
    assert ranking.top == "a" and ranking.outcome == "margin (3 of 100 runs failed: too few to rank failure)"
