"""MATLAB .mat files as Simulink's To Workspace block and MATLAB users save them.

Each file is written with scipy.io.savemat in the exact layout MATLAB uses (struct with
``time`` (N x 1) and ``signals`` with ``values``, ``dimensions``, ``label``,
``blockName``), and what pendc reads is compared with the signals it was made from.
"""

import math

import numpy as np
import pytest
import scipy.io as sio

from measurement_samples import opts, simulink_struct, truth
from pendc.errors import PendcError
from pendc.sim.measurements import read_measurements


def test_simulink_structure_with_time_10khz_degrees_from_upright(tmp_path):
    """The issue's file: one To Workspace block, [theta x u] at 10 kHz, theta in degrees from upright."""
    t, theta, x, u = truth(rate=10_000.0)
    theta_file = np.degrees(theta - math.pi)  # 0 upright; pendc's theta = file + pi
    path = tmp_path / "swing.mat"
    sio.savemat(path, {"simout": simulink_struct(t, np.column_stack([theta_file, x, u]))})
    m = read_measurements(path, options=opts(columns={"theta": "simout:1", "x": "simout:2", "u": "simout:3"},
                                             theta_unit="deg", theta_zero="upright", uniform=True))
    assert np.allclose(np.diff(m.t), 1e-3)  # decimated to 1 kHz
    assert len(m.t) == len(t) // 10
    assert any("decimated from 10 kHz" in n and "1 kHz" in n for n in m.notes)
    # Each sample is the mean of a 10-sample block, placed at the block's centre: compare with the
    # truth there (the boxcar's curvature error is ~(1 ms)^2/24 * |theta''| < 1e-6 rad).
    t_true, th_true, x_true, u_true = truth(rate=10_000.0)
    centre = t_true[: len(m.t) * 10].reshape(-1, 10).mean(axis=1)
    assert np.allclose(m.t, centre)
    assert np.max(np.abs(m.theta - np.interp(m.t, t_true, th_true))) < 1e-5
    assert np.max(np.abs(m.x - np.interp(m.t, t_true, x_true))) < 1e-6
    assert m.experiment == "free" and m.missing == ()


def test_simulink_signals_array_with_labels_map_themselves(tmp_path):
    t, theta, x, u = truth()
    dtype = [("values", "O"), ("dimensions", "O"), ("label", "O"), ("blockName", "O")]
    signals = np.array([(theta[:, None], 1.0, "theta", "rig/Angle"), (x[:, None], 1.0, "x", "rig/Pos"),
                        (u[:, None], 1.0, "u", "rig/Drive")], dtype=dtype).reshape(1, 3)
    path = tmp_path / "run.mat"
    sio.savemat(path, {"logs": {"time": t[:, None], "signals": signals}})
    m = read_measurements(path)
    assert np.array_equal(m.t, t) and np.array_equal(m.theta, theta) and np.array_equal(m.u, u)


def test_one_variable_per_block_with_tout(tmp_path):
    """Several To Workspace blocks ('Structure', no time) plus the model's tout, combined."""
    t, theta, x, u = truth()
    path = tmp_path / "run.mat"
    sio.savemat(path, {"Theta": simulink_struct(t, theta, time=False), "X": simulink_struct(t, x, time=False),
                       "U": simulink_struct(t, u, time=False), "tout": t[:, None]})
    m = read_measurements(path)  # names match case-insensitively, tout is the time
    assert np.array_equal(m.t, t) and np.array_equal(m.x, x) and np.array_equal(m.theta, theta)


def test_structure_without_time_needs_sample_time(tmp_path):
    t, theta, x, u = truth()
    path = tmp_path / "run.mat"
    sio.savemat(path, {"data": simulink_struct(t, np.column_stack([u, x, theta]), time=False)})
    cols = {"u": "data:1", "x": "data:2", "theta": "data:3"}
    with pytest.raises(PendcError) as info:
        read_measurements(path, options=opts(columns=cols))
    msg = str(info.value)
    assert "no time" in msg and "--sample-time" in msg and "data:1, data:2, data:3" in msg
    m = read_measurements(path, options=opts(columns=cols, sample_time=1e-3))
    assert np.allclose(m.t, t) and np.array_equal(m.theta, theta)
    assert any("no time vector" in n for n in m.notes)
    sio.savemat(path, {"data": simulink_struct(t, np.column_stack([u, x, theta]), time=False), "Ts": 1e-3})
    m = read_measurements(path, options=opts(columns=cols))  # the sample time saved beside the data
    assert np.allclose(m.t, t)
    sio.savemat(path, {"data": simulink_struct(t, np.column_stack([u, x, theta]), time=False), "Ts": "fast"})
    with pytest.raises(PendcError, match="no time"):
        read_measurements(path, options=opts(columns=cols))


