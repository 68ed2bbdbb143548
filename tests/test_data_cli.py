"""Reading data through the commands (pendc compare / diagnose / fit): options, hostile files.

Every hostile file gets one ``pendc: error:`` line naming the problem, exit status 2,
no Python warning or traceback on stderr, and no output file. The good files go
through ``pendc compare`` with options only (no converter).
"""

import io
import json
import math
import sys

import numpy as np
import pytest
import scipy.io as sio

from pendc.cli import main
from pendc.sim.measurements import format_csv, read_measurements

ROOT_DATA = "data/hidden_spring.csv"


def signals(duration=20.0, rate=1000.0):
    """Plausible 1 kHz signals (no simulation needed to test reading)."""
    t = np.arange(int(round(duration * rate))) / rate
    return {"t": t, "u": 5.0 + 2.0 * np.sin(2 * np.pi * 0.5 * t), "x": 0.1 * np.sin(2 * np.pi * 0.5 * t),
            "theta": 0.8 * np.sin(2 * np.pi * 0.9 * t)}


def with_row(cols, name, row, value):
    out = {k: v.copy() for k, v in cols.items()}
    out[name][row] = value
    return out


def scaled(cols, **factors):
    return {k: v * factors.get(k, 1.0) for k, v in cols.items()}


def csv(cols, meta=None):
    return format_csv(cols, meta)


def v73(path):
    head = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
    path.write_bytes(head.ljust(512, b" ") + b"\x89HDF\r\n\x1a\n" + bytes(64))


def odd_mat(path):
    sio.savemat(path, {"alpha": np.arange(50.0), "beta": np.ones((50, 2))})


def gappy(cols):
    keep = np.ones(len(cols["t"]), bool)
    keep[5000:5100] = False
    return {k: v[keep] for k, v in cols.items()}


BASE = signals()
# name -> (file text or writer, extra args, words the message must hold)
HOSTILE = {
    "time_in_ms": (csv(scaled(BASE, t=1e3)), [], ["t looks like milliseconds", "--t-unit ms", "last t = 19999"]),
    "x_in_mm": (csv(scaled(BASE, x=1e3)), [], ["column 'x' looks like millimetres", "--x-unit mm", "0.75 m"]),
    "x_in_cm": (csv(scaled(BASE, x=1e2)), [], ["looks like centimetres", "--x-unit cm"]),
    "u_in_mV": (csv(scaled(BASE, u=1e3)), [], ["column 'u' looks like millivolts", "--u-unit mV", "spans 0-10 V"]),
    "theta_in_degrees": (csv(scaled(BASE, theta=180 / math.pi * 5)), [], ["'theta' looks like degrees",
                                                                         "--theta-unit deg"]),
    "outlier_x": (csv(with_row(BASE, "x", 1233, 1e30)), [], ["line 1235: x = 1e+30 is an outlier"]),
    "outlier_u": (csv(with_row(BASE, "u", 77, 1e30)), [], ["line 79: u = 1e+30 is an outlier"]),
    "outlier_theta": (csv(with_row(BASE, "theta", 4000, 1e30)), [], ["line 4002: theta = 1e+30 is an outlier"]),
    "outlier_t": (csv(with_row(BASE, "t", 500, 1e30)), [], ["line 502: t = 1e+30 is an outlier"]),
    "outlier_last_t": (csv(with_row(BASE, "t", 19999, 1e30)), [], ["line 20001: t jumps from 19.998 to 1e+30",
                                                                  "an outlier"]),
    "nan_theta": (csv(with_row(BASE, "theta", 10, np.nan)), [], ["line 12: column 'theta' is nan"]),
    "inf_u": (csv(with_row(BASE, "u", 10, np.inf)), [], ["line 12: column 'u' is inf"]),
    "time_decreases": (csv(with_row(BASE, "t", 100, 0.05)), [], ["line 102: time decreases"]),
    "time_duplicated": (csv(with_row(BASE, "t", 100, 0.099)), [], ["line 102: duplicate time t = 0.099"]),
    "truncated_row": (csv(BASE)[:csv(BASE).rstrip().rfind(",") - 3], [], ["line 20001: 3 fields, expected 4",
                                                                        "truncated"]),
    "not_a_number": ("t,u,x,theta\n0,5,0,0\n0.001,5,zero,0\n", [], ["line 3: column 'x': not a number: 'zero'"]),
    "empty": ("", [], ["file is empty"]),
    "header_only": ("t,u,x,theta\n", [], ["no data rows"]),
    "gap_too_long": (csv(gappy(BASE)), [], ["a gap of 0.101 s", "too long to interpolate"]),
    "missing_theta": (csv({k: v for k, v in BASE.items() if k != "theta"}), [],
                      ["missing column(s) theta", "--experiment pendulum_removed"]),
    "unknown_column_map": (csv(BASE), ["--columns", "theta=Theta1"],
                           ["--columns theta=Theta1: no such column", "names found: t, u, x, theta"]),
    "unknown_experiment": (csv(BASE, {"experiment": "clamped"}), [], ["unknown experiment 'clamped'",
                                                                      "cart_held"]),
    "mat_v73": (v73, [], ["v7.3", "-v7"]),
    "mat_unmappable": (odd_mat, [], ["missing column(s)", "alpha, beta:1, beta:2"]),
    "bad_columns_syntax": (csv(BASE), ["--columns", "theta"], ["--columns", "PENDC_NAME=FILE_NAME"]),
    "bad_separator": (csv(BASE), ["--separator", "ab"], ["--separator 'ab'"]),
    "bad_rate": (csv(BASE), ["--rate", "-5"], ["--rate", "positive"]),
}


