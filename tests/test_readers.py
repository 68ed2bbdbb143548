"""Other labs' text files and every reading option, through the library API (.mat: test_matread.py).

Each test writes a file the way the other tool writes it (CSV with other names,
separators, units, encodings, no header, other sample rates) and checks the values
pendc reads against the truth they were made from.
"""

import io
import math
import sys

import numpy as np
import pytest

from measurement_samples import Q_THETA, Q_X, opts, truth
from pendc.errors import PendcError
from pendc.sim.measurements import format_csv, parse_measurements, read_measurements
from pendc.sim.readers import estimate_resolution


# ---------------------------------------------------------------- CSV dialects and units

def test_csv_other_names_semicolons_and_units():
    t, theta, x, u = truth()
    rows = [f"{a!r};{b!r};{c!r};{d!r}" for a, b, c, d in
            zip((t * 1e3).tolist(), (x * 1e3).tolist(), (u * 1e3).tolist(), np.degrees(theta).tolist())]
    text = "Time_ms;CartPos_mm;Vin_mV;Theta1\n" + "\n".join(rows) + "\n"
    m = parse_measurements(text, options=opts(columns={"t": "Time_ms", "x": "CartPos_mm", "u": "Vin_mV",
                                                       "theta": "Theta1"},
                                              t_unit="ms", x_unit="mm", u_unit="mV", theta_unit="deg"))
    assert np.allclose(m.t, t, rtol=0, atol=1e-12) and np.allclose(m.x, x, atol=1e-12)
    assert np.allclose(m.u, u, atol=1e-9) and np.allclose(m.theta, theta, atol=1e-12)
    assert list(m.columns)[:4] == ["t", "u", "x", "theta"]


@pytest.mark.parametrize("sep, option", [("\t", ...), ("\t", "\t"), ("   ", ...), (" ", None), (";", ...),
                                         (";", ";"), ("|", "|")])
def test_separators_detected_or_given(sep, option):
    """``...`` detects the separator from the header; None is runs of whitespace."""
    t, theta, x, u = truth(duration=0.2)
    rows = [sep.join(repr(v) for v in r) for r in zip(t.tolist(), u.tolist(), x.tolist(), theta.tolist())]
    text = "# rig: B\n" + sep.join(["t", "u", "x", "theta"]) + "\n" + "\n".join(rows) + "\n"
    m = parse_measurements(text, options=opts(separator=option))
    assert np.array_equal(m.theta, theta) and m.meta == {"rig": "B"}


def test_theta_zero_upright_and_sign():
    t, theta, x, u = truth()
    cols = {"t": t, "u": u, "x": x, "theta": -(theta - math.pi)}  # from upright, counter-clockwise
    m = parse_measurements(format_csv(cols), options=opts(theta_zero="upright", theta_sign=-1.0))
    assert np.allclose(m.theta, theta, atol=1e-12)


def test_decimal_comma_is_named():
    with pytest.raises(PendcError, match=r"line 3: column 'x': not a number: '0,5' \(decimal comma\? give "
                                         r"--decimal comma\)"):
        parse_measurements("t;u;x;theta\n0;5;0;0\n0.001;5;0,5;0\n")


def test_a_text_column_is_skipped_and_named_when_it_is_needed():
    t, theta, x, u = truth(duration=0.2)
    rows = [f"{a!r},{b!r},{c!r},{d!r},{'swing' if k < 100 else 'balance'}"
            for k, (a, b, c, d) in enumerate(zip(t.tolist(), u.tolist(), x.tolist(), theta.tolist()))]
    text = "# controller: builtin\nt,u,x,theta,mode\n" + "\n".join(rows) + "\n"
    m = parse_measurements(text)
    assert np.array_equal(m.theta, theta) and "mode" not in m.columns
    assert [n for n in m.notes if "text" in n] == ["<string>: ignoring text column(s) mode"]
    with pytest.raises(PendcError, match=r"--columns theta=mode: column 'mode' holds text \('swing' on line 3\), "
                                         r"not numbers$"):
        parse_measurements(text, options=opts(columns={"theta": "mode"}))
    with pytest.raises(PendcError, match=r"missing column\(s\) x: column 'x' holds text \('zero' on line 2\)"):
        parse_measurements("t,u,x,theta\n0,5,zero,0\n")


