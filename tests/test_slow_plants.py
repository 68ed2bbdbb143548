"""A plant whose time constants are minutes (the private check's round F TCLab: two heated sinks,
93 s): recorded at its own 1 Hz, which the reader took for milliseconds ("sampling slower than
10 Hz cannot record a swing", even with --t-unit s), and diagnosed on 0.5 s segments in which its
sinks move less than one 0.32 K converter code ("Nothing systematic left" with a 10 % heater
dead zone hidden). Now the reader asks ten samples a period of the plant's fastest mode, a given
unit is taken at its word, and the horizon grows until the data move four sensor steps in it.

The record is the TCLab's energy balance integrated here by scipy (solve_ivp), not by pendc,
with the heater's dead zone and the 10-bit converters written out."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from cli_capture import run_cli
from pendc.ident.horizon import DEFAULT_HORIZON, horizon_for
from pendc.model.modelfile import load_model
from pendc.sim.measurements import format_csv

PLANT = Path(__file__).parent / "data" / "tclab1.toml"
DEAD_ZONE = 10.0     # % of heater 1's command that gives no heat
TA, U, M, CP, A, AS, A1, A2, Q2, EPS, SIGMA = 296.15, 10.0, 0.004, 500.0, 1e-3, 2e-4, 0.01, 0.0075, 20.0, 0.9, 5.67e-8


def _heat(q1):
    return max(q1 - DEAD_ZONE, 0.0)


def _rhs(t, y, level):
    t1, t2 = y
    q = level(t)
    between = U * AS * (t2 - t1) + EPS * SIGMA * AS * (t2**4 - t1**4)
    d1 = U * A * (TA - t1) + EPS * SIGMA * A * (TA**4 - t1**4) + between + A1 * _heat(q)
    d2 = U * A * (TA - t2) + EPS * SIGMA * A * (TA**4 - t2**4) - between + A2 * Q2
    return [d1 / (M * CP), d2 / (M * CP)]


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    """12 minutes of 60 s steps of heater 1, sampled at 1 Hz by the 10-bit converters."""
    levels = np.array([20.0, 60.0, 15.0, 80.0, 30.0, 5.0, 70.0, 40.0, 90.0, 12.0, 55.0, 25.0])
    level = lambda t: float(levels[min(int(t // 60.0), len(levels) - 1)])
    t = np.arange(0.0, 720.0, 1.0)
    y = np.empty((2, len(t)))
    y[:, 0] = (TA, TA)
    for k in range(len(levels)):        # piece by piece: the steps are the input's corners
        a, b = 60 * k, min(60 * (k + 1), len(t) - 1)
        sol = solve_ivp(_rhs, (t[a], t[b]), y[:, a], args=(lambda s, v=levels[k]: v,), t_eval=t[a:b + 1],
                        rtol=1e-10, atol=1e-10)
        y[:, a:b + 1] = sol.y
    q = 330.0 / 1024                    # a code of the TMP36 through a 10-bit converter over 223.15-553.15 K
    codes = np.clip(np.floor((y - 223.15) / q), 0, 1023)
    reading = 223.15 + (codes + 0.5) * q
    path = tmp_path_factory.mktemp("tclab") / "tclab_1hz.csv"
    path.write_text(format_csv({"t": t, "Q1": [level(s) for s in t], "T1": reading[0], "T2": reading[1]}))
    return path


def test_the_slow_plants_own_rate_is_read(record, capsys):
    rc, out, err = run_cli(capsys, "compare", record, "--model", PLANT)
    assert rc == 0, err
    assert "looks like milliseconds" not in err


def test_the_horizon_grows_until_the_data_move(record):
    from pendc.sim.measurements import read_measurements
    from pendc.sim.readers import ReadOptions
    from pendc.sim.signals import signals_of

    model = load_model(PLANT)
    data = read_measurements(record, options=ReadOptions(plant=model, plausible=True))
    horizon, why = horizon_for([data], signals_of(model))
    assert horizon > 4.0 and "--horizon sets it" in why
    # a pendulum's record keeps the half second (the shipped SCT data)
    sct = read_measurements(Path(__file__).parents[1] / "data" / "hidden_spring_validation.csv",
                            options=ReadOptions(plausible=True))
    assert horizon_for([sct], signals_of(None)) == (DEFAULT_HORIZON, "")


def test_diagnose_names_the_hidden_dead_zone(record, capsys):
    rc, out, err = run_cli(capsys, "diagnose", record, "--model", PLANT)
    assert rc == 0, err
    assert "the horizon is" in err and "Most likely missing: heater1_deadzone" in out
    fitted = float(out.split("Q1_dz=")[1].split()[0])
    assert fitted == pytest.approx(DEAD_ZONE, rel=0.1)
    assert "encoder" not in out                       # a converter plant's words
