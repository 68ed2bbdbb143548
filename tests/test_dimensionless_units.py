"""A dimensionless unit ("-", "1" or "") is printed as nothing after a value and as the word
"dimensionless" where it stands alone, never as a stray '-': in hil's summary keys and lines,
simulate's and the readers' input checks, compare's regime words and tables, the plots' labels.
Before, a duty cycle d read "give d in -", "0.5 -", "d (-)" and hil --json gave "max_abs_x_-"."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from cli_capture import run_cli
from pendc.model.modelfile import parse_model

# a first-order lag of a duty cycle in state form: the input d and the state x have no unit
LAG = """
[plant]
name = "lag"
core = "lag_core"
summary = "a first-order lag of a duty cycle"
tau = 1e-3

[constants]
tau = { unit = "s", meaning = "time constant", bounds = [1e-6, 1.0] }

[states.x]
unit = "-"
meaning = "normalised output"
derivative = "(d - x)/tau"
initial = 0.0
range = [-0.5, 1.5]

[inputs.d]
unit = "-"
meaning = "duty cycle"
range = [0.0, 1.0]
neutral = 0.5

[sensors.adc_x]
kind = "adc"
state = "x"
bits = 12
range = [-0.5, 1.5]

[operating_points]
half = { x = "0.5" }
"""

# a value followed by a bare '-' ("0.5 -", "10 -,", "0.5 -)") or a "(-)" label
STRAY = re.compile(r"\d -(?:[,;:)]|$)|\(-\)", re.MULTILINE)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("lag")
    model = folder / "lag.toml"
    model.write_text(LAG, encoding="utf-8")
    t = np.arange(2000) * 1e-5
    d = 0.5 + 0.4 * np.sin(2 * math.pi * 100 * t) + np.where((np.arange(2000) // 137) % 2, 0.05, -0.05)
    drive = folder / "drive.csv"
    drive.write_text("t,d\n" + "".join(f"{a:.6f},{b:.6f}\n" for a, b in zip(t, d)), encoding="utf-8")
    return folder, model, drive


def test_hil_summary_keys_and_lines_have_no_stray_dash(files, tmp_path, capsys, monkeypatch):
    _, model, _ = files
    run = ("hil", "--model", model, "--controller", "lqr", "--start", "half", "--seconds", "0.002",
           "--period", "1e-5")
    rc, out, err = run_cli(capsys, *run, "--json")
    assert rc == 0, err
    summary = json.loads(out)
    assert "max_abs_x" in summary and "hold_x" in summary              # were max_abs_x_- and hold_x_-
    assert not [k for k in summary if "-" in k]

    import matplotlib.axes

    labels = []
    original = matplotlib.axes.Axes.set_ylabel
    monkeypatch.setattr(matplotlib.axes.Axes, "set_ylabel",
                        lambda ax, label, *a, **k: (labels.append(label), original(ax, label, *a, **k))[1])
    rc, out, err = run_cli(capsys, *run, "--out", tmp_path / "run")
    assert rc == 0, err
    assert re.search(r"^max \|x\| = \d\.\d{4}, 0 controller switches$", out, re.MULTILINE), out
    assert re.search(r"from operating point half: max \|x - 0\.5\| = [\d.e-]+$", out, re.MULTILINE), out
    assert not STRAY.search(out), out
    assert labels == ["x (dimensionless)", "d (dimensionless)"]                  # were "x (-)", "d (-)"
    written = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert not [k for k in written if "-" in k]


def test_simulate_names_no_unit_for_a_dimensionless_input(files, tmp_path, capsys):
    folder, model, _ = files
    percent = folder / "percent.csv"
    percent.write_text("t,d\n" + "".join(f"{k * 1e-5:.6f},{50 if k > 50 else 0}\n" for k in range(200)))
    rc, _, err = run_cli(capsys, "simulate", "--model", model, "--input", percent, "-o", tmp_path / "o.csv")
    assert rc == 2
    # was: looks like another unit than - (149 of 200 values beyond 10 -, ...): give d in -
    assert "looks like a percentage or another scale (149 of 200 values beyond 10, max |d| = 50;" in err
    assert "give d as a plain number" in err and "in -" not in err and not STRAY.search(err)

    spike = folder / "spike.csv"
    spike.write_text("t,d\n" + "".join(f"{k * 1e-5:.6f},{3.0 if k == 120 else 0.6}\n" for k in range(200)))
    rc, _, err = run_cli(capsys, "simulate", "--model", model, "--input", spike, "-o", tmp_path / "o.csv")
    assert rc == 0, err
    assert "d outside 0-1 in 1 of 200 samples (min 0.6, max 3)" in err              # was "0-1 - in", "3 -)"


def test_compare_reads_and_reports_a_dimensionless_signal(files, tmp_path, capsys):
    folder, model, drive = files
    sim = tmp_path / "sim.csv"
    rc, _, err = run_cli(capsys, "simulate", "--model", model, "--input", drive, "-o", sim)
    assert rc == 0, err
    rc, out, err = run_cli(capsys, "compare", "--model", model, sim)
    assert rc == 0, err
    assert re.search(r"x +rms error [\d.e-]+ \(data spread [\d.e-]+\)", out), out       # was "0.0015 - (... 0.245 -)"
    assert re.search(r"rms +[\d.e-]+ +100\.0 % of the x error", out), out
    assert not STRAY.search(out), out

    # data logged in percent: the readers' check suggests the scale, not a unit named '-'
    lines = sim.read_text().splitlines()
    head = next(k for k, ln in enumerate(lines) if not ln.startswith("#"))
    col = lines[head].split(",").index("d")
    scaled = [",".join(f"{float(v) * 100:g}" if j == col else v for j, v in enumerate(ln.split(",")))
              for ln in lines[head + 1:]]
    percent = tmp_path / "percent.csv"
    percent.write_text("\n".join(lines[:head + 1] + scaled) + "\n")
    rc, _, err = run_cli(capsys, "compare", "--model", model, percent)
    assert rc == 2 and "looks like a percentage or another scale" in err and "use --d-unit 0.01 if it is in percent" in err
    assert not STRAY.search(err), err
    rc, _, err = run_cli(capsys, "compare", "--model", model, percent, "--d-unit", "0.01")
    assert rc == 0, err


def test_side_by_side_prints_a_small_dimensionless_rms_with_its_digits(files, tmp_path, capsys):
    """Round H: a duty cycle's rms errors of a few thousandths were printed 0.00 in compare's
    side-by-side table (two decimals for every figure), in the text and the HTML alike."""
    folder, model, drive = files
    sim = tmp_path / "sim.csv"
    rc, _, err = run_cli(capsys, "simulate", "--model", model, "--input", drive, "-o", sim)
    assert rc == 0, err
    slower = tmp_path / "slower.toml"
    slower.write_text(LAG.replace("tau = 1e-3", "tau = 1.05e-3"), encoding="utf-8")
    page = tmp_path / "cmp.html"
    rc, out, err = run_cli(capsys, "compare", "--model", model, "--model", slower, sim, "--html", page)
    assert rc == 0, err
    row = next(ln for ln in out.splitlines() if ln.startswith("free-run rms error x "))
    first, second, change = row.split()[-3:]
    assert 0 < float(first) < float(second) < 0.1 and float(change) > 0, row       # was 0.00  0.01  +0.01
    assert float(second) == pytest.approx(float(change) + float(first), abs=2e-5), row
    assert len(second.split(".")[1].lstrip("0")) >= 2, row        # three significant digits
    assert f"<td>{second}</td>" in page.read_text(encoding="utf-8")


def test_a_small_unit_is_kept_for_small_values_only():
    """Round I: a state in volts printed '1.77e+03 mV' (rms error 1.77 V)."""
    from pendc.ident.units import amount_in, small_scale, table_digits

    assert amount_in("V", 1.77) == "1.77 V" and amount_in("V", 0.0177) == "17.7 mV"
    assert amount_in("m", 2.5) == "2.5 m" and amount_in("rad", 1.5) == "1.5 rad"
    assert small_scale("V", 0.9) == (1e3, "mV") and small_scale("V", 1.0) == (1.0, "V")
    assert table_digits([0.0031, 0.0002], "-") == 5 and table_digits([1.77, 0.01], "V") == 2
    assert table_digits([3.0], "turns") == 0 and table_digits([0.001], "%") == 2


def test_regime_words_and_report_labels_name_no_unit():
    from pendc.ident.regimes import regime_partitions
    from pendc.ident.units import amount_in, axis_label, labelled
    from pendc.sim.read_options import unit_factor

    model = parse_model(LAG)
    u = np.linspace(0.0, 1.0, 50)
    definitions = [d for _, members in regime_partitions(model, {"x": u}, u, 0.5) for _, d, _ in members]
    # was "|d - input_centre| < 0.5 -, input_centre = 0.5 -", "0.005 < d < 0.995 -"
    # a 0-1 duty cycle's weak drive is 5 % of its span (at 0.5 every sample was weak)
    assert "|d - input_centre| < 0.05, input_centre = 0.5" in definitions
    assert "0.005 < d < 0.995" in definitions and "d <= 0.005 or >= 0.995" in definitions
    assert not [d for d in definitions if STRAY.search(d)]
    assert amount_in("-", 0.0015) == "0.0015" and amount_in("m", 0.0015) == "1.5 mm"
    assert labelled("rms error x", "-") == "rms error x" and labelled("fit x", "%") == "fit x (%)"
    assert axis_label("x", "1") == "x (dimensionless)" and axis_label("x", "rad") == "x (rad)"
    with pytest.raises(Exception, match=r"d is dimensionless: give the size of one file unit"):
        unit_factor("d", "percent", model)
    assert unit_factor("d", "0.01", model) == pytest.approx(0.01)


@pytest.mark.parametrize("unit", ["-", "1", "", " - "])
def test_a_json_key_ends_with_no_dimensionless_unit(unit):
    from pendc.model.interface import unit_key

    assert unit_key("max_abs_x", unit) == "max_abs_x"
    assert unit_key("max_abs_x", "m") == "max_abs_x_m" and unit_key("hold_w", "rad/s") == "hold_w_rad_per_s"
    # round J: a key kept the '^' of mol/m^3
    assert unit_key("max_abs_C_A", "mol/m^3") == "max_abs_C_A_mol_per_m3"
    assert unit_key("hold_q", "W/(m^2*K)") == "hold_q_W_per_m2_K"