@pytest.mark.parametrize("sep", [";", "\t"])
def test_decimal_commas_detected_or_given(sep):
    t, theta, x, u = truth(duration=0.5)
    rows = [sep.join(repr(v).replace(".", ",") for v in r)
            for r in zip(t.tolist(), u.tolist(), x.tolist(), theta.tolist())]
    text = sep.join(["t", "u", "x", "theta"]) + "\n" + "\n".join(rows) + "\n"
    m = parse_measurements(text)  # detected from the first row, "0,0;5,0;0,0;0,0"
    assert np.array_equal(m.theta, theta) and np.array_equal(m.t, t)
    assert "decimal commas" in m.notes[0]
    lines = text.split("\n")
    lines[1] = sep.join(["0", "5", "0", "0"])  # a first row without any comma: not detected
    whole = "\n".join(lines)
    with pytest.raises(PendcError, match="decimal comma"):
        parse_measurements(whole)
    m = parse_measurements(whole, options=opts(decimal=","))
    assert np.array_equal(m.x, x) and m.notes == ()
    with pytest.raises(PendcError, match="decimal commas need another field separator"):
        parse_measurements("t,u\n0,1\n", options=opts(decimal=","))


def test_standard_input(monkeypatch):
    t, theta, x, u = truth(duration=0.1)
    data = format_csv({"t": t, "u": u, "x": x, "theta": theta}).encode()
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(data)))
    m = read_measurements("-")
    assert m.source == "<stdin>" and np.array_equal(m.theta, theta)


# ---------------------------------------------------------------- experiments and missing axes

def test_cart_held_file_without_x_and_u():
    t, theta, _, _ = truth()
    text = "# experiment: cart_held\n" + format_csv({"t": t, "theta": theta})
    m = parse_measurements(text)
    assert m.experiment == "cart_held" and m.missing == ("x", "u")
    assert np.array_equal(m.x, np.zeros_like(t)) and np.array_equal(m.u, np.zeros_like(t))
    assert any("filled" in n for n in m.notes)
    m = parse_measurements(format_csv({"t": t, "theta": theta}), options=opts(experiment="cart_held", u_value=5.26))
    assert np.all(m.u == 5.26)


def test_pendulum_removed_without_theta_and_user_allowed_missing():
    t, _, x, u = truth()
    m = parse_measurements(format_csv({"t": t, "u": u, "x": x}), options=opts(experiment="pendulum_removed"))
    assert m.missing == ("theta",) and np.all(m.theta == 0)
    m = parse_measurements(format_csv({"t": t, "x": x, "theta": x}), options=opts(allow_missing=("u",)))
    assert m.missing == ("u",) and m.experiment == "free"


def test_missing_axis_without_permission_says_how():
    t, theta, _, _ = truth()
    with pytest.raises(PendcError) as info:
        parse_measurements(format_csv({"t": t, "theta": theta}), source="swing.csv")
    msg = str(info.value)
    assert msg.startswith("swing.csv: missing column(s) u, x") and "--experiment cart_held" in msg


def test_unknown_experiment_names_the_known_ones():
    with pytest.raises(PendcError, match=r"run.csv: unknown experiment 'clamped' \(known: free, cart_held"):
        parse_measurements("# experiment: clamped\nt,u,x,theta\n0,5,0,0\n", source="run.csv")


# ---------------------------------------------------------------- resolution

def test_resolution_estimated_from_encoder_counts():
    t, theta, x, u = truth()
    rng = np.random.default_rng(3)
    cols = {"t": t, "u": u + rng.normal(0, 0.01, len(t)), "x": np.round(x / Q_X) * Q_X,
            "theta": np.round(theta / Q_THETA) * Q_THETA}
    m = parse_measurements(format_csv(cols))
    assert m.resolution["theta"] == pytest.approx(Q_THETA, rel=1e-6)
    assert m.resolution["x"] == pytest.approx(Q_X, rel=1e-6)
    assert "u" not in m.resolution  # noisy analogue input: no step to find
    m = parse_measurements(format_csv(cols), options=opts(resolution={"theta": 1e-3}))
    assert m.resolution["theta"] == 1e-3