def run(argv, capsys):
    rc = main(argv)
    out, err = capsys.readouterr()
    assert "Warning" not in err and "Traceback" not in err, err
    return rc, out, err


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_hostile_file_through_compare(case, tmp_path, capsys):
    content, extra, words = HOSTILE[case]
    path = tmp_path / (f"{case}.mat" if callable(content) else f"{case}.csv")
    if callable(content):
        content(path)
    else:
        path.write_text(content)
    before = sorted(p.name for p in tmp_path.iterdir())
    html = tmp_path / "report.html"
    rc, out, err = run(["compare", str(path), "--html", str(html), *extra], capsys)
    assert rc == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pendc: error: "), err
    for w in words:
        assert w in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written


def test_experiment_list_must_match_the_files(tmp_path, capsys):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text(csv(BASE))
    b.write_text(csv(BASE))
    rc, _, err = run(["diagnose", str(a), str(b), "--experiment", "free,cart_held,free"], capsys)
    assert rc == 2 and "--experiment names 3 experiments for 2 data files" in err


def test_stdin_read_only_once(capsys):
    rc, _, err = run(["diagnose", "-", "-"], capsys)
    assert rc == 2 and "standard input" in err


@pytest.fixture(scope="module")
def recording():
    """4 s of the project's simulated rig data (quantised encoders, noisy input)."""
    m = read_measurements(ROOT_DATA)
    n = 4000
    return {k: np.asarray(m.columns[k][:n]) for k in ("t", "u", "x", "theta")}


def test_simulink_mat_10khz_degrees_from_upright_through_compare(recording, tmp_path, capsys):
    r = recording
    t = np.arange(0, r["t"][-1], 1e-4)
    cols = {k: np.interp(t, r["t"], r[k]) for k in ("theta", "x", "u")}
    values = np.column_stack([np.degrees(cols["theta"] - math.pi), cols["x"], cols["u"]])
    path = tmp_path / "swing.mat"
    sio.savemat(path, {"simout": {"time": t[:, None], "signals": {
        "values": values, "dimensions": 3.0, "label": "", "blockName": "rig/To Workspace"}}})
    html = tmp_path / "r.html"
    rc, out, err = run(["compare", str(path), "--columns", "theta=simout:1,x=simout:2,u=simout:3",
                        "--theta-unit", "deg", "--theta-zero", "upright", "--json", "--html", str(html)], capsys)
    assert rc == 0, err
    assert err.startswith("pendc: note: ") and "decimated from 10 kHz" in err and len(err.splitlines()) == 1
    report = json.loads(out)
    assert html.exists()
    # Same figures as for the 1 kHz original: the reader undid degrees, the upright zero and the rate.
    rc, out1, _ = run(["compare", _write(tmp_path / "orig.csv", r), "--json"], capsys)
    original = json.loads(out1)
    for key in ("fit", "fit_horizon"):
        for axis in ("x", "theta"):
            assert abs(report[key][axis] - original[key][axis]) < 2.0, (key, axis, report[key], original[key])
    assert original["samples"] == 4000 and report["samples"] == 3999  # 39990 samples at 10 kHz


def test_gappy_csv_is_resampled_through_compare_with_a_note(recording, tmp_path, capsys):
    r = recording
    keep = np.random.default_rng(1).random(len(r["t"])) > 0.3
    keep[[0, -1]] = True
    path = _write(tmp_path / "gappy.csv", {k: v[keep] for k, v in r.items()})
    rc, out, err = run(["compare", path, "--json"], capsys)
    assert rc == 0 and "pendc: note:" in err and "non-uniform sampling" in err and "1 kHz" in err


def test_cart_held_from_stdin_through_compare(recording, monkeypatch, tmp_path, capsys):
    text = format_csv({"t": recording["t"], "theta": recording["theta"]}, {"experiment": "cart_held"})
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(text.encode())))
    rc, out, err = run(["compare", "-", "--json", "--u-value", "5.264616"], capsys)
    assert rc == 0, err
    assert "no x, u in the file (cart_held experiment)" in err


