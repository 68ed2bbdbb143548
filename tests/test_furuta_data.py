"""The independent Furuta data generator (tests/independent_furuta.py) against pendc: its
hand-written equations, scipy integration and stick-slip friction agree with pendc's model and
simulator, its files read back through pendc's measurement reader, and a hidden dry friction
on the arm shows in the data (what the identification story needs)."""

import sys
from pathlib import Path

import numpy as np
import pytest

import pendc

sys.path.insert(0, str(Path(__file__).resolve().parent))
import independent_furuta as gen  # noqa: E402

QUBE = Path(__file__).resolve().parents[1] / "models" / "furuta_qube.toml"
ANGLES = ("phi_r", "alpha_p")


@pytest.fixture(scope="module")
def qube():
    return pendc.load_model(QUBE)


@pytest.fixture(scope="module")
def stimulus():
    return gen.stimulus(seconds=1.0, seed=4)


def test_the_generators_figures_are_the_shipped_models(qube):
    values = qube.parameter_values()
    assert {k: values[k] for k in gen.QUBE} == pytest.approx(gen.QUBE, rel=1e-7)


def _misfit(res, run) -> dict:
    return {q: float(np.max(np.abs(res[q] - run[f"true_{q}"]))) for q in ANGLES} | \
           {f"d{q}": float(np.max(np.abs(res[f"d{q}"] - run[f"d{q}"]))) for q in ANGLES}


def test_pendcs_simulator_follows_the_independent_integration(qube, stimulus):
    t, u = stimulus
    run = gen.simulate(t, u, quantize_angles=False)
    res = pendc.Simulator(qube, dt=1e-5, method="rk4")(t, u)
    err = _misfit(res, run)
    assert max(err.values()) < 1e-6, err
    assert np.ptp(run["true_phi_r"]) > 1.0 and np.ptp(run["true_alpha_p"]) > 0.3     # it moved


def test_a_hidden_dry_friction_shows_and_the_catalogue_effect_explains_it(qube, stimulus):
    """tau_r = 3 mN*m on the arm: the generator's stick-slip and pendc's coulomb_arm (sgn, 1 us
    Euler) agree to a few microradians; the shipped model without it is off by far more than a
    count."""
    t, u = stimulus
    run = gen.simulate(t, u, {"tau_r": 0.003}, quantize_angles=False)
    assert np.count_nonzero(run["dphi_r"] == 0.0) > 10                     # the arm did stick
    with_effect = pendc.Simulator(qube.with_effect("coulomb_arm", {"tau_r": 0.003}), dt=1e-6)(t, u)
    err = _misfit(with_effect, run)
    assert err["phi_r"] < 1e-4 and err["alpha_p"] < 1e-4, err
    without = _misfit(pendc.Simulator(qube, dt=1e-5, method="rk4")(t, u), run)
    assert without["phi_r"] > 50 * gen.RESOLUTION, without


def test_encoders_read_whole_counts_from_the_start(stimulus):
    t, u = stimulus
    run = gen.simulate(t, u, y0=(0.5, 0.0, 0.0, 0.0))
    for q in ANGLES:
        counts = (run[q] - run[f"true_{q}"][0]) / gen.RESOLUTION
        assert np.allclose(counts, np.round(counts), atol=1e-6)
        lag = run[f"true_{q}"] - run[q]
        assert np.all(lag >= -1e-12) and np.all(lag < gen.RESOLUTION)
    assert gen.RESOLUTION == pytest.approx(0.00307, rel=1e-3)               # the user manual's count


def test_files_read_back_through_pendcs_reader(qube, tmp_path):
    from pendc.sim.measurements import read_measurements
    from pendc.sim.readers import ReadOptions

    t, u = gen.stimulus(seconds=0.3, seed=2)
    run = gen.simulate(t, u, {"alpha_p_off": 0.05})
    path = tmp_path / "hidden_offset.csv"
    gen.write_csv(path, run, hidden="alpha_p_off=0.05")
    data = read_measurements(path, options=ReadOptions(plant=qube))
    assert np.array_equal(data.t, run["t"]) and np.array_equal(data.u, run["u"])
    for q in ANGLES:
        assert np.array_equal(data.column(q), run[q])
    assert data.meta.get("hidden") == "alpha_p_off=0.05"
    assert gen.main([str(tmp_path / "cli.csv"), "--seconds", "0.05", "--tau-r", "0.002"]) == 0
    assert "# hidden: tau_r=0.002" in (tmp_path / "cli.csv").read_text()