def test_resolution_of_a_12_bit_input_and_of_unquantised_data():
    lsb = 10.0 / 4095
    u = np.round((5 + 3 * np.sin(np.linspace(0, 20, 5000))) / lsb) * lsb
    assert estimate_resolution(u) == pytest.approx(lsb, rel=1e-6)
    assert estimate_resolution(np.sin(np.linspace(0, 20, 5000))) is None
    assert estimate_resolution(np.zeros(100)) is None


# ---------------------------------------------------------------- sample rates

def test_uniform_1khz_file_is_kept_as_is():
    t, theta, x, u = truth()
    m = parse_measurements(format_csv({"t": t, "u": u, "x": x, "theta": theta}), options=opts(uniform=True))
    assert np.array_equal(m.t, t) and m.notes == ()


def test_30_percent_rows_dropped_is_resampled_with_a_note():
    t, theta, x, u = truth(duration=5.0)
    keep = np.random.default_rng(5).random(len(t)) > 0.3
    keep[[0, -1]] = True
    cols = {"t": t[keep], "u": u[keep], "x": x[keep], "theta": theta[keep]}
    m = parse_measurements(format_csv(cols), options=opts(uniform=True))
    assert np.allclose(np.diff(m.t), 1e-3)
    assert m.notes and "non-uniform" in m.notes[0] and "linear interpolation" in m.notes[0]
    assert np.max(np.abs(m.theta - np.interp(m.t, t, theta))) < 1e-3


def test_long_gap_is_refused_with_its_line():
    t, theta, x, u = truth()
    keep = np.ones(len(t), bool)
    keep[1000:1050] = False   # 51 ms without data
    keep[200] = False
    cols = {"t": t[keep], "u": u[keep], "x": x[keep], "theta": theta[keep]}
    with pytest.raises(PendcError) as info:
        parse_measurements(format_csv(cols), source="gappy.csv", options=opts(uniform=True))
    msg = str(info.value)
    assert "gappy.csv: line 1001: a gap of 0.051 s" in msg and "too long" in msg


def test_rate_option_downsamples_and_upsamples():
    t, theta, x, u = truth()
    cols = format_csv({"t": t, "u": u, "x": x, "theta": theta})
    m = parse_measurements(cols, options=opts(uniform=True, rate=500.0))
    assert np.allclose(np.diff(m.t), 2e-3) and "blocks of 2" in m.notes[0]
    m = parse_measurements(cols, options=opts(uniform=True, rate=300.0))  # not an integer ratio
    assert np.allclose(np.diff(m.t), 1 / 300) and "each output interval" in m.notes[0]
    assert np.max(np.abs(m.x - np.interp(m.t, t, x))) < 1e-4
    m = parse_measurements(cols, options=opts(uniform=True, rate=2000.0))
    assert np.allclose(np.diff(m.t), 5e-4) and "upsampled" in m.notes[0]


def test_wrapped_angle_is_unwrapped_with_a_note():
    t = np.arange(3000) * 1e-3
    theta = 20.0 * t  # 60 rad: about ten turns
    wrapped = (theta + math.pi) % (2 * math.pi) - math.pi
    m = parse_measurements(format_csv({"t": t, "u": t * 0 + 5, "x": t * 0, "theta": wrapped}))
    assert np.allclose(m.theta, theta, atol=1e-9)
    assert any("wrapped" in n and "unwrapped" in n for n in m.notes)


# ---------------------------------------------------------------- streaming

MEMORY_PROBE = r"""
import json, resource, sys
import numpy as np, scipy.io
from pendc.sim import csvread, matread, plausibility, readers, resample
from pendc.sim.measurements import read_measurements
from pendc.model import plantfile
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
m = read_measurements(sys.argv[1], options=readers.ReadOptions(uniform=True, plausible=True))
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"rows": len(m.t), "extra": peak - base}))
"""
FIXED_BYTES = 12 << 20   # the reader's text blocks and loadtxt's buffers, whatever the file's length
BYTES_PER_ROW = 64       # 4 float64 columns (32 B) plus the checks' largest temporaries