def test_help_shows_every_reading_option_with_examples(capsys):
    for command in ("compare", "diagnose", "fit"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        out = capsys.readouterr().out
        for option in ("--columns", "--separator", "--t-unit", "--x-unit", "--u-unit", "--theta-unit",
                       "--theta-zero", "--theta-sign", "--experiment", "--missing", "--u-value", "--resolution",
                       "--sample-time", "--rate"):
            assert option in out, (command, option)
        for example in ("--columns t=Time,theta=Theta1", "--theta-zero upright", "--separator tab",
                        "--sample-time", "--experiment cart_held", f"pendc {command} -"):
            assert example in out, (command, example)


def _write(path, cols):
    path.write_text(format_csv(cols))
    return str(path)


def test_clamped_cart_swing_mat_through_fit(tmp_path, capsys):
    """The issue's recording: a free swing with the cart clamped, Simulink To Workspace at 10 kHz,
    theta in degrees from upright, no x and no u logged, the experiment named in the file."""
    t = np.arange(0, 3.0, 1e-4)
    q = 2 * math.pi / 20000
    theta = np.round(0.6 * np.cos(2 * math.pi * 1.07 * t) * np.exp(-0.05 * t) / q) * q
    path = tmp_path / "held.mat"
    sio.savemat(path, {"experiment": "cart_held", "theta": {"time": t[:, None], "signals": {
        "values": np.degrees(theta - math.pi)[:, None], "dimensions": 1.0, "label": "Theta",
        "blockName": "rig/Theta"}}})
    out_model = tmp_path / "fitted.toml"
    rc, out, err = run(["fit", str(path), "--theta-unit", "deg", "--theta-zero", "upright", "--free", "I",
                        "-o", str(out_model), "--max-evaluations", "8"], capsys)
    assert rc == 0, err
    assert "no x, u in the file (cart_held experiment)" in err and "decimated from 10 kHz" in err
    assert all(line.startswith("pendc: note: ") for line in err.strip().splitlines()), err
    assert out_model.exists() and "I" in out


def test_one_experiment_per_file_and_options_from_a_namespace(tmp_path, capsys):
    """load_datasets takes any object with the options' attributes (absent ones: defaults)."""
    import argparse

    from pendc.cli.data import load_datasets

    held = tmp_path / "held.csv"
    held.write_text(csv({"t": BASE["t"], "theta": BASE["theta"]}))
    cart = tmp_path / "cart.csv"
    cart.write_text(csv({k: BASE[k] for k in ("t", "u", "x")}))
    args = argparse.Namespace(data=[str(held), str(cart)], experiment="cart_held,pendulum_removed")
    a, b = load_datasets(args)
    assert (a.experiment, a.missing) == ("cart_held", ("x", "u"))
    assert (b.experiment, b.missing) == ("pendulum_removed", ("theta",))
    err = capsys.readouterr().err
    assert err.count("pendc: note:") == 2 and "Warning" not in err
    extra = tmp_path / "validate.csv"
    extra.write_text(csv({"t": BASE["t"], "theta": BASE["theta"]}, {"experiment": "cart_held"}))
    (v,) = load_datasets(args, [str(extra)])  # a --validate file: its own '# experiment:' line
    assert v.experiment == "cart_held"


def test_reading_arguments_round_trip(tmp_path):
    """The words reading_arguments gives back parse to the same reading options."""
    from pendc.cli import build_parser
    from pendc.cli.data import read_options, reading_arguments

    given = ["compare", "run.csv", "--columns", "t=Zeit [s],theta=Winkel", "--theta-unit", "deg", "--theta-zero",
             "upright", "--theta-sign", "-1", "--experiment", "cart_held", "--u-value", "5.2", "--rate", "500",
             "--resolution", "theta=0.001", "--decimal", "comma", "--separator", "tab", "--encoding", "cp1252"]
    args = build_parser().parse_args(given)
    import shlex

    again = build_parser().parse_args(["compare", "run.csv", *shlex.split(" ".join(reading_arguments(args)))])
    assert read_options(again) == read_options(args)
    assert reading_arguments(build_parser().parse_args(["compare", "run.csv"])) == []


def test_mat_through_diagnose(tmp_path, capsys):
    """diagnose reads the issue's .mat (10 kHz, degrees from upright, cart held) with options only."""
    t = np.arange(0, 1.5, 1e-4)
    q = 2 * math.pi / 20000
    theta = np.round(0.6 * np.cos(2 * math.pi * 1.07 * t) * np.exp(-0.05 * t) / q) * q
    path = tmp_path / "held.mat"
    sio.savemat(path, {"experiment": "cart_held", "theta": {"time": t[:, None], "signals": {
        "values": np.degrees(theta - math.pi)[:, None], "dimensions": 1.0, "label": "Theta",
        "blockName": "rig/Theta"}}})
    rc, out, err = run(["diagnose", str(path), "--theta-unit", "deg", "--theta-zero", "upright", "--workers", "1",
                        "--json"], capsys)
    assert rc == 0, err
    assert all(line.startswith("pendc: note: ") for line in err.strip().splitlines()), err
    report = json.loads(out)
    assert report["candidates"]
