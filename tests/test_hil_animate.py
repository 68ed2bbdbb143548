"""`pendc animate`: the HTML page opened in headless Chromium draws the plant file's [drawing]
(points and lines) where the run says and moves it between frames, for the default plant and
for a plant file of one's own; GIF through Pillow; bad input."""

import math
import os
import shutil
import subprocess

import numpy as np
import pytest

from pendc.cli import main
from pendc.hil.loop import HilRun
from pendc.hil.records import read_run, run_csv_text

from plants import DEFAULT
from test_plantfile import example

ROD = 2 * DEFAULT.parameter_values()["L"]        # the default plant's drawing: pivot to the bob's centre


def chromium_path():
    """Debian's chromium; installed here if we are root and it is missing (as in CI)."""
    found = shutil.which("chromium")
    if found is None and hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("apt-get"):
        env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
        subprocess.run(["apt-get", "update"], capture_output=True, timeout=600, env=env)
        subprocess.run(["apt-get", "install", "-y", "chromium"], capture_output=True, timeout=1200, env=env)
        found = shutil.which("chromium")
    return found


@pytest.fixture(scope="module")
def browser():
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (test extras)")
    path = chromium_path()
    if path is None:
        pytest.skip("no chromium and cannot install it (not root or no apt-get)")
    with sync_api.sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=path, headless=True, args=["--no-sandbox"])
        yield b
        b.close()


def synthetic_run(tmp_path):
    """A swing: the cart moves 10 cm left while the pendulum turns from hanging to upright."""
    t = np.arange(0, 2.001, 0.001)
    run = HilRun(t=t, u=5 + np.sin(3 * t), positions=(("x", 0.1 * t / 2), ("theta", math.pi * t / 2)),
                 mode=tuple("swing" if v < 1 else "balance" for v in t), plant="float", wall_s=0.0, seconds=2.0,
                 input_name="u", units=(("x", "m"), ("theta", "rad")), angle="theta")
    path = tmp_path / "run.csv"
    path.write_text(run_csv_text(run))
    return path


def drawn(page, k):
    page.evaluate(f"window.pendcShow({k})")
    points = page.evaluate("window.pendc.points")
    for name, (x, y) in points.items():          # the page's circles are where window.pendc says
        assert float(page.get_attribute(f"#pt-{name}", "cx")) == pytest.approx(x, abs=0.01)
        assert float(page.get_attribute(f"#pt-{name}", "cy")) == pytest.approx(y, abs=0.01)
    return {**points, "clock": page.inner_text("#clock"), "frame": page.evaluate("window.pendc.frame"),
            "line": [float(page.get_attribute("#line-pivot-bob", a)) for a in ("x1", "y1", "x2", "y2")]}


def open_page(browser, path):
    page = browser.new_page(viewport={"width": 1120, "height": 640})
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(path.as_uri())
    return page, errors


def test_html_draws_and_moves_the_plant(browser, tmp_path, capsys):
    src = synthetic_run(tmp_path)
    out = tmp_path / "pendulum.html"
    assert main(["animate", str(src), "-o", str(out)]) == 0
    text = out.read_text()
    assert "http://" not in text.replace("http://www.w3.org/2000/svg", "") and "https://" not in text
    page, errors = open_page(browser, out)
    n = int(page.get_attribute("#slider", "max")) + 1
    assert n == 201          # 2 s at 100 frames per second, both ends
    first, last = drawn(page, 0), drawn(page, n - 1)
    # frame 0: hanging, the bob straight below the pivot (screen y grows downwards)
    (px0, py0), (bx0, by0) = first["pivot"], first["bob"]
    assert bx0 == pytest.approx(px0, abs=0.01) and by0 > py0
    scale = (by0 - py0) / ROD                     # pixels per metre, one for the whole run
    # last frame: the cart 10 cm to the LEFT (+x is drawn to the left), upright: bob straight above
    (px1, py1), (bx1, by1) = last["pivot"], last["bob"]
    assert px1 == pytest.approx(px0 - 0.1 * scale, abs=0.05) and py1 == pytest.approx(py0, abs=0.01)
    assert bx1 == pytest.approx(px1, abs=0.05) and by1 == pytest.approx(py1 - ROD * scale, abs=0.05)
    assert last["line"] == pytest.approx([px1, py1, bx1, by1], abs=0.01) and last["clock"] == "t = 2.000 s"
    shot0 = page.screenshot(path=str(tmp_path / "frame0.png"))
    page.evaluate(f"window.pendcShow({n // 2})")
    assert page.screenshot(path=str(tmp_path / "frame1.png")) != shot0
    # play moves the frame forward by itself
    page.evaluate("window.pendcShow(0)")
    page.click("#play")
    page.wait_for_timeout(400)
    assert page.evaluate("window.pendc.frame") > 5 and page.inner_text("#play") == "Pause"
    page.click("#play")
    assert not errors
    page.close()


