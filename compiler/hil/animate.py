"""`pendc animate RUN.csv -o pendulum.html|.gif|.mp4`: the virtual pendulum of a run.

HTML is one self-contained file (inline SVG and JavaScript, see :mod:`.animate_html`);
GIF goes through matplotlib's PillowWriter (Pillow comes with matplotlib); MP4 needs an
``ffmpeg`` on PATH. The geometry follows the plant spec: x positive to the left, the bob
at (x - l sin theta, -l cos theta), the track 750 mm long.
"""

from __future__ import annotations

import html
import json
import math
import os
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..atomic import check_file_output, write_atomic
from ..errors import PendcError
from .animate_html import PAGE
from .records import RunRecord, read_run, write_bytes_atomic

HTML_RATE = 100.0    # frames per simulated second kept in the page
TRACK = 0.75         # m
ROD = 0.22           # m, pivot to bob centre as drawn
FORMATS = (".html", ".gif", ".mp4")
STDIN = "-"
STDIN_SOURCE = "<stdin>"


def read_run_input(path) -> RunRecord:
    """:func:`~pendc.hil.records.read_run`, with ``-`` for standard input (``<stdin>`` in errors)."""
    if str(path) != STDIN:
        if Path(path).is_dir():
            raise PendcError(f"{path}: is a folder, not a run file")
        return read_run(path)
    data = sys.stdin.buffer.read()
    # read_run reads a path: give it one, and the user's name for it back in any error
    with tempfile.TemporaryDirectory(prefix="pendc-animate.") as folder:
        spool = Path(folder) / "stdin.csv"
        spool.write_bytes(data)
        try:
            return read_run(spool)
        except PendcError as exc:
            raise PendcError(str(exc).replace(str(spool), STDIN_SOURCE)) from None


def cart_and_angle(record: RunRecord) -> tuple[str, str]:
    """The record's two measured positions, as the cart-pendulum drawing takes them: the
    translation first, then the pendulum angle (the plant interface's encoder order)."""
    if len(record.positions) != 2:
        raise PendcError(f"the animation draws a cart and a pendulum: the run has {len(record.positions)} "
                         f"measured positions ({', '.join(s for s, _ in record.positions)})")
    return record.positions[0][0], record.positions[1][0]


def resample(record: RunRecord, rate: float) -> dict:
    """The run at (at most) ``rate`` samples per second: nearest earlier sample, so modes stay labels.
    Keys: t, cart, angle, input, mode."""
    cart, angle = cart_and_angle(record)
    t = record.t
    if t.size < 2:
        idx = np.arange(t.size)
    else:
        grid = np.arange(t[0], t[-1] + 0.5 / rate, 1.0 / rate)
        idx = np.unique(np.clip(np.searchsorted(t, grid, side="right") - 1, 0, t.size - 1))
    return {"t": t[idx], "cart": record.column(cart)[idx], "angle": record.column(angle)[idx],
            "input": record.u[idx], "mode": [record.mode[i] for i in idx]}


def html_page(record: RunRecord, title: str) -> str:
    """The self-contained page for ``record``."""
    d = resample(record, HTML_RATE)

    def clean(values, digits):
        return [round(float(v), digits) if math.isfinite(v) else None for v in values]

    cart, angle = cart_and_angle(record)
    data = {"t": clean(d["t"], 4), "cart": clean(d["cart"], 6), "angle": clean(d["angle"], 5),
            "input": clean(d["input"], 4), "mode": d["mode"],
            "names": {"cart": cart, "angle": angle, "input": record.input_name},
            "units": {"cart": "m", "angle": "rad"}}
    # JSON inside <script>: escape "</" so a mode label cannot close the element
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return PAGE.replace("__TITLE__", html.escape(title)).replace("__DATA__", payload)


def animate_run(record: RunRecord, output, fps: int = 25) -> None:
    """Write the animation of ``record`` to ``output`` (format from the extension)."""
    if str(output) == "-":
        raise PendcError("animate: -o names a file (.html, .gif or .mp4), not standard output")
    if Path(output).is_dir():
        raise PendcError(f"{output}: is a folder; give a file name ending in .html, .gif or .mp4")
    check_file_output(output)   # before rendering: a movie takes a while
    output = Path(output)
    suffix = output.suffix.lower()
    if suffix not in FORMATS:
        raise PendcError(f"{output}: unknown animation format '{suffix}' (use .html, .gif or .mp4)")
    if not 1 <= fps <= 100:
        raise PendcError(f"--fps must be in 1..100, got {fps}")
    if suffix == ".html":
        write_atomic(output, html_page(record, output.stem))
        return
    if suffix == ".mp4" and shutil.which("ffmpeg") is None:
        raise PendcError("writing .mp4 needs ffmpeg on PATH; write .html or .gif instead")
    _write_movie(record, output, fps, suffix)


def _write_movie(record: RunRecord, output: Path, fps: int, suffix: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter

    d = resample(record, fps)
    fig, (ax, axt) = plt.subplots(1, 2, figsize=(9, 3.6), gridspec_kw={"width_ratios": [1.4, 1]})
    ax.set_xlim(TRACK / 2 + 0.05, -TRACK / 2 - 0.05)   # +x to the left, as on the rig
    ax.set_ylim(-0.3, 0.3)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m), positive to the left")
    ax.plot([-TRACK / 2, TRACK / 2], [0, 0], color="0.3", lw=3)
    cart = plt.Rectangle((0, -0.02), 0.08, 0.04, color="tab:blue")
    ax.add_patch(cart)
    (rod,) = ax.plot([], [], color="black", lw=3)
    (bob,) = ax.plot([], [], "o", color="chocolate", ms=12)
    stamp = ax.text(TRACK / 2, 0.26, "", fontsize=9)
    cart_name, angle_name = cart_and_angle(record)
    axt.plot(d["t"], d["angle"], lw=0.8, label=f"{angle_name} (rad)")
    axt.plot(d["t"], np.asarray(d["cart"]) * 10, lw=0.8, label=f"10 {cart_name} (m)")
    cursor = axt.axvline(d["t"][0], color="tab:red", lw=0.8)
    axt.legend(loc="upper left", fontsize=8)
    axt.set_xlabel("t (s)")
    fig.tight_layout()

    def frame(k):
        x, th = d["cart"][k], d["angle"][k]
        cart.set_x(x - 0.04)
        bx, by = x - ROD * math.sin(th), -ROD * math.cos(th)
        rod.set_data([x, bx], [0, by])
        bob.set_data([bx], [by])
        stamp.set_text(f"t = {d['t'][k]:.2f} s  {d['mode'][k]}")
        cursor.set_xdata([d["t"][k], d["t"][k]])
        return cart, rod, bob, stamp, cursor

    anim = FuncAnimation(fig, frame, frames=len(d["t"]), blit=False)
    writer = PillowWriter(fps=fps) if suffix == ".gif" else FFMpegWriter(fps=fps)
    fd, tmp = tempfile.mkstemp(prefix=f".{output.stem}.", suffix=suffix, dir=output.parent or ".")
    os.close(fd)
    try:
        anim.save(tmp, writer=writer)
        write_bytes_atomic(output, Path(tmp).read_bytes())
    finally:
        plt.close(fig)
        if os.path.exists(tmp):
            os.unlink(tmp)
