"""Hidden-effect data: deterministic, degraded like the rig, and the shipped files are current."""

from pathlib import Path

import numpy as np

from pendc import load_model
from pendc.ident.datagen import degrade_input, identification_experiment, make_dataset
from demo_data import closed_loop_swing_up, demo_datasets
from pendc.sim.measurements import format_csv

DATA = Path(__file__).resolve().parents[1] / "data"


def test_experiment_and_data_are_quantised_and_deterministic():
    t, u = identification_experiment()
    assert t[-1] == 20.0 and np.all((u >= 0) & (u <= 10))
    a, b = make_dataset(load_model()), make_dataset(load_model())
    assert all(np.array_equal(a[k], b[k]) for k in a)
    for sensor in load_model().interface.sensors:          # 2.5 um and 0.314 mrad, from the thesis
        counts = a[sensor.state] / sensor.resolution
        assert np.allclose(counts, np.round(counts), atol=1e-6)
    assert np.array_equal(a["u"], u)                              # the log holds the command


def test_the_dac_and_noise_change_what_the_plant_sees():
    u = np.full(1000, 5.2646)
    seen = degrade_input(u, load_model().interface.input.range)
    assert 0.001 < np.std(seen - u) < 0.01


def test_closed_loop_swing_up_swings_high_and_stays_on_the_track():
    c = closed_loop_swing_up(load_model(), duration=6.0)
    assert np.max(np.abs(c["theta"])) > 2.5
    assert np.max(np.abs(c["x"])) < 0.375


def test_shipped_files_are_what_the_generator_makes():
    made = demo_datasets(load_model())
    assert sorted(made) == sorted(p.stem for p in DATA.glob("*.csv"))      # every shipped file, each made again
    for name, (columns, description, *extra) in made.items():
        meta = {"description": description, "generator": "data/generate.py", **(extra[0] if extra else {})}
        assert (DATA / f"{name}.csv").read_text() == format_csv(columns, meta=meta), name


def test_free_swing_holds_the_cart_and_the_unknown_pendulum_differs():
    from demo_data import unknown_pendulum
    from pendc.ident.datagen import free_swing

    base = load_model()
    other = unknown_pendulum(base)
    swing = free_swing(other, duration=2.0)
    assert np.all(swing["x"] == 0.0) and np.all(swing["u"] == base.interface.input.neutral)   # idle: the neutral input
    assert swing["theta"][0] == 0.8 and np.min(swing["theta"]) < -0.7
    assert other.plant["m"] == base.plant["m"] * 1.05 and other.effects["viscous_pendulum"]["b_theta"] == 0.0025
