"""`pendc animate`: the HTML page opened in headless Chromium draws the cart and the pendulum
where the run says and moves them between frames; GIF through Pillow; bad input."""

import math
import os
import shutil
import subprocess

import numpy as np
import pytest

from pendc.cli import main
from pendc.hil.loop import HilRun
from pendc.hil.records import read_run, run_csv_text

W, TRACK, ROD, PIVOT_Y = 640, 0.75, 0.22, 230
SCALE = (W - 40) / TRACK


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
    get = page.get_attribute
    return {"cart": float(get("#cart", "x")) + 30, "pivot": float(get("#pivot", "cx")),
            "bob": (float(get("#bob", "cx")), float(get("#bob", "cy"))),
            "rod_end": (float(get("#rod", "x2")), float(get("#rod", "y2"))),
            "clock": page.inner_text("#clock"), "frame": page.evaluate("window.pendc.frame")}


def test_html_draws_and_moves_cart_and_pendulum(browser, tmp_path, capsys):
    src = synthetic_run(tmp_path)
    out = tmp_path / "pendulum.html"
    assert main(["animate", str(src), "-o", str(out)]) == 0
    text = out.read_text()
    assert "http://" not in text.replace("http://www.w3.org/2000/svg", "") and "https://" not in text
    page = browser.new_page(viewport={"width": 1120, "height": 560})
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(out.as_uri())
    n = int(page.get_attribute("#slider", "max")) + 1
    assert n == 201          # 2 s at 100 frames per second, both ends
    first, last = drawn(page, 0), drawn(page, n - 1)
    # frame 0: centre, hanging: the bob straight below the pivot
    assert first["cart"] == pytest.approx(W / 2, abs=0.01) and first["pivot"] == pytest.approx(W / 2, abs=0.01)
    assert first["bob"] == pytest.approx((W / 2, PIVOT_Y + SCALE * ROD), abs=0.01)
    # last frame: 10 cm to the LEFT (+x), upright: the bob straight above the pivot
    assert last["cart"] == pytest.approx(W / 2 - SCALE * 0.1, abs=0.01)
    assert last["bob"] == pytest.approx((W / 2 - SCALE * 0.1, PIVOT_Y - SCALE * ROD), abs=0.01)
    assert last["rod_end"] == pytest.approx(last["bob"], abs=0.01) and last["clock"] == "t = 2.000 s"
    page.evaluate("window.pendcShow(0)")
    shot0 = page.screenshot(path=str(tmp_path / "frame0.png"))
    page.evaluate(f"window.pendcShow({n // 2})")
    shot1 = page.screenshot(path=str(tmp_path / "frame1.png"))
    assert shot0 != shot1
    # play moves the frame forward by itself
    page.evaluate("window.pendcShow(0)")
    page.click("#play")
    page.wait_for_timeout(400)
    assert page.evaluate("window.pendc.frame") > 5 and page.inner_text("#play") == "Pause"
    page.click("#play")
    assert not errors
    page.close()


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
