"""The quick cocotb profile's runs from a deposited golden state (tb/test_core.py), on a plant
nobody at pendc wrote: a ball on a wheel (tests/data/ball_on_wheel.toml, written from
docs/plant_files.md alone) with an encoder on the wheel and a converter on the ball.

Its quick converter test starts deep in the chirp, where the wheel's encoder has counted 974:
the deposit moves both encoder lines at once (974 = 2 mod 4), which the testbench's decoders
read as a quadrature error unless they take the golden count there first (found by that
session: Icarus failed converters_code, Verilator, which runs from reset, passed).
"""

from __future__ import annotations

import pickle
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PLANT = Path(__file__).parent / "data" / "ball_on_wheel.toml"


def test_converter_and_encoder_tests_from_a_deposited_state(tmp_path):
    if shutil.which("iverilog") is None:
        pytest.skip("no Icarus")
    work = tmp_path / "work"
    done = subprocess.run([sys.executable, str(REPO / "tb" / "run.py"), "--sim", "icarus", "--suite", "core",
                           "-k", "converters_code,encoders_decode", "--model", str(PLANT), "--work", str(work)],
                          cwd=REPO, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0 and re.search(r"\[icarus\] core: 2/2 passed", done.stdout), \
        (done.stdout + done.stderr)[-3000:]
    with open(work / "vectors.pickle", "rb") as f:
        chirp = pickle.load(f)["long"]["chirp"]
    at = chirp.get("codes_at", chirp["mid"])
    assert at > 0 and int(chirp["cnt"][at][0]) % 4 == 2          # the deposit jumps both lines
    log = (work / "sim" / "icarus_core" / "test.log").read_text(encoding="utf-8")
    assert "test_core.converters_code passed" in log and "test_core.encoders_decode passed" in log
    assert re.search(r"adc_theta: \d+ different codes", log), log[-2000:]
