"""Multiple-shooting residual: zero for the true model on noiseless data, segment handling."""

import numpy as np
import pytest

from pendc import Simulator, load_model
from pendc.errors import PendcError
from pendc.ident.shooting import ShootingProblem, estimate_velocities, horizon_fit, prepare
from pendc.sim.measurements import format_csv, parse_measurements
from plants import chirp


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


def _run(x, theta, name="run", u=None, **attrs):
    t = np.arange(x.size) * 1e-3
    u = np.full(x.size, 5.264616) if u is None else u
    data = parse_measurements(format_csv({"t": t, "u": u, "x": x, "theta": theta}), source=name)
    for k, v in attrs.items():
        object.__setattr__(data, k, v)
    return data


def test_outputs_are_scaled_by_spread_or_resolution_and_held_ones_dropped():
    from pendc.ident.outputs import plan_outputs, resolution_of
    from plants import THETA_COUNT, X_COUNT

    n = 3000
    swing = np.round(0.5 * np.cos(2 * np.pi * np.arange(n) / 900.0) / THETA_COUNT) * THETA_COUNT
    creep = np.where(np.arange(n) > 1500, X_COUNT, 0.0)          # one count of cart creep: held
    plan = plan_outputs([_run(creep, swing)])
    assert plan.outputs == (("theta",),) and set(plan.scales) == {"theta"}
    assert any("x does not move" in note for note in plan.notes)
    assert resolution_of(_run(creep, swing), "theta") == pytest.approx(THETA_COUNT)
    # a few counts of x motion are compared, but never scaled below the resolution
    wiggle = X_COUNT * (np.arange(n) % 4)
    plan = plan_outputs([_run(wiggle, swing)])
    assert plan.outputs == (("x", "theta"),) and plan.scales["x"] >= X_COUNT
    # a missing column and an experiment without x leave x out; the user may ask for theta only
    assert plan_outputs([_run(wiggle, swing, missing=("x",))]).outputs == (("theta",),)
    assert plan_outputs([_run(wiggle, swing, experiment="cart_held")]).outputs == (("theta",),)
    assert plan_outputs([_run(wiggle, swing)], ("theta",)).outputs == (("theta",),)
    # a resolution given with the data wins over the estimate; unquantised data get the encoder's
    given = _run(wiggle, swing, resolution={"theta": 1e-3})
    assert resolution_of(given, "theta") == 1e-3
    smooth = _run(wiggle, 0.5 * np.cos(2 * np.pi * np.arange(n) / 900.0))
    # (the encoder's count as the plant interface gives it)
    assert resolution_of(smooth, "theta") == pytest.approx(THETA_COUNT)


def test_nothing_to_compare_and_bad_output_names_are_clear_errors():
    from pendc.ident.outputs import parse_outputs

    flat = _run(np.zeros(500), np.zeros(500), name="flat.csv")
    with pytest.raises(PendcError, match="flat.csv: no output left to compare"):
        ShootingProblem(load_model(), [flat], [])
    with pytest.raises(PendcError, match="--outputs takes x, theta"):
        parse_outputs("phi")
    assert parse_outputs("theta") == ("theta",) and parse_outputs(None) is None


def test_sensor_offset_is_part_of_the_residual(clean):
    model, data = clean
    shifted = _run(np.asarray(data.column("x")) + 0.01, np.asarray(data.column("theta")) - 0.02, u=data.u)
    with_offsets = model.with_effect("x_offset", {"x_off": 0.01}).with_effect("theta_offset", {"theta_off": -0.02})
    p = ShootingProblem(with_offsets, [shifted], ["x_off", "theta_off"], dt=1e-4)
    assert p.cost(np.array([0.01, -0.02])) < 1e-4 < 1.0 < p.cost(np.array([0.0, 0.0]))
