"""Multiple-shooting residual: zero for the true model on noiseless data, segment handling."""

import numpy as np
import pytest

from pendc import Simulator, load_model
from pendc.errors import PendcError
from pendc.ident.shooting import ShootingProblem, estimate_velocities, horizon_fit, prepare
from pendc.sim.measurements import format_csv, parse_measurements
from pendc.sim.stimuli import chirp


@pytest.fixture(scope="module")
def clean():
    model = load_model()
    t, u = chirp(duration=2.0)
    res = Simulator(model, dt=1e-4, method="rk4")(t, u)
    cols = {"t": t, "u": u, "x": res["x"], "theta": res["theta"], "dx": res["dx"], "dtheta": res["dtheta"]}
    return model, parse_measurements(format_csv(cols))


def test_true_model_on_its_own_data_has_zero_residual(clean):
    model, data = clean
    p = ShootingProblem(model, [data], [], dt=1e-4)
    assert p.cost(np.array([])) < 1e-16
    assert horizon_fit(model, [data])["x"] == pytest.approx(100.0, abs=1e-6)


def test_a_wrong_parameter_costs_and_free_parameters_map_to_the_kernel(clean):
    model, data = clean
    p = ShootingProblem(model, [data], ["b_x"], dt=1e-4)
    assert p.start_values()[0] == model.parameter_values()["b_x"]
    assert p.cost(np.array([700.0])) > 1e-6 > p.cost(p.start_values())


def test_segments_and_held_out_halves(clean):
    model, data = clean
    rec = prepare(data, 0.5)
    assert rec.bounds[0] == (0, 500) and all(b - a >= 2 for a, b in rec.bounds)
    even = ShootingProblem(model, [data], [], subset="even")
    odd = ShootingProblem(model, [data], [], subset="odd")
    full = ShootingProblem(model, [data], [])
    assert even.size + odd.size == full.size
    assert sum(b - a for a, b in full.segment_blocks()) == full.size


def test_velocity_estimate_of_a_quantised_ramp():
    t = np.arange(2000) * 1e-3
    x = np.floor(0.1 * t / 2.5e-6) * 2.5e-6
    assert np.median(estimate_velocities(t, x)) == pytest.approx(0.1, rel=1e-3)


def test_unknown_parameter_is_a_clear_error(clean):
    model, data = clean
    with pytest.raises(PendcError, match="unknown parameter"):
        ShootingProblem(model, [data], ["k_c"])
