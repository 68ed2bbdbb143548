"""A plant file's ``[hardware] dt`` is the step of every command that steps the plant as the core
does: simulate (float and --fixed), hil on the float and golden plants, robust's plants. Before,
only the build read it: simulate's float run and hil's float plant took 1 us, and hil --plant
golden failed ("the core was built for a step of 5e-07 s, not 1e-06 s")."""

from __future__ import annotations

import numpy as np
import pytest

from cli_capture import run_cli
from pendc.model.modelfile import parse_model
from pendc.sim.measurements import read_measurements

DT = 5e-7
# a first-order RC filter in state form: fast (100 us), one converter, an operating point
RC = f"""
[plant]
name = "rc"
core = "rc_core"
summary = "RC low-pass filter"
tau = 1e-4

[constants]
tau = {{ unit = "s", meaning = "time constant", bounds = [1e-6, 1.0] }}

[states.v]
unit = "V"
meaning = "capacitor voltage"
derivative = "(u - v)/tau"
initial = 0.0
range = [-1.0, 11.0]

[inputs.u]
unit = "V"
meaning = "source voltage"
range = [0.0, 10.0]
neutral = 5.0

[sensors.adc_v]
kind = "adc"
state = "v"
bits = 12
range = [-1.0, 11.0]

[operating_points]
half = {{ v = "5.0" }}

[hardware]
dt = {DT!r}
"""


@pytest.fixture(scope="module")
def plant_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rc")
    path = folder / "rc.toml"
    path.write_text(RC, encoding="utf-8")
    t = np.arange(0, 5e-4 + 1e-9, 1e-5)
    u = np.where(t < 2e-4, 0.0, 8.0)
    stim = folder / "steps.csv"
    stim.write_text("t,u\n" + "".join(f"{a:.6f},{b}\n" for a, b in zip(t, u)), encoding="utf-8")
    return path, stim


def header_dt(path) -> str:
    return next(ln for ln in path.read_text().splitlines() if ln.startswith("# dt:")).split(":")[1].strip()


def test_simulate_float_steps_as_the_core(plant_file, tmp_path, capsys):
    model_path, stim = plant_file
    out = tmp_path / "float.csv"
    rc, _, err = run_cli(capsys, "simulate", "--model", model_path, "--input", stim, "-o", out)
    assert rc == 0, err
    assert header_dt(out) == repr(DT)
    from pendc.sim.simulator import Simulator

    model = parse_model(RC)
    data = read_measurements(stim, required=("t", "u"))
    expected = Simulator(model, dt=DT)(data.t, data.u).columns()["v"]
    assert np.allclose(read_measurements(out, required=("t", "v")).v, expected, rtol=0, atol=1e-9)
    # an explicit --dt still wins for the float run
    rc, _, err = run_cli(capsys, "simulate", "--model", model_path, "--input", stim, "-o", out, "--dt", "1e-6")
    assert rc == 0 and header_dt(out) == repr(1e-6)


def test_simulate_fixed_refuses_another_step_before_building(plant_file, tmp_path, capsys):
    model_path, stim = plant_file
    rc, _, err = run_cli(capsys, "simulate", "--model", model_path, "--input", stim, "--fixed", "--dt", "1e-6",
                         "-o", tmp_path / "x.csv")
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert "every 5e-07 s" in err and "drop --dt 1e-06" in err and "compiling" not in err


def test_hil_runs_every_plant_at_the_files_step(plant_file, tmp_path, capsys, monkeypatch):
    from pendc.hil import loop

    seen = []
    original = loop.run_closed_loop

    def spy(plant, *args, **kwargs):
        seen.append(plant.dt)
        return original(plant, *args, **kwargs)

    monkeypatch.setattr(loop, "run_closed_loop", spy)
    model_path, _ = plant_file
    for kind in ("float", "golden"):
        rc, out, err = run_cli(capsys, "hil", "--model", model_path, "--controller", "lqr", "--plant", kind,
                               "--start", "half", "--seconds", "0.002", "--period", "1e-5",
                               "--out", tmp_path / kind)
        assert rc == 0, err
        assert "from operating point half" in out
    assert seen == [DT, DT]


def test_robust_plants_step_as_the_core(plant_file):
    from pendc.model.model_writer import dumps_model
    from pendc.robust.golden_retype import RetypeTemplate
    from pendc.robust.scenario_runner import SweepSpec, WorkerCache, make_sampled_plant

    text = dumps_model(parse_model(RC))
    spec = SweepSpec(model_text=text, design_text=text, model_source="rc", design_source="rc")
    assert make_sampled_plant(spec, {"tau": 1.1e-4}, WorkerCache()).dt == DT
    # the golden sweep's template: its build (cached by the hil test) checked against the file's step
    template = RetypeTemplate.of(parse_model(RC))
    assert template.build.options.dt == DT and template.plant({"tau": 1.1e-4}).dt == DT