def test_array_format_matrix_and_named_vectors(tmp_path):
    t, theta, x, u = truth()
    path = tmp_path / "arr.mat"
    sio.savemat(path, {"rec": np.column_stack([t, u, x, theta])})  # Simulink 'Array' with time first
    m = read_measurements(path, options=opts(columns={"t": "rec:1", "u": "rec:2", "x": "rec:3", "theta": "rec:4"}))
    assert np.array_equal(m.theta, theta) and np.array_equal(m.t, t)
    path = tmp_path / "vec.mat"
    sio.savemat(path, {"t": t, "u": u, "x": x, "theta": theta, "experiment": "free"})  # row vectors
    m = read_measurements(path)
    assert np.array_equal(m.x, x) and m.meta["experiment"] == "free"


def test_timeseries_like_structs(tmp_path):
    t, theta, x, u = truth()
    path = tmp_path / "ts.mat"
    sio.savemat(path, {name: {"Time": t[:, None], "Data": v[:, None]} for name, v in
                       (("theta", theta), ("x", x), ("u", u))})
    m = read_measurements(path)
    assert np.array_equal(m.t, t) and np.array_equal(m.theta, theta)


def test_signals_with_different_time_vectors_are_interpolated(tmp_path):
    t, theta, x, u = truth()
    t2 = t[::2]
    path = tmp_path / "two_rates.mat"
    sio.savemat(path, {"theta": simulink_struct(t, theta), "x": simulink_struct(t, x),
                       "u": simulink_struct(t2, u[::2])})
    m = read_measurements(path)
    assert np.array_equal(m.t, t[:-1])  # t2 ends one sample earlier: nothing is extrapolated
    assert np.array_equal(m.theta, theta[:-1])
    assert np.max(np.abs(m.u - u[:-1])) < 1e-4  # linear interpolation of a 0.5 Hz sine at 500 Hz
    assert any("own time vector" in n for n in m.notes)


def test_mat_that_cannot_be_mapped_lists_the_names(tmp_path):
    t, theta, x, u = truth()
    path = tmp_path / "odd.mat"
    sio.savemat(path, {"a": t, "b": theta, "c": np.column_stack([x, u])})
    with pytest.raises(PendcError) as info:
        read_measurements(path)
    msg = str(info.value)
    assert "\n" not in msg and "missing" in msg and "a, b, c:1, c:2" in msg and "--columns" in msg
    with pytest.raises(PendcError, match=r"--columns theta=q: no such column.*names found: a, b, c:1, c:2"):
        read_measurements(path, options=opts(columns={"theta": "q"}))


def test_mat_v73_is_refused_with_the_way_out(tmp_path):
    path = tmp_path / "big.mat"
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
    path.write_bytes(header.ljust(512, b" ") + b"\x89HDF\r\n\x1a\n" + bytes(64))
    with pytest.raises(PendcError) as info:
        read_measurements(path)
    msg = str(info.value)
    assert "v7.3" in msg and "-v7" in msg and "\n" not in msg


def test_damaged_mat_file(tmp_path):
    path = tmp_path / "cut.mat"
    good = tmp_path / "good.mat"
    t, theta, x, u = truth()
    sio.savemat(good, {"t": t, "u": u, "x": x, "theta": theta})
    path.write_bytes(good.read_bytes()[:300])
    with pytest.raises(PendcError) as info:
        read_measurements(path)
    assert "\n" not in str(info.value) and str(path) in str(info.value)


def test_mat_without_numeric_signals_and_cell_arrays(tmp_path):
    path = tmp_path / "notes.mat"
    sio.savemat(path, {"comment": "swing test", "names": np.array(["theta", "x"], dtype=object)})
    with pytest.raises(PendcError, match=r"no numeric signal in the file \(variables found: comment, names\)"):
        read_measurements(path)
    t, theta, x, u = truth()
    cells = np.empty((1, 3), dtype=object)
    cells[0, 0], cells[0, 1], cells[0, 2] = theta, x, u
    path = tmp_path / "cells.mat"
    sio.savemat(path, {"log": cells, "tout": t})
    m = read_measurements(path, options=opts(columns={"theta": "log{1}", "x": "log{2}", "u": "log{3}"}))
    assert np.array_equal(m.theta, theta) and np.array_equal(m.t, t)


def test_mat_with_malformed_simulink_struct(tmp_path):
    t, theta, x, u = truth()
    path = tmp_path / "odd.mat"
    sio.savemat(path, {"sim": {"time": {"a": 1.0}, "signals": {"values": "text", "label": "theta"}},
                       "x": x, "u": u, "tout": t})
    with pytest.raises(PendcError) as info:
        read_measurements(path)
    msg = str(info.value)
    assert "\n" not in msg and "missing column(s) theta" in msg and "x, u, tout" in msg
    assert "not readable here: sim: MATLAB objects or malformed structs" in msg