def test_reading_streams_in_bounded_memory(tmp_path):
    """Peak memory grows by at most FIXED_BYTES + BYTES_PER_ROW * rows: a 1e7-row file then needs
    under 0.75 GiB (bench/bench_read_csv.py measures the real thing). Reading the whole text at
    once and splitting it into lines (the reader before streaming) costs ~4 bytes per byte of file:
    ~136 B per row here, 41 MB for this file, above the bound."""
    import json
    import subprocess

    rows = 300_000
    t = np.arange(rows) * 1e-3
    data = np.column_stack([t, 5 + np.sin(t), np.round(0.1 * np.sin(t) / Q_X) * Q_X,
                            np.round(np.sin(3 * t) / Q_THETA) * Q_THETA])
    path = tmp_path / "long.csv"
    with open(path, "w") as f:
        f.write("t,u,x,theta\n")
        np.savetxt(f, data, fmt=["%.3f", "%.6f", "%.7g", "%.9g"], delimiter=",")
    res = subprocess.run([sys.executable, "-c", MEMORY_PROBE, str(path)], capture_output=True, text=True,
                         check=True)
    probe = json.loads(res.stdout)
    assert probe["rows"] == rows
    assert probe["extra"] < FIXED_BYTES + BYTES_PER_ROW * rows, probe
    assert FIXED_BYTES + BYTES_PER_ROW * 10_000_000 < 0.75 * (1 << 30)


def test_file_without_header_mapped_by_column_number():
    t, theta, x, u = truth(duration=0.5)
    text = "# exported by writematrix\n" + "\n".join(
        f"{a!r} {b!r} {c!r} {d!r}" for a, b, c, d in zip(theta.tolist(), t.tolist(), x.tolist(), u.tolist())) + "\n"
    with pytest.raises(PendcError, match=r"line 2: no header row .* --columns t=1,u=2,x=3,theta=4"):
        parse_measurements(text)
    m = parse_measurements(text, options=opts(columns={"theta": "1", "t": "2", "x": "3", "u": "4"}))
    assert np.array_equal(m.theta, theta) and np.array_equal(m.t, t) and len(m.t) == len(t)


def test_units_as_numbers_for_encoder_counts():
    t, theta, x, u = truth()
    counts = {"t": t, "u": u, "x": np.round(x / Q_X), "theta": np.round(theta / Q_THETA)}
    m = parse_measurements(format_csv(counts), options=opts(theta_unit=repr(Q_THETA), x_unit="2.5e-6"))
    assert np.allclose(m.theta, theta, atol=Q_THETA) and np.allclose(m.x, x, atol=Q_X)
    assert m.resolution["theta"] == pytest.approx(Q_THETA) and m.resolution["x"] == pytest.approx(Q_X)
    with pytest.raises(PendcError, match=r"--x-unit 'inch': use one of m, cm, mm, or the size of one file unit in m"):
        opts(x_unit="inch")
    with pytest.raises(PendcError, match="--theta-unit '-1'"):
        opts(theta_unit="-1")


def test_header_in_windows_1252(tmp_path):
    t, theta, x, u = truth(duration=0.2)
    rows = "\n".join(";".join(repr(v) for v in r) for r in zip(t.tolist(), u.tolist(), x.tolist(), theta.tolist()))
    path = tmp_path / "export.csv"
    path.write_bytes("Zeit [s];Spannung [V];Position [m];Winkel [°]\n".encode("cp1252") + rows.encode() + b"\n")
    with pytest.raises(PendcError, match=r"line 1: not UTF-8 text \(byte 0xb0\).*--encoding cp1252"):
        read_measurements(path)
    cols = {"t": "Zeit [s]", "u": "Spannung [V]", "x": "Position [m]", "theta": "Winkel [°]"}
    m = read_measurements(path, options=opts(encoding="cp1252", columns=cols))
    assert np.array_equal(m.theta, theta)
    with pytest.raises(PendcError, match="--encoding 'klingon'"):
        read_measurements(path, options=opts(encoding="klingon"))


