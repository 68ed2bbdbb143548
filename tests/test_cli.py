"""The command line: outputs, and one-line errors with exit status 2 for bad input."""

import json

import numpy as np
import pytest

from pendc.cli import main
from pendc.sim.measurements import format_csv, read_measurements


def run(capsys, *argv):
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def test_stimulus_then_simulate(tmp_path, capsys):
    stim = tmp_path / "in.csv"
    out = tmp_path / "out.csv"
    assert run(capsys, "stimulus", "steps", "-o", str(stim))[0] == 0
    rc, _, err = run(capsys, "simulate", "--input", str(stim), "-o", str(out), "--dt", "1e-5")
    assert rc == 0, err
    res = read_measurements(out)
    assert list(res.columns) == ["t", "u", "x", "theta", "dx", "dtheta"]
    assert np.array_equal(res.t, read_measurements(stim, required=("t", "u")).t)
    assert res.x.max() > 0.05            # the +0.8 V step moves the cart left
    rc, _, _ = run(capsys, "simulate", "--input", str(stim), "-o", str(out), "--dt", "1e-5",
                   "--method", "rk4", "--quantize", "--x0", "0,0,0.2,0")
    q = read_measurements(out)
    assert q.theta[0] == 0.2 and rc == 0


def _one_line_error(capsys, *argv, match):
    rc, out, err = run(capsys, *argv)
    assert rc == 2
    assert err.count("\n") == 1 and err.startswith("pendc: error: ")
    assert match in err
    return err


def test_bad_arguments(tmp_path, capsys):
    stim = tmp_path / "in.csv"
    stim.write_text(format_csv({"t": np.arange(5) * 1e-3, "u": np.full(5, 5.0)}))
    _one_line_error(capsys, "nonsense", match="invalid choice")
    _one_line_error(capsys, "simulate", match="--input")
    _one_line_error(capsys, "simulate", "--input", str(stim), "--dt", "abc", match="--dt")
    _one_line_error(capsys, "simulate", "--input", str(stim), "--method", "rk5", match="--method")
    _one_line_error(capsys, "simulate", "--input", str(stim), "--x0", "1,2", match="expected 4 numbers x,dx,theta,dtheta")
    _one_line_error(capsys, "simulate", "--input", str(tmp_path / "none.csv"), match="not found")
    _one_line_error(capsys, "simulate", "--input", str(stim), "--model", str(tmp_path / "m.toml"),
                    match="not found")
    _one_line_error(capsys, "stimulus", "sawtooth", match="unknown stimulus")


def test_bad_files_leave_no_output(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,u\n0,5\n0,5\n")
    out = tmp_path / "out.csv"
    _one_line_error(capsys, "simulate", "--input", str(bad), "-o", str(out), match="time")
    assert not out.exists()
    model = tmp_path / "m.toml"
    model.write_text("[plant]\ng = 9.8\n")
    good = tmp_path / "in.csv"
    good.write_text("t,u\n0,5\n0.001,5\n")
    _one_line_error(capsys, "simulate", "--input", str(good), "--model", str(model), "-o", str(out),
                    match="lacks")
    _one_line_error(capsys, "simulate", "--input", str(good), "-o", str(tmp_path / "no" / "o.csv"),
                    match="does not exist")
    assert {p.name for p in tmp_path.iterdir()} == {"bad.csv", "m.toml", "in.csv"}  # no temp files left


def test_voltage_warning_is_not_an_error(tmp_path, capsys):
    stim = tmp_path / "in.csv"
    stim.write_text("t,u\n0,11\n0.001,11\n")
    rc, out, err = run(capsys, "simulate", "--input", str(stim), "--dt", "1e-5")
    assert rc == 0 and "warning" in err and "0-10 V" in err


def test_build_debug_status_lists_the_node_of_every_status_bit(tmp_path, capsys):
    plain, debug = tmp_path / "plain", tmp_path / "debug"
    assert main(["build", "-o", str(plain)]) == 0
    assert main(["build", "-o", str(debug), "--debug-status"]) == 0
    capsys.readouterr()
    report = json.loads((debug / "report.json").read_text())
    nodes = report["overflow_status_nodes"]
    assert report["debug_status"] is True and nodes == report["overflow_nodes"]
    words = [r for r in report["registers"] if r["name"].startswith("OVERFLOW_STATUS_")]
    assert len(words) == (len(nodes) + 31) // 32
    assert "overflow_status" in (debug / "pendulum_core.v").read_text()
    assert "overflow_status" not in (plain / "pendulum_core.v").read_text()
    assert "debug_status" not in json.loads((plain / "report.json").read_text())
    # a plain folder is not what the debug build writes, and --check says so
    assert main(["build", "-o", str(plain), "--debug-status", "--check"]) == 2
    assert "differs" in capsys.readouterr().err


def test_the_qformat_report_prints_units_not_words():
    """Round G: a tank file's meanings end in "(Torricelli)" and "(L1)", which the report printed
    as units; a parenthesis that is no unit is not one."""
    from pendc.cli.report import _unit
    assert [_unit(m) for m in ("cart acceleration (m/s^2)", "flow (Torricelli)", "table (L1)", "x (F_in)")] == \
        ["m/s^2", "", "", ""]


def test_stimulus_at_a_fast_plants_rate_makes_data_compare_reads(tmp_path, capsys):
    """Round I (F5): pendc stimulus sampled at 1 kHz only, so the documented recipe for test data
    (stimulus, then simulate --quantize) made records a 3.4 kHz converter's compare refuses. With
    --rate the same two commands make a record compare takes."""
    from buck_plant import buck_toml

    plant = tmp_path / "buck.toml"
    plant.write_text(buck_toml(), encoding="utf-8")
    for rate, accepted in (("1000", False), ("40000", True)):
        stim, data = tmp_path / f"stim{rate}.csv", tmp_path / f"data{rate}.csv"
        assert run(capsys, "stimulus", "steps", "--model", str(plant), "--rate", rate, "-o", str(stim))[0] == 0
        rows = [ln for ln in stim.read_text().splitlines() if not ln.startswith("#")]
        assert rows[0] == "t,d" and f"# rate: {float(rate):g} Hz" in stim.read_text()
        t = np.array([float(ln.split(",")[0]) for ln in rows[1:]])
        assert np.allclose(np.diff(t), 1 / float(rate)) and t[-1] == pytest.approx(5.0)
        rc, _, err = run(capsys, "simulate", "--model", str(plant), "--input", str(stim), "--quantize", "-o", str(data))
        assert rc == 0, err
        rc, out, err = run(capsys, "compare", "--model", str(plant), str(data))
        assert (rc == 0) == accepted, err
        assert accepted or "faster" in err
    _one_line_error(capsys, "stimulus", "steps", "--rate", "0", match="--rate 0: the sample rate must be between")
    _one_line_error(capsys, "stimulus", "chirp_low", "--rate", "1e6", match="would be 2.01e+07 rows")
