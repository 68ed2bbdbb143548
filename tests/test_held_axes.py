"""A file whose cart never moves is read as the experiment that holds the cart (issue 22): the
simulation holds it, and no effect that acts through the cart is a candidate.

The file is the shipped free swing (data/unknown_pendulum_swing.csv) without its
``# experiment: cart_held`` line, as another lab's recording would come."""

from pathlib import Path

import numpy as np
import pytest

from pendc import load_model
from pendc.api import diagnose
from pendc.sim.experiment_axes import held_experiment_of
from pendc.sim.measurements import parse_measurements
from pendc.sim.read_options import ReadOptions

SWING = Path(__file__).resolve().parents[1] / "data" / "unknown_pendulum_swing.csv"


def without_experiment(seconds: float | None = None) -> str:
    lines = [s for s in SWING.read_text().splitlines() if not s.startswith("# experiment")]
    if seconds is not None:
        head = [s for s in lines if s.startswith("#")]
        rows = [s for s in lines if not s.startswith("#")]
        lines = head + rows[:1] + [r for r in rows[1:] if float(r.split(",")[0]) <= seconds]
    return "\n".join(lines) + "\n"


def test_a_still_cart_is_read_as_held_with_one_note():
    data = parse_measurements(without_experiment(5.0), source="swing.csv")
    assert data.experiment == "cart_held"
    held = [n for n in data.notes if "read as experiment" in n]
    assert held == ["swing.csv: x does not move: read as experiment cart_held "
                    "(give --experiment free to compare it moving)"]


def test_a_declared_experiment_is_kept():
    data = parse_measurements(without_experiment(5.0), source="swing.csv", options=ReadOptions(experiment="free"))
    assert data.experiment == "free" and not any("read as experiment" in n for n in data.notes)


def test_moving_or_wholly_still_data_stay_free():
    model = load_model()
    t = np.arange(0, 1, 1e-3)
    moving = {"x": 0.1 * np.sin(t), "theta": 0.3 * np.cos(3 * t)}
    assert held_experiment_of(model, moving, {"x": 1e-5, "theta": 1e-3}) is None
    still = {"x": np.zeros_like(t), "theta": np.zeros_like(t)}
    assert held_experiment_of(model, still, {"x": 1e-5, "theta": 1e-3}) is None     # no experiment holds both
    assert held_experiment_of(model, {**moving, "x": np.full_like(t, 0.2)}, {"x": 1e-5}) == "cart_held"


@pytest.mark.parametrize("seconds", [12.0])
def test_no_cart_effect_is_a_candidate_on_a_clamped_cart_file(tmp_path, seconds):
    path = tmp_path / "clamped.csv"
    path.write_text(without_experiment(seconds))
    model = load_model()
    through_cart = {n for n, e in model.definition.catalogue.items() if e.acts_on in ("cart", "x")}
    assert {"cart_spring", "viscous_cart", "drive_deadzone"} <= through_cart
    result = diagnose(model, str(path))
    ranked = [c.effect for c in result.candidates]
    assert ranked and not set(ranked) & through_cart, ranked
