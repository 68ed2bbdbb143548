"""Time units and sample rates of a fast plant's record (the blind check's buck converter, its
fastest mode a 3.4 kHz oscillation): a record at 1 kHz (0.3 samples a period) scored -8 % without
a word, and one with t in milliseconds was read as seconds at 100 Hz, where a mechanical plant's
was refused. Now fewer than two samples a period of the fastest oscillation (Nyquist) is refused
in one line, unit given or not, and times that would sample it in milliseconds are named so.

The records are the buck's response integrated by scipy (tests/test_resample.py), not by pendc."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from cli_capture import run_cli
from test_resample import write_buck


def _error(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pendc: error: "), err
    return lines[0]


def test_a_record_below_nyquist_is_refused_with_both_rates(tmp_path, capsys):
    model, data = write_buck(tmp_path, every=100)              # 1 kHz
    rc, out, err = run_cli(capsys, "compare", data, "--model", model)
    line = _error(err)
    assert rc != 0 and not out
    assert "t is sampled at 1 kHz" in line and "a 3384 Hz oscillation" in line and "Nyquist 6.769 kHz" in line
    assert "record faster, or give --t-unit ms if t is in milliseconds" in line
    assert "looks like milliseconds" not in line     # in ms it would last a tenth of a period
    rc, out, err = run_cli(capsys, "compare", data, "--model", model, "--t-unit", "s")
    line = _error(err)
    assert "with the --t-unit given" in line and "check --t-unit, or record faster" in line


def test_milliseconds_of_a_fast_plant_are_named(tmp_path, capsys):
    model, data = write_buck(tmp_path, t_scale=1e3)            # 100 kHz, t in ms
    rc, out, err = run_cli(capsys, "compare", data, "--model", model)
    line = _error(err)
    assert "t looks like milliseconds (median step 0.01, last t = 29.99; in seconds it is sampled at 100 Hz" in line
    assert "use --t-unit ms" in line
    rc, out, err = run_cli(capsys, "compare", data, "--model", model, "--t-unit", "ms")
    assert rc == 0, err
    fits = [float(f) for f in re.findall(r"(-?[\d.]+) %", out.splitlines()[0])]
    assert len(fits) == 2 and min(fits) > 99.9, out.splitlines()[0]


def test_a_fast_real_pole_needs_no_samples_a_period():
    """A DC motor's armature (a 2.3 kHz corner, no oscillation) recorded at 1 kHz is read: the
    current settles within a sample, it does not alias."""
    from pendc.model.modelfile import load_model
    from pendc.sim.measurements import format_csv, parse_measurements
    from pendc.sim.readers import ReadOptions

    model = load_model(Path(__file__).parent / "plant_dc_motor.toml")
    t = np.arange(0, 0.5 + 1e-9, 1e-3)
    m = parse_measurements(format_csv({"t": t, "v": np.sin(t), "phi": 0.1 * t}),
                           options=ReadOptions(plant=model, plausible=True))
    assert len(m.t) == len(t)


def test_a_file_pendc_wrote_is_in_seconds(tmp_path, capsys):
    """Round I: pendc simulate's own 1 kHz output of a fast plant was called milliseconds, and the
    advice (--t-unit ms) made a 20 ms record of it. A file pendc wrote is seconds: the line says so
    and how to make a faster one."""
    model, data = write_buck(tmp_path, every=100)              # 1 kHz
    ours = tmp_path / "ours.csv"
    ours.write_text("# generator: pendc simulate\n" + Path(data).read_text())
    rc, out, err = run_cli(capsys, "compare", ours, "--model", model)
    line = _error(err)
    assert rc == 2 and "(pendc wrote it: seconds)" in line and "looks like milliseconds" not in line
    assert "so give it an input sampled at 33.84 kHz or more (pendc stimulus --rate 34000)" in line


def test_a_lone_outlier_in_a_position_of_any_unit_is_named(tmp_path, capsys):
    """Round J: one row of a user plant's position at 1e6 (a CSTR's temperature in K, a robot's
    pitch in rad) was blamed on the simulation ('diverged') or accepted without a word: the
    outlier checks knew metres and periodic angles only. A sample that leaves both neighbours by
    ten times the column's own span is now an outlier, whatever the unit."""
    model, data = write_buck(tmp_path, every=2)
    lines = Path(data).read_text().splitlines()
    head = next(k for k, ln in enumerate(lines) if ln.startswith("t,"))
    k = head + 500
    cells = lines[k].split(",")
    cells[3] = "1000000.0"                                  # v_C
    lines[k] = ",".join(cells)
    bad = tmp_path / "outlier.csv"
    bad.write_text("\n".join(lines) + "\n")
    rc, out, err = run_cli(capsys, "compare", bad, "--model", model)
    line = _error(err)
    assert rc == 2 and re.search(rf"line {k + 1}: v_C = 1e\+06 is an outlier \(it jumps more than [\d.]+ V away", line)
    rc, out, err = run_cli(capsys, "compare", data, "--model", model)       # the clean record passes
    assert rc == 0, err


def test_a_still_column_with_one_count_of_flicker_is_no_outlier():
    """A held position that reads one code off for a sample: its span is that code, not zero."""
    from pendc.sim.plausibility import check_lone_spikes
    from pendc.sim.table import Table

    values = np.full(2000, 0.25)
    values[700] += 0.0048828125                             # one 12-bit code of a 20 V converter
    lsb = 20.0 / 4096
    check_lone_spikes(Table(columns={}, meta={}, source="held.csv"), "v", values, "V", lsb)
    values[700] = 30.0                                      # far beyond: still an outlier
    try:
        check_lone_spikes(Table(columns={}, meta={}, source="held.csv"), "v", values, "V", lsb)
    except Exception as exc:
        assert "row 701: v = 30 is an outlier" in str(exc)
    else:
        raise AssertionError("30 V among 0.25 V readings passed")
