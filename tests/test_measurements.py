"""Measurement files (spec §6): round trip, every kind of bad input, the degrees heuristic."""

import math
import time

import numpy as np
import pytest

from pendc.errors import PendcError
from pendc.sim.measurements import (
    Measurement,
    format_csv,
    parse_measurements,
    read_measurements,
    write_csv,
)

HEADER = "t,u,x,theta"


def good_text(rows=5):
    lines = [HEADER] + [f"{k * 0.001},5.0,{k * 1e-4},{k * 0.01}" for k in range(rows)]
    return "\n".join(lines) + "\n"


def realistic_columns(n=20_000, seed=1):
    """20 s at 1 kHz: swings past upright, spins a few turns at up to ~25 rad/s, quantised."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-3
    swing = 3.6 * np.sin(2 * np.pi * 0.4 * t) * np.minimum(t / 5, 1)
    spin = np.where(t > 12, np.minimum((t - 12) * 25.0, 25.0 * 3), 0.0)  # ~3 turns at 25 rad/s
    q = 2 * np.pi / 20000
    theta = np.round((swing + spin) / q) * q
    x = np.round(0.2 * np.sin(2 * np.pi * 0.3 * t) / 2.5e-6) * 2.5e-6
    u = 5.0 + 4.0 * np.sin(2 * np.pi * 0.3 * t) + rng.normal(0, 0.1, n)
    return {"t": t, "u": np.clip(u, 0, 10), "x": x, "theta": theta}


def raises(text, *words, required=("t", "u", "x", "theta"), meta=None):
    with pytest.raises(PendcError) as info:
        parse_measurements(text, source="run.csv", required=required)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith("run.csv"), msg
    for w in words:
        assert w in msg, msg
    return msg


# ---------------------------------------------------------------- valid input

def test_round_trip_bit_exact(tmp_path):
    rng = np.random.default_rng(0)
    n = 1000
    cols = {
        "t": np.cumsum(rng.uniform(1e-4, 2e-3, n)),
        "u": rng.uniform(0, 10, n),
        "x": rng.normal(0, 0.1, n),
        "theta": np.cumsum(rng.normal(0, 0.01, n)) + np.pi,  # a random walk, as angles move
        "dx": rng.normal(0, 1e-300, n),
        "extra": rng.normal(0, 1e300, n),
    }
    meta = {"date": "2024-05-01", "rig": "SCT #2: lab 3", "theta_unit": "rad"}
    path = tmp_path / "m.csv"
    write_csv(path, cols, meta)
    m = read_measurements(path)
    assert list(m.columns) == list(cols)
    for k, v in cols.items():
        assert m.columns[k].dtype == np.float64
        assert m.columns[k].tobytes() == v.tobytes(), k
    assert m.meta == meta
    assert m.source == str(path)
    assert m.warnings == ()
    assert m.t is m.columns["t"] and m.u is m.columns["u"]
    assert m.x is m.columns["x"] and m.dx is m.columns["dx"] and m.dtheta is None
    assert format_csv(m.columns, m.meta) == path.read_text(encoding="utf-8")


def test_format_is_deterministic_and_shaped():
    text = format_csv({"t": [0.0, 0.1], "u": np.array([1, 2])}, {"a": "b"})
    assert text == "# a: b\nt,u\n0.0,1.0\n0.1,2.0\n"


def test_comments_spaces_crlf_bom_trailing_blank_lines(tmp_path):
    text = "# free-form note, not metadata\n#operator: Ann\n\n t , u ,x, theta \r\n0,5,0,0\r\n0.001, 5 ,0,0.001\n\n\n"
    path = tmp_path / "m.csv"
    path.write_bytes(b"\xef\xbb\xbf" + text.encode())
    m = read_measurements(path)
    assert list(m.columns) == ["t", "u", "x", "theta"]
    assert m.meta == {"operator": "Ann"}
    assert m.u.tolist() == [5.0, 5.0]


def test_required_subset_and_column_access():
    m = parse_measurements("t,u\n0,1\n1,2\n", required=("t", "u"))
    assert m.x is None and m.theta is None
    assert m.initial_state() == (0.0, 0.0, 0.0, 0.0)
    with pytest.raises(PendcError) as info:
        m.column("x")
    assert "'x'" in str(info.value) and "<string>" in str(info.value)
    assert m.column("u").tolist() == [1.0, 2.0]


def test_extra_column_with_nan_only_fails_when_used():
    m = parse_measurements(HEADER + ",i\n0,1,0,0,nan\n1,1,0,0,1\n")
    with pytest.raises(PendcError, match="line 2.*'i'"):
        m.column("i")


def test_arrays_are_read_only():
    m = parse_measurements(good_text())
    with pytest.raises(ValueError):
        m.u[0] = 1.0


def test_initial_state_from_columns():
    m = parse_measurements("t,u,x,theta,dx,dtheta\n0,5,0.1,3.0,0.5,-2\n0.001,5,0.2,3.1,0.6,-3\n")
    assert m.initial_state() == (0.1, 0.5, 3.0, -2.0)


def test_initial_state_fits_velocity_over_first_10ms():
    t = np.arange(200) * 1e-3
    x = 0.05 + 0.3 * t
    theta = np.round((1.0 - 2.0 * t) / 3.14e-4) * 3.14e-4  # quantised
    m = parse_measurements(format_csv({"t": t, "u": 0 * t + 5, "x": x, "theta": theta}))
    x0, dx0, th0, dth0 = m.initial_state()
    assert x0 == x[0] and th0 == theta[0]
    assert dx0 == pytest.approx(0.3, rel=1e-9)
    assert dth0 == pytest.approx(-2.0, rel=0.05)


def test_initial_state_uses_at_least_three_samples():
    # 100 Hz: the 10 ms window holds only 2 samples (slope 1); 3 samples give 0.03 / 0.02.
    m = parse_measurements("t,u,x,theta\n0,5,0,0\n0.01,5,0.01,0\n0.02,5,0.03,0\n0.03,5,9,0\n")
    assert m.initial_state()[1] == pytest.approx(1.5)


def test_voltage_outside_range_is_a_warning():
    # outside the range the actuator takes in the plant interface (0-10 V for the SCT drive)
    text = HEADER + "\n0,-10.5,0,0\n0.001,5,0,0\n0.002,10.25,0,0\n0.003,10,0,0\n"
    m = parse_measurements(text, source="run.csv")
    assert len(m.warnings) == 1
    w = m.warnings[0]
    assert "\n" not in w and "run.csv" in w and "2 of 4" in w and "-10.5" in w and "10.25" in w


def test_realistic_radian_data_not_flagged(tmp_path):
    cols = realistic_columns()
    assert np.abs(cols["theta"]).max() > 2 * np.pi  # the test data really spin
    path = tmp_path / "real.csv"
    write_csv(path, cols, {"theta_unit": "rad"})
    m = read_measurements(path)
    assert m.theta.tobytes() == cols["theta"].tobytes()


def test_large_file_parses_fast(tmp_path):
    cols = realistic_columns(n=200_000)
    cols["dx"] = np.gradient(cols["x"], cols["t"])
    cols["dtheta"] = np.gradient(cols["theta"], cols["t"])
    path = tmp_path / "big.csv"
    write_csv(path, cols)
    # Against numpy's own C parser on the same file in the same process, so the bound holds
    # however loaded the machine is (an absolute "< 1 s" failed on 2 cores shared by 6 jobs);
    # bench/bench_read_csv.py records absolute times.
    numpy_seconds, pendc_seconds = [], []
    for _ in range(2):  # best of two: one run can lose its core to another job
        start = time.perf_counter()
        reference = np.loadtxt(path, delimiter=",", skiprows=1)
        numpy_seconds.append(time.perf_counter() - start)
        start = time.perf_counter()
        m = read_measurements(path)
        pendc_seconds.append(time.perf_counter() - start)
    assert min(pendc_seconds) < 2.0 * min(numpy_seconds) + 0.3
    assert len(m.t) == 200_000
    assert m.columns["dtheta"].tobytes() == reference[:, 5].tobytes()


# ---------------------------------------------------------------- bad input

def test_file_not_found(tmp_path):
    with pytest.raises(PendcError, match="not found"):
        read_measurements(tmp_path / "nope.csv")


def test_folder_is_not_a_file(tmp_path):
    with pytest.raises(PendcError, match="folder"):
        read_measurements(tmp_path)


def test_unreadable(tmp_path, monkeypatch):
    path = tmp_path / "m.csv"
    path.write_text(good_text())

    real_open = open

    def denied(file, *args, **kwargs):  # chmod 0 does not stop root, so fake the refusal
        if str(file) == str(path):
            raise PermissionError(13, "Permission denied", str(file))
        return real_open(file, *args, **kwargs)

    monkeypatch.setattr("builtins.open", denied)
    with pytest.raises(PendcError) as info:
        read_measurements(path)
    msg = str(info.value)
    assert "cannot read" in msg and "Permission denied" in msg and "\n" not in msg


def test_not_utf8(tmp_path):
    path = tmp_path / "m.csv"
    path.write_bytes(b"# caf\xe9\n" + good_text().encode())
    with pytest.raises(PendcError) as info:
        read_measurements(path)
    msg = str(info.value)
    assert "UTF-8" in msg and "line 1" in msg and str(path) in msg and "\n" not in msg


def test_empty_file():
    raises("", "empty")
    raises("\n\n  \n", "empty")


def test_only_comments():
    raises("# a: b\n# note\n", "no header")


def test_header_only():
    raises(HEADER + "\n\n", "no data rows")


def test_data_without_header():
    raises("0,1,2,3\n1,1,2,3\n", "no header", "line 1")


def test_missing_required_column():
    msg = raises("t,u,x\n0,1,0\n", "missing", "theta", "columns: t, u, x")
    assert "x," not in msg.split("missing")[1].split("(")[0]


def test_missing_column_with_required_subset():
    raises("t,x\n0,1\n", "missing", "u", required=("t", "u"))


def test_duplicate_column():
    raises("t,u,x,theta,x\n0,1,0,0,0\n", "duplicate", "x", "line 1")


def test_empty_column_name():
    raises("t,u,,theta\n0,1,0,0\n", "empty column name")


def test_wrong_field_count():
    raises(HEADER + "\n0,1,0,0\n0.1,1,0\n", "line 3", "3 fields, expected 4")
    raises(HEADER + "\n0,1,0,0\n0.1,1,0,0,9\n", "line 3", "5 fields")


def test_blank_line_inside_data():
    raises(HEADER + "\n0,1,0,0\n\n0.1,1,0,0\n", "line 3", "blank line")


def test_comment_inside_data():
    raises("# a: b\n" + HEADER + "\n0,1,0,0\n# late\n", "line 4", "comment")


def test_non_numeric_field():
    raises("# c\n" + HEADER + "\n0,1,0,0\n0.1,1,abc,0\n", "line 4", "'x'", "abc")
    raises(HEADER + "\n0,1,0,0\n0.1,1,0,\n", "line 3", "'theta'", "not a number")


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf", "NaN"])
@pytest.mark.parametrize("col", range(4))
def test_non_finite_in_used_column(bad, col):
    rows = [["0", "1", "0", "0"], ["0.001", "1", "0", "0"], ["0.002", "1", "0", "0"]]
    rows[2][col] = bad
    text = HEADER + "\n" + "\n".join(",".join(r) for r in rows) + "\n"
    raises(text, "line 4", f"'{HEADER.split(',')[col]}'", "not allowed")


def test_non_finite_in_optional_velocity_column():
    raises("t,u,x,theta,dtheta\n0,1,0,0,0\n1,1,0,0,inf\n", "line 3", "'dtheta'")


def test_time_duplicate():
    raises(HEADER + "\n0,1,0,0\n0.001,1,0,0\n0.001,1,0,0\n", "line 4", "duplicate", "0.001")


def test_time_decreasing():
    raises(HEADER + "\n0,1,0,0\n0.002,1,0,0\n0.001,1,0,0\n", "line 4", "decreases", "0.002", "0.001")


def test_degrees_by_values():
    cols = realistic_columns(n=5000)
    cols["theta"] = np.degrees(cols["theta"])
    raises(format_csv(cols), "degrees", "radians")


def test_degrees_by_magnitude_alone():
    t = np.arange(100) * 1.0  # slow: rate test alone would not catch it
    raises(format_csv({"t": t, "u": t * 0, "x": t * 0, "theta": t * 2.5}), "degrees")


def test_degrees_by_column_name():
    raises("t,u,x,theta_deg\n0,1,0,0\n", "degrees", "theta_deg")
    raises("t,u,x,theta (deg)\n0,1,0,0\n", "degrees")


def test_degrees_by_metadata():
    raises("# theta_unit: degrees\n" + good_text(), "degrees", "theta_unit")
    raises("# theta_unit: deg\n" + good_text(), "degrees")


def test_theta_checks_skipped_without_theta():
    m = parse_measurements("# theta_unit: deg\nt,u\n0,1\n1,1\n", required=("t", "u"))
    assert m.theta is None


def test_fast_pendulum_in_radians_near_limit_not_flagged():
    t = np.arange(3000) * 1e-3
    theta = 25.0 * t  # 8π rad/s for 3 s: 12 turns
    m = parse_measurements(format_csv({"t": t, "u": t * 0 + 5, "x": t * 0, "theta": theta}))
    assert m.theta[-1] > 70


def test_format_rejects_bad_names_and_shapes():
    with pytest.raises(PendcError, match="column name"):
        format_csv({"a,b": [1.0]})
    with pytest.raises(PendcError, match="shape"):
        format_csv({"t": [1.0, 2.0], "u": [1.0]})
    with pytest.raises(PendcError, match="metadata"):
        format_csv({"t": [1.0]}, {"k": "two\nlines"})


def test_measurement_is_constructible_directly():
    t = np.array([0.0, 0.1])
    m = Measurement(t=t, u=t, columns={"t": t, "u": t}, meta={}, source="synthetic")
    assert math.isclose(m.initial_state()[0], 0.0)
