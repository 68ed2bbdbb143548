"""Issue 9 point 1: the hardware model survives what controllers do to it, and says when not.

Without end stops (Table 14) a full-scale push drives the cart off its format's range, and
``pendc simulate --fixed`` stops with an error naming the node and the time, or marks every
affected row on request. The rig model's minute of full-scale switching (the cart stays on the
track, nothing leaves its range) and its pendulum spun over 20 turns (theta right at every turn)
are tests/test_rtl_full_scale.py, whose golden runs the RTL windows start from: the same golden
model ``pendc simulate --fixed`` runs.
"""

import re

import numpy as np

from pendc.cli import main
from pendc.model.modelfile import load_model
from pendc.sim.measurements import format_csv
from pendc.sim.simulator import Simulator


def _input_file(tmp_path, t, u, name="in.csv"):
    path = tmp_path / name
    path.write_text(format_csv({"t": t, "u": u}, {"generator": "test_full_scale"}))
    return str(path)


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
