"""Start rates from a segment's own samples (pendc.ident.start_rates): a coarse encoder on a slow
plant whose first counts come while the derivative filter's window is one-sided.

The data come from the equation written out here and scipy's solve_ivp, not from pendc: the
private check's helicopter pitch, reduced to a torsion pendulum on the same encoder.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import pendc
from pendc.ident import start_rates
from pendc.model.modelfile import load_model

TORSION = """
[plant]
name = "torsion_pitch"
core = "torsion_pitch_core"
summary = "a torsion pendulum read by a 2048-line encoder (slow, coarse: a helicopter pitch's kind)"
J = 1.0e-3
K = 1.0e-3

[constants]
J = { unit = "kg*m^2", meaning = "inertia", bounds = [1e-5, 1e-1] }
K = { unit = "N*m/V", meaning = "torque per volt", bounds = [1e-5, 1e-1] }

[coordinates.p]
unit = "rad"
meaning = "pitch"
quantity = "angle"
force = "tau"
rate = { unit = "rad/s", meaning = "pitch rate", training_rate = 1.0 }

[bodies.disk]
inertia = "J"
rotation = "p"

[inputs.u]
unit = "V"
meaning = "drive voltage"
range = [-5.0, 5.0]

[sensors.enc_p]
state = "p"
band = 0.0015339807878856412
lines = 2048
bands_per_rev = 4096

[catalogue.drive]
kind = "drive"
on = "p"
force = "K*u"
name = "tau_drive"
summary = "the motor's torque"

[catalogue.spring]
kind = "spring"
on = "p"
stiffness = "k"
summary = "the torsion wire"
params.k = { unit = "N*m/rad", default = 0.04, bounds = [0.0, 1.0], meaning = "stiffness" }

[catalogue.damping]
kind = "viscous"
on = "p"
coefficient = "b"
summary = "air and wire damping"
evidence = "the residual torque follows the rate"
params.b = { unit = "N*m*s/rad", default = 2e-4, bounds = [0.0, 0.1], meaning = "viscous damping" }

[effects.drive]
[effects.spring]
k = 0.04
[effects.damping]
b = 2e-4
"""

COUNT = 2 * math.pi / 8192


def _steps(seconds: float, rate: float, seed: int) -> tuple:
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * rate) + 1) / rate
    u = np.repeat(rng.uniform(-2.0, 2.0, len(t) // 400 + 1), 400)[:len(t)]
    return t, u


def _torsion_run(path, b: float, seconds: float = 6.0, seed: int = 4, start_rate: float = 0.0) -> str:
    """J p'' = K u - k p - b p' from rest at p = 0 under a step from the first sample (so the
    first counts come while the filter's window is one-sided), p read by the encoder: a CSV."""
    J, K, k = 1.0e-3, 1.0e-3, 0.04
    t, u = _steps(seconds, 1000.0, seed)
    y, p = np.array([0.0, start_rate]), np.empty(len(t))
    p[0] = y[0]
    for i in range(len(t) - 1):
        sol = solve_ivp(lambda _t, s: [s[1], (K * u[i] - k * s[0] - b * s[1]) / J], (t[i], t[i + 1]), y,
                        method="DOP853", rtol=1e-10, atol=1e-12)
        y = sol.y[:, -1]
        p[i + 1] = y[0]
    read = COUNT * np.floor(p / COUNT + 0.5)
    path.write_text("t,u,p\n" + "\n".join(f"{a!r},{v!r},{r!r}" for a, v, r in zip(t.tolist(), u.tolist(), read.tolist())) + "\n")
    return str(path)


@pytest.fixture(scope="module")
def torsion(tmp_path_factory):
    folder = tmp_path_factory.mktemp("torsion")
    (folder / "torsion.toml").write_text(TORSION)
    return str(folder / "torsion.toml"), _torsion_run(folder / "b2e-4.csv", 2e-4), folder


def test_coarse_slow_data_start_from_their_own_samples(torsion, monkeypatch):
    """The model that made the data fits them; the filter's rates alone (the old start) do not."""
    model, data, _ = torsion
    c = pendc.compare(model, data).comparison
    assert c.fit["p"] > 98.0
    monkeypatch.setattr(start_rates, "REFINE_ABOVE", math.inf)
    before = pendc.compare(model, data).comparison
    assert before.fit["p"] < c.fit["p"] - 3.0


def test_fine_data_keep_the_filter_rates(torsion):
    """Rates the filter gives well (a finer sensor) are not refined."""
    from pendc.ident.shooting import ShootingProblem
    from pendc.sim.measurements import read_measurements
    from pendc.sim.readers import ReadOptions

    model, data, _ = torsion
    m = load_model(model)
    coarse = read_measurements(data, options=ReadOptions(plant=m, uniform=True))
    assert ShootingProblem(m, [coarse], []).start_fits[0] is not None
    fine = replace(coarse, resolution={"p": 1e-7})
    assert ShootingProblem(m, [fine], []).start_fits[0] is None


def test_fit_recovers_damping_from_coarse_positions(torsion):
    """The damping that made the data, from positions alone, within 10 % and inside its interval,
    which is narrower (the filter's start rates alone left it +-19 % wide; refined, +-7 %)."""
    model, _, folder = torsion
    data = _torsion_run(folder / "b6e-4.csv", 6e-4, seed=5)
    report = pendc.fit(model, data, free=["b"])
    low, high = report.result.ci95["b"]
    assert report.result.values["b"] == pytest.approx(6e-4, rel=0.10)
    assert low <= 6e-4 <= high
    assert (high - low) / 6e-4 < 0.2