@pytest.mark.parametrize("dt", ["0.0", "-1e-6", "nan", "0.1"])
def test_a_step_that_is_no_step_is_one_line(dt, tmp_path, capsys):
    """Round I: dt = 0 was a ZeroDivisionError traceback in plant check, -1e-6 and nan passed it."""
    path = tmp_path / "rc.toml"
    path.write_text(RC.replace(f"dt = {DT}", f"dt = {dt}"), encoding="utf-8")
    rc, out, err = run_cli(capsys, "plant", "check", str(path))
    assert rc == 2 and "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert f"{path}: [hardware] dt must be a step in (0, 0.01] s, got" in err


def test_an_operating_point_a_converter_cannot_read_is_one_line(tmp_path, capsys):
    """Round I: a boost's point at 90 V beyond its converter's 64 V passed, and the LQR, reading the
    clipped code, missed the point by 26 V without a word."""
    path = tmp_path / "rc.toml"
    path.write_text(RC.replace("bits = 12\nrange = [-1.0, 11.0]", "bits = 12\nrange = [6.0, 11.0]"), encoding="utf-8")
    rc, out, err = run_cli(capsys, "hil", "--model", str(path), "--controller", "lqr", "--plant", "float",
                           "--seconds", "0.01", "--out", str(tmp_path / "out"))
    assert rc == 2 and len(err.strip().splitlines()) == 1, err
    assert ("operating point 'half' of plant 'rc': v = 5 V lies outside the range of its converter adc_v, "
            "[6, 11] V: it reads clipped there" in err)
    # plant check says it before any run (round I, F6), of the start state too; a file whose states
    # all lie within their converters' and their own ranges gets no such note
    rc, out, err = run_cli(capsys, "plant", "check", str(path))
    assert rc == 0, err
    notes = [ln for ln in out.splitlines() if ln.startswith("note: ")]
    assert notes == [
        "note: the start state: v = 0 V lies outside the range of its converter adc_v, [6, 11] V: it reads "
        "clipped there until the state comes back within it",
        "note: operating point 'half': v = 5 V lies outside the range of its converter adc_v, [6, 11] V: it "
        "reads clipped there, so pendc hil's LQR refuses the point"], out
    path.write_text(RC.replace('half = { v = "5.0" }', 'half = { v = "12.0" }'), encoding="utf-8")
    rc, out, err = run_cli(capsys, "plant", "check", str(path))
    assert [ln for ln in out.splitlines() if ln.startswith("note: ")] == [
        "note: operating point 'half': v = 12 V lies outside the range of its converter adc_v, [-1, 11] V: it "
        "reads clipped there, so pendc hil's LQR refuses the point",
        "note: operating point 'half': v = 12 V lies outside its range [-1, 11] V, which the core's formats are "
        "sized for: widen states.v.range"], out
    path.write_text(RC, encoding="utf-8")
    rc, out, err = run_cli(capsys, "plant", "check", str(path))
    assert rc == 0 and "note: " not in out, out


def test_make_sim_runs_a_core_that_steps_a_millisecond(tmp_path):
    """Round J (F4): `make sim MODEL=...` refused a CSTR with [hardware] dt = 1 ms (and 0.1 ms,
    10 us): the testbench sampled its stimuli as if every core stepped 1 us (a 1 MHz multisine, a
    long run's input held 1000 steps). They are now sampled at the core's own step: a sample a
    millisecond, every step at 1 ms."""
    import re
    import shutil
    import subprocess
    from pathlib import Path

    if shutil.which("make") is None or shutil.which("iverilog") is None:
        pytest.skip("no make or no Icarus")
    repo = Path(__file__).resolve().parents[1]
    slow = tmp_path / "rc_slow.toml"           # a 50 ms RC filter: Euler at 1 ms is stable
    slow.write_text(RC.replace("tau = 1e-4", "tau = 0.05").replace(f"dt = {DT!r}", "dt = 0.001"), encoding="utf-8")
    assert "dt = 0.001" in slow.read_text()
    done = subprocess.run(["make", "sim", f"MODEL={slow}", "SIM=icarus", "TB_ARGS=--suite core"], cwd=repo,
                          capture_output=True, text=True, timeout=900)
    out = done.stdout + done.stderr
    assert done.returncode == 0, out[-3000:]
    found = re.search(r"\[icarus\] core: (\d+)/(\d+) passed", out)
    assert found and found.group(1) == found.group(2) and int(found.group(1)) >= 12, out[-3000:]
    assert "every-step windows of 999 steps" in out          # a 2 s multisine at a sample a step
    shutil.rmtree(repo / "sim_build" / "rc_slow", ignore_errors=True)
