"""Identification of a plant unstable faster than the default horizon, from a record made under
feedback (the private check's round E: a maglev, its magnet's pole at ~57 /s, 17 ms).

The 0.5 s horizon replays the input without the controller, so every restart diverges: diagnose
said 'Most likely missing: x_offset' with x_off pinned at its bound, and fit wrote it. Now
``--horizon`` (diagnose, fit, compare) restarts often enough to follow, a candidate pinned on its
bound never explains the error, and the converter's offset is in the HIL plant that makes the
record (it reads state + offset, as the core does)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cli_capture import run_cli

DITHER_LQR = '''
from pendc.hil.controllers.operating_point_lqr import OperatingPointLqr


class DitherLqr:
    """The operating point's LQR with a +-1.5 V square dither every 0.15 s."""

    def __init__(self, model, period):
        self.inner = OperatingPointLqr(model, period)
        self.mode = "lqr+dither"

    def reset(self):
        self.inner.reset()
        self.k = 0

    def step(self, meas):
        u = self.inner.step(meas)
        self.k += 1
        return u + (1.5 if ((self.k - 1) // 150) % 2 == 0 else -1.5)
'''

TRUE_OFFSET = -0.0005


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    """4 s of the levitated ball under the dithered LQR, its position converter reading 0.5 mm short."""
    import os

    from pendc.cli import main

    folder = tmp_path_factory.mktemp("maglev")
    plain = Path(__file__).parent / "data" / "maglev.toml"
    truth = folder / "maglev_truth.toml"
    truth.write_text(plain.read_text() + f"\n[effects.x_offset]\nx_off = {TRUE_OFFSET}\n")
    (folder / "dither_lqr.py").write_text(DITHER_LQR)
    here = os.getcwd()
    os.chdir(folder)
    try:
        assert main(["hil", "--model", str(truth), "--controller", "dither_lqr:DitherLqr", "--start", "levitated",
                     "--seconds", "4", "--out", "run"]) == 0
    finally:
        os.chdir(here)
    return plain, folder / "run" / "run.csv"


def test_a_short_horizon_names_the_offset_of_a_fast_unstable_plant(record, capsys):
    plain, run = record
    rc, out, err = run_cli(capsys, "diagnose", run, "--model", plain, "--horizon", "0.02",
                           "--effects", "x_offset,air_drag")
    assert rc == 0, err
    assert "0.02 s horizon fit" in out and "Most likely missing: x_offset" in out
    assert "--horizon 0.02 --add x_offset" in out             # the suggested fit keeps the horizon
    fitted = next(line for line in out.splitlines() if line.startswith("1 ") and "x_offset" in line)
    x_off = float(fitted.split("x_off=")[1].split()[0])
    assert x_off == pytest.approx(TRUE_OFFSET, rel=0.1)


def test_the_default_horizon_diverges_and_names_nothing(record, capsys):
    plain, run = record
    rc, out, err = run_cli(capsys, "diagnose", run, "--model", plain, "--effects", "x_offset,air_drag")
    assert rc == 0, err
    assert "leaves these data far behind" in err and "shorter --horizon" in err
    assert "Most likely missing" not in out


def test_fit_takes_the_horizon(record, capsys, tmp_path):
    plain, run = record
    rc, out, err = run_cli(capsys, "fit", run, "--model", plain, "--horizon", "0.02", "--add", "x_offset",
                           "--objective", "horizon", "-o", tmp_path / "fitted.toml")
    assert rc == 0, err
    line = next(line for line in out.splitlines() if line.strip().startswith("x_off"))
    assert float(line.split("=")[1].split()[0]) == pytest.approx(TRUE_OFFSET, rel=0.1)
    assert "0.02 s horizon fit" in out and "--horizon 0.02" in (tmp_path / "fitted.toml").read_text()
    rc, _, err = run_cli(capsys, "fit", run, "--model", plain, "--horizon", "0", "--add", "x_offset",
                         "-o", tmp_path / "bad.toml")
    assert rc == 2 and "--horizon must be a positive number" in err and not (tmp_path / "bad.toml").exists()
