"""`pendc hil --serve`: the C example client of docs/ swings up and balances through the socket;
a malformed answer or a silent client ends the run with a partial record."""

import json
import shutil
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from pendc.errors import PendcError
from pendc.hil.plants.plant import make_plant
from pendc.hil.records import run_csv_text
from pendc.hil.server import parse_loopback_address, serve_loop

ROOT = Path(__file__).resolve().parents[1]
PENDC = [sys.executable, "-m", "pendc.cli"] if not (ROOT / ".venv/bin/pendc").exists() else [str(ROOT / ".venv/bin/pendc")]


def start_server(out: Path, seconds: float, timeout: float = 60.0):
    """`pendc hil --serve 127.0.0.1:0` in a subprocess; returns it and the port it announced."""
    proc = subprocess.Popen([*PENDC, "hil", "--serve", "127.0.0.1:0", "--seconds", str(seconds), "--out", str(out),
                             "--timeout", str(timeout), "--json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    line = proc.stderr.readline()          # the announcement comes before any waiting
    if "serving on 127.0.0.1:" not in line:
        proc.kill()
        raise AssertionError(f"no announcement: {line!r} {proc.stderr.read()}")
    return proc, int(line.split("127.0.0.1:")[1].split(",")[0])


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed (needed to build docs/hil_client.c)")
def test_c_client_swings_up_and_balances_through_the_socket(tmp_path):
    exe = tmp_path / "hil_client"
    subprocess.run(["gcc", "-O2", "-Wall", "-Werror", "-o", str(exe), str(ROOT / "docs/hil_client.c"), "-lm"],
                   check=True, capture_output=True, timeout=60)
    proc, port = start_server(tmp_path / "out", 10.0)
    client = subprocess.run([str(exe), "127.0.0.1", str(port)], capture_output=True, text=True, timeout=300)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert client.returncode == 0 and "END complete" in client.stderr
    summary = json.loads(out)
    assert summary["completed"] and summary["rows"] == 10001
    assert summary["upright_at_s"] is not None and summary["upright_at_s"] < 7.0
    assert summary["max_abs_x_m"] < 0.3
    text = (tmp_path / "out" / "run.csv").read_text()
    assert "# controller: socket client" in text and text.rstrip().endswith("external")


class ScriptedClient(threading.Thread):
    """A client that answers ``good`` periods with 5.3 V, then sends ``last`` (or nothing)."""

    def __init__(self, port, good, last):
        super().__init__(daemon=True)
        self.port, self.good, self.last, self.lines = port, good, last, []

    def run(self):
        with socket.create_connection(("127.0.0.1", self.port), timeout=30) as s:
            f = s.makefile("rw")
            self.lines.append(f.readline())
            for _ in range(self.good):
                self.lines.append(f.readline())
                f.write("5.3\n")
                f.flush()
            self.lines.append(f.readline())
            if self.last is not None:
                f.write(self.last)
                f.flush()
            self.lines.append(f.readline())   # the END line (or nothing)


def serve_with(client_good, client_last, timeout=5.0, plant=None):
    plant = plant or make_plant("float")
    port_box = []
    ready = threading.Event()

    def announce(text):
        port_box.append(int(text.split("127.0.0.1:")[1].split(",")[0]))
        ready.set()

    result = {}
    server = threading.Thread(target=lambda: result.setdefault(
        "run", serve_loop(plant, ("127.0.0.1", 0), 1.0, timeout=timeout, announce=announce)), daemon=True)
    server.start()
    assert ready.wait(30)
    client = ScriptedClient(port_box[0], client_good, client_last)
    client.start()
    server.join(60)
    client.join(30)
    return result["run"], client.lines


def test_greeting_and_measurement_lines():
    run, lines = serve_with(3, "bogus\n")
    assert lines[0].startswith("PENDC-HIL 1 period=0.001 periods=1001 x_count=2.5e-06 theta_count=0.000314159")
    assert lines[1] == "S 0 0.000000 0 0\n" and lines[2].startswith("S 1 0.001000 ")


def test_converter_codes_follow_the_encoder_counts():
    """The ball and beam: the servo's encoder count, then the ball's 12-bit converter code, whose
    LSB and range bottom the greeting gives (a converter-read state was not sent at all)."""
    from pendc.model.modelfile import load_model
    model = load_model(str(ROOT / "models" / "ball_beam.toml"))
    adc = model.interface.sensors[-1]
    _, lines = serve_with(2, "bogus\n", plant=make_plant("float", model))
    assert lines[0].startswith("PENDC-HIL 1 period=0.001 periods=1001 theta_count=0.00153398")
    assert lines[0].rstrip().endswith(f"x_code={(adc.hi - adc.lo) / 4096!r} x_lo={adc.lo!r}")
    k, t, count, code = lines[1].split()[1:]
    assert (k, t, count) == ("0", "0.000000", "0") and int(code) == adc.code(0.0) == 2048


def test_malformed_answer_ends_the_run_with_a_partial_record():
    run, lines = serve_with(3, "five volts\n")
    assert run.stopped == "t = 0.003 s: malformed answer from the controller: 'five volts' is not a number of volts"
    assert run.t.size == 3 and list(run.u) == pytest.approx([5.3] * 3, abs=0.003)
    assert lines[-1].startswith("END stopped t = 0.003 s: malformed answer")
    assert "# status: stopped at t = 0.003 s: malformed answer" in run_csv_text(run)


def test_silent_client_times_out():
    run, lines = serve_with(2, None, timeout=0.5)
    assert run.stopped == "t = 0.002 s: no answer from the controller within 0.5 s"
    assert run.t.size == 2


def test_nobody_connects():
    with pytest.raises(PendcError, match="no controller connected"):
        serve_loop(make_plant("float"), ("127.0.0.1", 0), 1.0, timeout=0.3)


def test_only_loopback_addresses():
    assert parse_loopback_address("127.0.0.1:5555") == ("127.0.0.1", 5555)
    assert parse_loopback_address("[::1]:80") == ("::1", 80)
    assert parse_loopback_address("localhost:0") == ("127.0.0.1", 0)
    for bad in ("0.0.0.0:5555", "192.168.1.2:1", "example.com:1"):
        with pytest.raises(PendcError):
            parse_loopback_address(bad)
