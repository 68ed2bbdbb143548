"""pendc.model.modes: what forward Euler at the core's step does to the plant's fastest mode."""

import math

import pytest

from pendc.model.modes import euler_growth, euler_unstable


def test_a_step_that_makes_a_decaying_mode_grow_is_called_unstable():
    """Round I: a 733 Hz mode decaying at 294 /s under dt = 1 ms (|1 + lambda dt| = 4.7) was said to
    'ring longer'; the largest stable step is -2 Re(lambda) / |lambda|^2."""
    lam = complex(-294.0, 2 * math.pi * 733.4)
    words = euler_unstable(lam, 1e-3)
    assert words is not None and "unstable" in words and "|1 + lambda dt| = 4.66 > 1" in words
    stable = -2 * lam.real / abs(lam) ** 2
    assert f"below {stable:.3g} s" in words
    assert euler_unstable(lam, 0.99 * stable) is None and euler_unstable(lam, 1.01 * stable) is not None
    assert euler_growth(lam, 0.99 * stable) < -lam.real < euler_growth(lam, 1.01 * stable)   # the same edge
    assert euler_unstable(complex(5.0, 0.0), 1.0) is None          # a growing mode is the plant's own


@pytest.mark.parametrize("dt", [1e-6, 1e-5])
def test_a_small_step_is_stable(dt):
    assert euler_unstable(complex(-294.0, 2 * math.pi * 733.4), dt) is None