def test_html_draws_a_plant_file_of_ones_own(browser, tmp_path, capsys):
    """The docs' example cart (its drawing added): the bob swings out by L sin(theta)."""
    plant = tmp_path / "my_cart.toml"
    plant.write_text(example().replace('cart = ["x", 0]', 'hub = ["x", 0]').replace('[["cart", "bob"]]',
                                                                                 '[["hub", "bob"]]'), encoding="utf-8")
    t = np.arange(0, 1.001, 0.01)
    run = HilRun(t=t, u=np.zeros_like(t), positions=(("x", 0.2 * t), ("theta", 0.5 * math.pi * t)),
                 mode=("",) * t.size, plant="float", wall_s=0.0, seconds=1.0, input_name="F",
                 units=(("x", "m"), ("theta", "rad")), angle="theta")
    src = tmp_path / "run.csv"
    src.write_text(run_csv_text(run, {"model": str(plant)}))
    out = tmp_path / "cart.html"
    assert main(["animate", str(src), "-o", str(out)]) == 0          # the model the header names
    page, errors = open_page(browser, out)
    (hx0, hy0), (bx0, by0) = page.evaluate("window.pendcShow(0) || window.pendc.points['hub']"), \
        page.evaluate("window.pendc.points['bob']")
    scale = (by0 - hy0) / 0.3                                           # L = 0.3 m
    page.evaluate("window.pendcShow(100)")
    (hx1, hy1), (bx1, by1) = page.evaluate("window.pendc.points['hub']"), page.evaluate("window.pendc.points['bob']")
    assert hx1 - hx0 == pytest.approx(0.2 * scale, abs=0.05)            # +x to the right in this file
    assert (bx1 - hx1, by1 - hy1) == pytest.approx((0.3 * scale, 0.0), abs=0.05)   # swung out horizontally
    assert not errors
    page.close()
    capsys.readouterr()
    plain = tmp_path / "plain.toml"
    plain.write_text(example().split("[drawing]")[0], encoding="utf-8")
    assert main(["animate", str(src), "--model", str(plain), "-o", str(tmp_path / "p.html")]) == 2
    assert "declares no [drawing]" in capsys.readouterr().err


def test_gif(tmp_path):
    src = synthetic_run(tmp_path)
    out = tmp_path / "pendulum.gif"
    assert main(["animate", str(src), "-o", str(out), "--fps", "5"]) == 0
    from PIL import Image

    with Image.open(out) as img:
        assert img.n_frames == 11
        img.seek(0)
        a = np.asarray(img.convert("RGB"))
        img.seek(10)
        b = np.asarray(img.convert("RGB"))
    assert (a != b).any()


