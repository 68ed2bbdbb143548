"""Issue 9 point 1: the hardware model survives what controllers do to it.

A minute of full-scale switching (0/10 V at random intervals of 1-50 ms) through
``pendc simulate --fixed`` on the rig model (Table 14 plus end stops): the cart stays on the
track, nothing leaves its range. A pendulum spun over 20 turns keeps theta right at every
turn. Without end stops the same input drives the cart off its format's range, and the run
stops with an error naming the node and the time, or marks every affected row on request.
"""

import re
from pathlib import Path

import numpy as np
import pytest

from pendc.cli import main
from pendc.model.modelfile import load_model
from pendc.passes.ranges import full_scale_switching
from pendc.passes.pipeline import BuildOptions
from pendc.sim.measurements import format_csv, read_measurements
from pendc.sim.simulator import Simulator

RIG = str(Path(__file__).resolve().parents[1] / "models" / "sct_rig.toml")
X_END = 0.375
PENETRATION = 0.03     # k_end = 1e5 N/m stops the 104 kg cart from 0.55 m/s within about 2 cm


def _input_file(tmp_path, t, u, name="in.csv"):
    path = tmp_path / name
    path.write_text(format_csv({"t": t, "u": u}, {"generator": "test_full_scale"}))
    return str(path)


def test_a_minute_of_full_scale_switching_stays_on_the_track(tmp_path):
    t, u = full_scale_switching(60.0, seed=1)
    out = tmp_path / "out.csv"
    assert main(["simulate", "--fixed", "--model", RIG, "--input", _input_file(tmp_path, t, u),
                 "-o", str(out)]) == 0
    run = read_measurements(out)
    assert run.t[-1] == pytest.approx(60.0)
    assert np.max(np.abs(run.x)) <= X_END + PENETRATION
    assert np.max(np.abs(run.x)) > X_END            # it did hit the stops
    # the hits on the stops shake the pendulum hard; theta stays continuous (turns are the
    # next test's subject)
    assert np.max(np.abs(run.theta)) > 0.3
    assert np.max(np.abs(np.diff(run.theta))) < 0.05


def test_a_pendulum_spun_over_twenty_turns_is_right_after_every_turn(tmp_path):
    """Started at 30 rad/s (the hardware model's registers start there) and left alone: over
    20 turns, and at every completed turn theta agrees with the float simulator."""
    model = load_model(RIG)
    t = np.arange(0, 8.0 + 1e-9, 1e-3)
    u = np.full_like(t, model.parameter_values()["V_off"])
    out = tmp_path / "spin.csv"
    assert main(["simulate", "--fixed", "--model", RIG, "--x0", "0,0,0,30", "--input",
                 _input_file(tmp_path, t, u), "-o", str(out)]) == 0
    fixed = read_measurements(out)
    ref = Simulator(model)(t, u, x0=(0.0, 0.0, 0.0, 30.0))
    turns = np.floor(ref["theta"] / (2 * np.pi))
    at_turn = np.flatnonzero(np.diff(turns) != 0) + 1
    assert len(at_turn) >= 20
    err = np.abs(fixed.theta[at_turn] - ref["theta"][at_turn])
    print(f"{len(at_turn)} turns, worst |theta fixed - float| at a turn {err.max():.3g} rad")
    assert err.max() < BuildOptions().budget_theta        # the error budget: half an encoder count


def test_leaving_a_range_stops_the_run_with_the_node_and_the_time(tmp_path, capsys):
    """Table 14 has no track ends: pushed full scale from 0.1 m below the end of x's format, the
    cart leaves it; the error names the node and the time the float model crosses the limit."""
    from pendc.caching.build_cache import compile_cached
    model = load_model()
    limit = compile_cached(model).graph.output("x").qformat.max_value
    x0 = f"{limit - 0.1!r},0,0,0"
    t = np.arange(0, 1.0 + 1e-9, 1e-3)
    u = np.full_like(t, 10.0)
    ref = Simulator(model)(t, u, x0=(limit - 0.1, 0.0, 0.0, 0.0))
    crossing = t[np.argmax(ref["x"] > limit)]
    assert 0.1 < crossing < 0.9
    inp = _input_file(tmp_path, t, u)
    out = tmp_path / "out.csv"
    assert main(["simulate", "--fixed", "--x0", x0, "--input", inp, "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and not out.exists()
    m = re.fullmatch(r"pendc: error: node '(x\w*)' left its Q-format range at t = ([0-9.]+) s .*", err)
    assert m, err
    assert abs(float(m.group(2)) - crossing) <= 2e-3

    assert main(["simulate", "--fixed", "--x0", x0, "--on-overflow", "mark", "--input", inp,
                 "-o", str(out)]) == 0
    warn = capsys.readouterr().err
    assert f"pendc: warning: node '{m.group(1)}'" in warn and "marked in column 'overflow'" in warn
    # read as plain numbers: the rows after the flag hold wrapped positions, which the
    # measurement reader's plausibility checks rightly refuse
    header = [line for line in out.read_text().splitlines() if not line.startswith("#")][0].split(",")
    table = np.loadtxt(out, delimiter=",", comments="#", skiprows=1 + sum(
        1 for line in out.read_text().splitlines() if line.startswith("#")))
    marked = table[:, header.index("overflow")]
    first = int(np.argmax(marked))
    assert marked[0] == 0 and np.all(marked[first:] == 1)       # sticky from the flag on
    assert abs(t[first] - crossing) <= 2e-3