def test_wrapped_angle_balancing_at_upright_is_not_an_outlier():
    t = np.arange(2000) * 1e-3
    rng = np.random.default_rng(4)
    theta = np.pi + np.cumsum(rng.normal(0, 0.002, len(t)))  # wandering around upright
    wrapped = (theta + math.pi) % (2 * math.pi) - math.pi     # crosses +-pi back and forth
    assert np.sum(np.abs(np.diff(wrapped)) > math.pi) > 2
    m = parse_measurements(format_csv({"t": t, "u": t * 0 + 5, "x": t * 0, "theta": wrapped}))
    assert np.allclose(m.theta - m.theta[0], theta - theta[0], atol=1e-9)


def test_sparse_input_file_is_not_taken_for_milliseconds():
    """An input for pendc simulate may be a few steps seconds apart; a recorded motion may not."""
    m = parse_measurements("t,u\n0,5\n1,6\n3,5\n4,5\n", required=("t", "u"))
    assert m.t.tolist() == [0.0, 1.0, 3.0, 4.0]
    with pytest.raises(PendcError, match="t looks like milliseconds"):
        parse_measurements("t,u,x,theta\n0,5,0,0\n1,6,0,0\n3,5,0,0\n4,5,0,0\n", options=opts(plausible=True))


def test_limits_are_checked_for_identification_not_for_a_simulation_output():
    t, theta, x, u = truth()
    text = format_csv({"t": t, "u": u, "x": x + 1.5, "theta": theta})  # a simulated cart off the track
    assert parse_measurements(text).x.max() > 1.5
    with pytest.raises(PendcError, match="column 'x' looks like centimetres"):
        parse_measurements(text, options=opts(plausible=True))


def test_a_plant_that_declares_a_fast_wheel_is_read_at_its_speed(tmp_path):
    """A reaction wheel at 200 rad/s (its plant file's training rate 250 rad/s) is no unit mistake
    nor degrees (the private check: the tool refused its own simulated data), a pendulum angle
    in degrees still is, and a unit given for the column is taken at its word."""
    from pathlib import Path

    from pendc.model.modelfile import load_model
    from pendc.sim.readers import ReadOptions
    model = load_model(str(Path(__file__).parent / "data" / "reaction_wheel.toml"))
    t = np.arange(2001) * 1e-3
    rows = ["t,u,theta,phi,dphi"] + [f"{a!r},1.0,{0.01 * math.sin(a)!r},{200.0 * a!r},200.0" for a in t.tolist()]
    path = tmp_path / "spin.csv"
    path.write_text("\n".join(rows) + "\n")
    data = read_measurements(str(path), options=ReadOptions(plant=model, uniform=True, plausible=True))
    assert float(np.max(data.column("phi"))) == pytest.approx(400.0)
    rows = ["t,u,theta,phi"] + [f"{a!r},1.0,{math.degrees(3.0 * math.sin(5 * a))!r},0.0" for a in t.tolist()]
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(PendcError, match="'theta' looks like degrees"):
        read_measurements(str(path), options=ReadOptions(plant=model, uniform=True, plausible=True))
    given = read_measurements(str(path), options=ReadOptions(plant=model, uniform=True, plausible=True,
                                                               units={"theta": 1.0}))
    assert float(np.max(given.column("theta"))) > 100.0


def test_a_whirling_angle_pendc_wrote_is_radians():
    """Round G: pendc simulate's own run of a Pendubot whose elbow whirled nine turns was refused
    as degrees (max |q2| = 55.7, faster than a bench rig between samples), and the error offered
    only --q2-unit deg. A file pendc wrote is in radians; the error names both units."""
    t = np.arange(2000) * 1e-3
    theta = np.cumsum(np.full(len(t), 0.07))      # 70 rad/s: 140 rad in 2 s
    text = format_csv({"t": t, "u": t * 0 + 5, "x": t * 0, "theta": theta})
    with pytest.raises(PendcError, match=r"looks like degrees.*--theta-unit rad if they are radians"):
        parse_measurements(text, options=opts(plausible=True))
    ours = format_csv({"t": t, "u": t * 0 + 5, "x": t * 0, "theta": theta}, meta={"generator": "pendc simulate"})
    assert parse_measurements(ours, options=opts(plausible=True)).theta.max() == pytest.approx(theta.max())