@pytest.mark.parametrize("content, message", [
    ("t,u\n0,1\n", "no column 'x'"),
    ("t,x,theta\n0,0,0\n0,1,1\n", "not strictly increasing"),
    ("t,x,theta\n0,0\n", "2 fields, the header has 3"),
    ("t,x,theta\n0,zero,0\n", "not a number"),
])
def test_bad_run_files(tmp_path, capsys, content, message):
    src = tmp_path / "bad.csv"
    src.write_text(content)
    assert main(["animate", str(src), "-o", str(tmp_path / "p.html")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert not (tmp_path / "p.html").exists()


def test_bad_outputs(tmp_path, capsys):
    src = synthetic_run(tmp_path)
    assert main(["animate", str(src), "-o", str(tmp_path / "p.txt")]) == 2
    assert "unknown animation format" in capsys.readouterr().err
    if shutil.which("ffmpeg") is None:
        assert main(["animate", str(src), "-o", str(tmp_path / "p.mp4")]) == 2
        assert capsys.readouterr().err.strip() == ("pendc: error: writing .mp4 needs ffmpeg on PATH; "
                                                   "write .html or .gif instead")
    assert read_run(src).mode[0] == "swing"


def test_a_run_animates_from_any_folder_with_its_own_model(tmp_path, capsys, monkeypatch):
    """`pendc hil --model my_cart.toml --out run1` in the model's folder, then `pendc animate` from
    elsewhere: the header names the model by its absolute path; an older header's relative name is
    found beside the run or one folder up; a model that is nowhere is one line, never the default
    plant drawn instead (which then missed the run's columns)."""
    home = tmp_path / "lab"
    home.mkdir()
    (home / "my_cart.toml").write_text(example(), encoding="utf-8")
    monkeypatch.chdir(home)
    assert main(["hil", "--model", "my_cart.toml", "--controller", "lqr", "--seconds", "0.3",
                 "--out", "run1"]) == 0
    header = (home / "run1" / "run.csv").read_text(encoding="utf-8")
    assert f"# model: {home / 'my_cart.toml'}" in header
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    capsys.readouterr()
    assert main(["animate", str(home / "run1" / "run.csv"), "-o", "a.html"]) == 0
    older = home / "run1" / "older.csv"
    older.write_text(header.replace(str(home / "my_cart.toml"), "my_cart.toml"), encoding="utf-8")
    assert read_run(older).meta["model"] == str(home / "my_cart.toml")
    lost = home / "run1" / "lost.csv"
    lost.write_text(header.replace(str(home / "my_cart.toml"), "gone.toml"), encoding="utf-8")
    capsys.readouterr()
    assert main(["animate", str(lost), "-o", "b.html"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"pendc: error: {lost}: the run's model 'gone.toml' (its header) is not found; give --model"]
    assert main(["animate", str(lost), "--model", str(home / "my_cart.toml"), "-o", "c.html"]) == 0


def fast_run(tmp_path, seconds=0.05, period=1e-5):
    """A fast plant's record: ``seconds`` at a ``period`` control period (a converter's 50 ms at 10 us)."""
    t = np.arange(0, seconds + 0.5 * period, period)
    run = HilRun(t=t, u=np.zeros_like(t), positions=(("x", 2 * t), ("theta", 60 * t)), mode=("",) * t.size,
                 plant="golden", wall_s=0.0, seconds=seconds, input_name="u", units=(("x", "m"), ("theta", "rad")),
                 angle="theta")
    path = tmp_path / "fast.csv"
    path.write_text(run_csv_text(run))
    return path


def page_data(path) -> dict:
    import json
    import re

    return json.loads(re.search(r"const D = (.*?);\n", path.read_text()).group(1))


def test_a_short_run_is_slowed_down_with_a_note(tmp_path, capsys):
    """50 ms at 10 us was 6 frames 10 ms apart (the start transient never drawn): by default a run
    shorter than 1 s plays slowed to last at least 5 s, and says so; --slow-motion sets the factor."""
    src, out = fast_run(tmp_path), tmp_path / "fast.html"
    assert main(["animate", str(src), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "pendc: note: the run lasts 0.05 s, too short to watch in real time: it plays 100x slower (5 s)" in err
    d = page_data(out)
    assert len(d["t"]) == 501 and d["slow"] == 100 and d["t"][1] == pytest.approx(1e-4) and d["decimals"] == 4
    for factor, frames in (("1", 6), ("10", 51), ("1000", 5001)):   # never more frames than the run has rows
        assert main(["animate", str(src), "-o", str(out), "--slow-motion", factor]) == 0
        assert "note" not in capsys.readouterr().err and len(page_data(out)["t"]) == frames
    assert main(["animate", str(synthetic_run(tmp_path)), "-o", str(out)]) == 0     # 2 s: real time
    assert "note" not in capsys.readouterr().err and page_data(out)["slow"] == 1


def test_a_short_run_as_gif_and_too_many_frames(tmp_path, capsys):
    src, out = fast_run(tmp_path, seconds=0.02, period=1e-4), tmp_path / "fast.gif"
    assert main(["animate", str(src), "-o", str(out), "--fps", "2"]) == 0      # 500x slower: 10 s at 2 frames/s
    assert "plays 500x slower (10 s)" in capsys.readouterr().err
    from PIL import Image

    with Image.open(out) as img:
        assert img.n_frames == 21
    assert main(["animate", str(synthetic_run(tmp_path)), "-o", str(out), "--slow-motion", "1000"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["pendc: error: 2 s at 1000x slower and 25 frames/s is 50001 frames, more than 10000: lower "
                   "--slow-motion or --fps, or write .html"]
    assert main(["animate", str(src), "-o", str(out), "--slow-motion", "0"]) == 2
    assert "--slow-motion: must be positive" in capsys.readouterr().err


def test_slowed_and_slow_speed_pages_play(browser, tmp_path, capsys):
    """The slowed page plays and says by how much; a speed below 1 plays too (it stood still: each
    tick's advance, under one frame, was dropped)."""
    src, out = fast_run(tmp_path), tmp_path / "fast.html"
    assert main(["animate", str(src), "-o", str(out)]) == 0
    page, errors = open_page(browser, out)
    assert page.inner_text("#pace") == "played 100\u00d7 slower than real time" and page.inner_text("#clock") == \
        "t = 0.0000 s"
    page.click("#play")
    page.wait_for_timeout(500)
    assert 10 < page.evaluate("window.pendc.frame") < 200      # ~50 frames (5 ms) in 0.5 s
    page.click("#play")
    page.close()
    slow = tmp_path / "slow.html"
    assert main(["animate", str(synthetic_run(tmp_path)), "-o", str(slow)]) == 0
    page, errors2 = open_page(browser, slow)
    assert page.inner_text("#pace") == ""
    page.select_option("#speed", "0.25")
    page.click("#play")
    page.wait_for_timeout(800)
    assert page.evaluate("window.pendc.frame") >= 5              # ~20 frames (0.2 s) in 0.8 s
    page.click("#play")
    assert not errors and not errors2
    page.close()
