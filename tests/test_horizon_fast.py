"""The automatic horizon on a fast plant's short record (the blind check's buck converter: a 0.3 s
record of a 3.4 kHz plant is one 0.5 s segment; diagnose named the missing offset anyway and
suggested a fit that refused it, "only 1 independent 0.5 s segment(s)"). Now the horizon shortens
while a segment still spans ten time constants of the plant's fastest mode and the data move, the
suggested fit carries it, and fit's refusal names a horizon that gives enough segments.

The record is the averaged buck's linear equations solved exactly under a zero-order hold
(scipy.linalg.expm), not by pendc, read by 12-bit converters with a 50 mV offset on v_C."""

from __future__ import annotations

import shlex

import numpy as np
import pytest
from scipy.linalg import expm

from buck_plant import FAST, buck_toml
from cli_capture import run_cli
from pendc.ident.horizon import DEFAULT_HORIZON, MIN_SEGMENTS, horizon_for, segment_count
from pendc.model.modelfile import load_model
from pendc.sim.measurements import format_csv, read_measurements
from pendc.sim.readers import ReadOptions
from pendc.sim.signals import signals_of

SLOW = dict(L=22e-2, C=1e-1)       # the same circuit a thousand times slower: 0.47 s
OFFSET = 0.05                      # V, hidden on the v_C converter (10 codes)
RATE = 100e3                       # Hz
SECONDS = 0.1


def write_buck_run(folder, offset: float = OFFSET):
    """The buck's model file (fast), and 0.1 s at 100 kHz of random 1-5 ms duty steps about 0.42
    with ``offset`` (V) on the v_C converter: ``(model, data)`` paths."""
    model = folder / "buck.toml"
    model.write_text(buck_toml(**FAST))
    vg, L, C, rl, ro = 12.0, FAST["L"], FAST["C"], 0.02, 2.5
    A = np.array([[-rl / L, -1 / L], [1 / C, -1 / (ro * C)]])
    B = np.array([vg / L, 0.0])
    h = 1.0 / RATE
    M = expm(np.block([[A, B[:, None]], [np.zeros((1, 3))]]) * h)
    Ad, Bd = M[:2, :2], M[:2, 2]
    rng = np.random.default_rng(3)
    n = int(round(SECONDS * RATE))
    d = np.empty(n)
    k = 0
    while k < n:
        hold = int(rng.integers(100, 500))
        d[k:k + hold] = 0.42 + rng.uniform(-0.05, 0.05)
        k += hold
    x = np.empty((n, 2))
    x[0] = (2.0, 5.0)                  # the equilibrium at d = 0.42
    for i in range(n - 1):
        x[i + 1] = Ad @ x[i] + Bd * d[i]

    def adc(y, lo, hi):                # a 12-bit converter: the middle of the code the value falls in
        q = (hi - lo) / 4096
        return lo + (np.clip(np.floor((y - lo) / q), 0, 4095) + 0.5) * q

    data = folder / "buck_run.csv"
    data.write_text(format_csv({"t": np.arange(n) * h, "d": d, "i_L": adc(x[:, 0], -10.0, 30.0),
                                "v_C": adc(x[:, 1] + offset, 0.0, 20.0)}))
    return model, data


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    return write_buck_run(tmp_path_factory.mktemp("buck"))


def _read(model, data):
    return read_measurements(str(data), options=ReadOptions(plant=model, plausible=True))


def test_a_fast_plants_short_record_gets_a_shorter_horizon(files, tmp_path):
    model_path, data = files
    model = load_model(model_path)
    record = _read(model, data)
    assert segment_count([record], DEFAULT_HORIZON) == 1
    horizon, why = horizon_for([record], signals_of(model), model)
    assert horizon == 0.01 and segment_count([record], horizon) >= MIN_SEGMENTS
    assert "3407 Hz" in why and "--horizon sets it" in why
    # the same record with a plant a thousand times slower: ten of its time constants (0.47 s)
    # do not fit in a shorter segment, so the half second stays
    slow = tmp_path / "slow.toml"
    slow.write_text(buck_toml(**SLOW))
    slow_model = load_model(slow)
    assert horizon_for([record], signals_of(slow_model), slow_model) == (DEFAULT_HORIZON, "")
    assert horizon_for([record], signals_of(model)) == (DEFAULT_HORIZON, "")    # no model: no plant to judge


def test_diagnose_suggests_a_fit_that_works_as_typed(files, capsys, tmp_path):
    model, data = files
    rc, out, err = run_cli(capsys, "diagnose", data, "--model", model)
    assert rc == 0, err
    assert "the horizon is 0.01 s, not 0.5 s" in err
    assert "Most likely missing: v_offset" in out
    command = next(line for line in out.splitlines() if line.startswith("Next: pendc fit "))
    assert " --horizon 0.01 " in command
    argv = shlex.split(command[len("Next: pendc "):].replace("NEW.toml", str(tmp_path / "new.toml")))
    rc, out, err = run_cli(capsys, *argv, "--objective", "horizon")
    assert rc == 0, err
    fitted = next(line for line in out.splitlines() if line.strip().startswith("v_os"))
    assert float(fitted.split("=")[1].split()[0]) == pytest.approx(OFFSET, rel=0.05)


def test_fits_refusal_names_a_horizon_that_gives_enough_segments(files, capsys, tmp_path):
    model, data = files
    rc, _, err = run_cli(capsys, "fit", data, "--model", model, "--horizon", "0.5", "--add", "v_offset",
                         "--objective", "horizon", "-o", tmp_path / "new.toml")
    assert rc == 2 and "only 1 independent 0.5 s segment(s)" in err
    assert "--horizon 0.01 gives 10" in err and not (tmp_path / "new.toml").exists()
