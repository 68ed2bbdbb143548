"""`pendc hil`: outputs, a user's controller class plugged in, partial runs, bad input."""

import json
import math

import pytest

from pendc.cli import main

USER_CONTROLLER = '''
"""A user's controller, not part of pendc: push left for 0.2 s, then hold V_off."""


class PushThenHold:
    def __init__(self, model):
        self.v_off = model.parameter_values()["V_off"]
        self.mode = "push"

    def reset(self):
        self.mode = "push"

    def step(self, meas):
        self.mode = "push" if meas.t < 0.2 else "hold"
        return self.v_off + 3.0 if meas.t < 0.2 else self.v_off


class FailsLater:
    def reset(self):
        pass

    def step(self, meas):
        if meas.t >= 0.25:
            raise RuntimeError("sensor fault")
        return 5.0


class NoStep:
    def reset(self):
        pass
'''


@pytest.fixture
def user_dir(tmp_path, monkeypatch):
    (tmp_path / "my_ctrl.py").write_text(USER_CONTROLLER)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def read_rows(path):
    lines = path.read_text().splitlines()
    meta = [ln for ln in lines if ln.startswith("#")]
    body = [ln for ln in lines if not ln.startswith("#")]
    assert body[0] == "t,u,x,theta,mode"
    return meta, [ln.split(",") for ln in body[1:]]


def test_user_controller_class_plugs_in(user_dir, capsys):
    assert main(["hil", "--controller", "my_ctrl:PushThenHold", "--seconds", "0.5", "--out", "out", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    meta, rows = read_rows(user_dir / "out" / "run.csv")
    assert "# status: complete" in meta and "# controller: my_ctrl:PushThenHold" in meta
    assert len(rows) == 501 and summary["rows"] == 501 and summary["completed"] is True
    assert [r[4] for r in rows[:2]] == ["push", "push"] and rows[-1][4] == "hold"
    u = [float(r[1]) for r in rows]
    # the DAC: 12 bits over 0-10 V, nearest code
    assert all(abs(v / (10 / 4095) - round(v / (10 / 4095))) < 1e-3 for v in u)
    assert u[0] == pytest.approx(5.264616 + 3.0, abs=10 / 4095)
    x = [float(r[2]) for r in rows]
    assert x[200] > 0.005                    # u > V_off pushes the cart left (+x)
    assert summary["max_abs_x_m"] == pytest.approx(max(abs(v) for v in x))
    assert summary["max_abs_theta_rad"] == pytest.approx(max(abs(float(r[3])) for r in rows))   # the angle too
    assert summary["switches"] == 1 and summary["plant"] == "float"
    assert (user_dir / "out" / "run.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in (user_dir / "out").iterdir()) == ["run.csv", "run.png", "summary.json"]


def test_failing_controller_leaves_a_partial_record(user_dir, capsys):
    assert main(["hil", "--controller", "my_ctrl:FailsLater", "--seconds", "1", "--out", "out"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pendc: error: the run stopped at t = 0.25 s")
    assert "RuntimeError: sensor fault" in err[0] and "out/run.csv" in err[0]
    meta, rows = read_rows(user_dir / "out" / "run.csv")
    assert any(m.startswith("# status: stopped at t = 0.25 s") for m in meta)
    assert len(rows) == 250 and float(rows[-1][0]) == pytest.approx(0.249)
    summary = json.loads((user_dir / "out" / "summary.json").read_text())
    assert summary["completed"] is False and "sensor fault" in summary["stopped"]


@pytest.mark.parametrize("args, message", [
    (["--controller", "nonsense"], "--controller must be builtin"),
    (["--controller", "no_such_module_xyz:C"], "no module named 'no_such_module_xyz'"),
    (["--controller", "my_ctrl:Missing"], "module my_ctrl has no Missing"),
    (["--controller", "my_ctrl:NoStep"], "has no step() method"),
    (["--seconds", "-1"], "must be positive"),
    (["--period", "1.5e-6"], "not a whole number of plant steps"),
    (["--serve", "8.8.8.8:5555"], "not a loopback address"),
    (["--serve", "127.0.0.1:99999"], "port must be in 0..65535"),
    (["--serve", "localhost"], "HOST:PORT"),
    (["--serve", "127.0.0.1:5555", "--controller", "builtin"], "exclude each other"),
    (["--model", "no_such_model.toml"], "no_such_model.toml"),
    (["--plant", "analog"], "invalid choice"),
])
def test_bad_input_is_one_line(user_dir, capsys, args, message):
    assert main(["hil", "--seconds", "0.01", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pendc: error:") and message in err[0]
    assert not (user_dir / "out").exists()


def test_builtin_balance_summary_without_out(capsys):
    assert main(["hil", "--controller", "swing-up", "--seconds", "2"]) == 0
    out = capsys.readouterr().out
    assert "not upright at the end of the run" in out and "max |x|" in out
    assert not math.isnan(float(out.split("max |x| = ")[1].split()[0]))


def test_the_documented_user_controllers_work(tmp_path, monkeypatch, capsys):
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[1] / "docs" / "hil.md").read_text()
    code = doc.split('```python\n"""Two controllers of my own')[1].split("```")[0]
    (tmp_path / "my_controller_doc.py").write_text('"""Two controllers of my own' + code)
    monkeypatch.chdir(tmp_path)
    assert main(["hil", "--controller", "my_controller_doc:CartTo5cm", "--seconds", "3", "--out", "pid"]) == 0
    meta, rows = read_rows(tmp_path / "pid" / "run.csv")
    assert rows[-1][4] == "pid" and abs(float(rows[-1][2]) - 0.05) < 0.002   # as docs/hil.md says
    assert max(float(r[2]) for r in rows) < 0.065
