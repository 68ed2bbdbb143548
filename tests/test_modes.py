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


def test_build_and_simulate_name_the_unstable_step_not_ranges_or_square_roots(tmp_path, capsys):
    """Round I (F3): at an Euler-unstable [hardware] dt, build said "raise margin_bits" and an
    Euler simulation "a square root of a state that went below zero?": neither can help. Both
    now say the step is unstable for the fastest mode, and below which dt it is stable."""
    from buck_plant import buck_toml
    from cli_capture import run_cli

    plant = tmp_path / "buck.toml"
    plant.write_text(buck_toml() + "\n[hardware]\ndt = 2e-4\n", encoding="utf-8")
    drive = tmp_path / "steps.csv"
    drive.write_text("t,d\n" + "".join(f"{k * 2e-4:.4f},{0.3 if k < 100 else 0.5}\n" for k in range(500)))
    rc, _, err = run_cli(capsys, "build", "--model", plant, "-o", tmp_path / "hdl")
    assert rc == 2 and err.count("\n") <= 2, err
    last = err.strip().splitlines()[-1]
    assert "[hardware] dt: the plant's fastest mode (3" in last and "forward Euler at 0.0002 s is unstable" in last
    assert "margin_bits" not in err and not (tmp_path / "hdl").exists()
    rc, _, err = run_cli(capsys, "simulate", "--model", plant, "--input", drive, "-o", tmp_path / "o.csv")
    assert rc == 2 and "simulation diverged" in err and "forward Euler at 0.0002 s is unstable" in err, err
    assert "sqrt" not in err and not (tmp_path / "o.csv").exists()
