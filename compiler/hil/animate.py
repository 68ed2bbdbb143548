"""`pendc animate RUN.csv -o run.html|.gif|.mp4 [--model M.toml]`: any plant's run, drawn.

The picture is the plant file's ``[drawing]`` (points as expressions of its coordinates,
lines joining them; :mod:`.drawing` lays them out per frame), beside the traces of every
recorded position and the input. HTML is one self-contained file (inline SVG and JavaScript,
see :mod:`.animate_html`); GIF goes through matplotlib's PillowWriter (Pillow comes with
matplotlib); MP4 needs an ``ffmpeg`` on PATH. The model is the one the run names in its
header (``# model: ...``, as ``pendc hil`` writes it), else ``--model``, else the default.

Every format plays ``slow_motion`` times slower than real time (:func:`playback`): a run of a fast
plant (a converter's 50 ms) in real time would be a handful of frames over in a blink.
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
from ..model.interface import is_dimensionless
from .animate_html import PAGE
from .drawing import layout
from .records import RunRecord, read_run, write_bytes_atomic

HTML_RATE = 100.0    # frames per second of playback kept in the page
REAL_TIME_S = 1.0    # a run at least this long plays in real time unless --slow-motion says otherwise
PLAYBACK_S = 5.0     # a shorter one is slowed (by 1, 2 or 5 times a power of ten) to last at least this
MAX_MOVIE_FRAMES = 10000   # a GIF or MP4 of more takes minutes and hundreds of megabytes
SCENE = (640.0, 440.0)   # pixels of the page's drawing
FORMATS = (".html", ".gif", ".mp4")
STDIN = "-"
STDIN_SOURCE = "<stdin>"


def read_run_input(path, ports=None) -> RunRecord:
    """:func:`~pendc.hil.records.read_run` (``ports``: see there), with ``-`` for standard input
    (``<stdin>`` in errors)."""
    if str(path) != STDIN:
        if Path(path).is_dir():
            raise PendcError(f"{path}: is a folder, not a run file")
        return read_run(path, ports)
    data = sys.stdin.buffer.read()
    # read_run reads a path: give it one, and the user's name for it back in any error
    with tempfile.TemporaryDirectory(prefix="pendc-animate.") as folder:
        spool = Path(folder) / "stdin.csv"
        spool.write_bytes(data)
        try:
            return read_run(spool, ports)
        except PendcError as exc:
            raise PendcError(str(exc).replace(str(spool), STDIN_SOURCE)) from None


def playback(record: RunRecord, slow_motion: float | None) -> tuple[float, str | None]:
    """(how many times slower than real time the run plays, a note or None): ``slow_motion`` as
    given, else 1 for a run of at least REAL_TIME_S, else the 1-2-5 factor that makes it last at
    least PLAYBACK_S (with a note saying so)."""
    if slow_motion is not None:
        if not (math.isfinite(slow_motion) and slow_motion > 0):
            raise PendcError(f"--slow-motion must be a positive number, got {slow_motion:g}")
        return float(slow_motion), None
    span = float(record.t[-1] - record.t[0]) if record.t.size > 1 else 0.0
    if not span > 0 or span >= REAL_TIME_S:
        return 1.0, None
    factor = next((m * 10.0 ** e for e in range(13) for m in (1, 2, 5) if span * m * 10.0 ** e >= PLAYBACK_S),
                  PLAYBACK_S / span)
    return factor, (f"the run lasts {span:g} s, too short to watch in real time: it plays {factor:g}x slower "
                    f"({span * factor:g} s); --slow-motion 1 plays it in real time")


def time_decimals(step: float) -> int:
    """Decimals of a clock that ticks every ``step`` seconds (at least the 3 of a millisecond)."""
    return int(min(9, max(3, math.ceil(-math.log10(step) - 1e-9)))) if step > 0 else 3


def resample(record: RunRecord, rate: float, repeat: bool = False) -> dict:
    """The run at (at most) ``rate`` samples per second: nearest earlier sample, so modes stay labels;
    ``repeat`` keeps a sample as many times as the grid meets it (a movie's frames are evenly
    spaced in time), else once. Keys: t, input, mode, and ``positions`` (state -> samples, the
    record's order)."""
    t = record.t
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    if t.size < 2 or (not repeat and span * rate + 1 >= t.size):
        idx = np.arange(t.size)   # as fine as the record or finer: every row, without a huge grid
    else:
        grid = np.arange(t[0], t[-1] + 0.5 / rate, 1.0 / rate)
        idx = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, t.size - 1)
        idx = idx if repeat else np.unique(idx)
    return {"t": t[idx], "input": record.u[idx], "mode": [record.mode[i] for i in idx],
            "positions": {state: column[idx] for state, column in record.positions}}


def _clean(values, digits):
    return [round(float(v), digits) if math.isfinite(v) else None for v in values]


def html_page(record: RunRecord, model, title: str, slow_motion: float = 1.0) -> str:
    """The self-contained page for ``record`` drawn as ``model``'s plant file draws it, playing
    ``slow_motion`` times slower than real time."""
    rate = HTML_RATE * slow_motion
    d = resample(record, rate)
    spacing = float(np.min(np.diff(d["t"]))) if d["t"].size > 1 else 1.0 / rate
    decimals = time_decimals(max(spacing, 1.0 / rate))
    drawn = layout(model, d["positions"], *SCENE)
    units = dict(record.units) if getattr(record, "units", None) else {}
    iface = model.interface
    data = {"t": _clean(d["t"], decimals + 3), "mode": d["mode"], "slow": slow_motion, "decimals": decimals,
            "points": {name: [_clean(px, 2), _clean(py, 2)] for name, (px, py) in drawn.points.items()},
            "lines": [list(line) for line in drawn.lines],
            "traces": [{"name": state, "unit": _shown(units.get(state) or _unit_of(iface, state)),
                        "values": _clean(values, 6)} for state, values in d["positions"].items()]
            + [{"name": record.input_name, "unit": _shown(iface.input.unit), "values": _clean(d["input"], 4)}],
            "plant": iface.name}
    # JSON inside <script>: escape "</" so a mode label cannot close the element
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return PAGE.replace("__TITLE__", html.escape(title)).replace("__DATA__", payload)


def _shown(unit: str) -> str:
    """A trace's unit as the page labels it (``name (unit)``): none for a dimensionless one, not "(-)"."""
    return "" if is_dimensionless(unit) else unit


def _unit_of(iface, state: str) -> str:
    return next((s.unit for s in iface.states if s.name == state), "")


def model_of_run(record: RunRecord, model_path=None):
    """The model to draw ``record`` with: ``model_path`` if given, else the model the run's header
    names (:func:`~pendc.hil.records.run_model`: not found is an error), else the default model."""
    from ..model.modelfile import load_model

    if model_path is not None:
        return load_model(model_path)
    named = record.meta.get("model")
    if named and not Path(named).is_file():
        raise PendcError(f"the run's model '{named}' (its header) is not found; give --model")
    return load_model(named or None)


def animate_run(record: RunRecord, output, fps: int = 25, model=None, slow_motion: float | None = None) -> None:
    """Write the animation of ``record`` to ``output`` (format from the extension), drawn as the
    plant file of ``model`` (a PlantModel; None: :func:`model_of_run`) draws it, played
    ``slow_motion`` times slower than real time (None: as :func:`playback` chooses)."""
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
    slow_motion = playback(record, slow_motion)[0]
    span = float(record.t[-1] - record.t[0]) if record.t.size > 1 else 0.0
    frames = int(span * fps * slow_motion) + 1
    if suffix != ".html" and frames > MAX_MOVIE_FRAMES:
        raise PendcError(f"{span:g} s at {slow_motion:g}x slower and {fps} frames/s is {frames} frames, more than "
                         f"{MAX_MOVIE_FRAMES}: lower --slow-motion or --fps, or write .html")
    model = model if model is not None else model_of_run(record)
    if suffix == ".html":
        write_atomic(output, html_page(record, model, output.stem, slow_motion))
        return
    if suffix == ".mp4" and shutil.which("ffmpeg") is None:
        raise PendcError("writing .mp4 needs ffmpeg on PATH; write .html or .gif instead")
    _write_movie(record, model, output, fps, suffix, slow_motion)


def _write_movie(record: RunRecord, model, output: Path, fps: int, suffix: str, slow_motion: float) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter

    d = resample(record, fps * slow_motion, repeat=True)
    decimals = time_decimals(1.0 / (fps * slow_motion))
    pace = f"  ({slow_motion:g}x slower)" if slow_motion != 1 else ""
    width, height = SCENE
    drawn = layout(model, d["positions"], width, height)
    fig, (ax, axt) = plt.subplots(1, 2, figsize=(9, 3.6), gridspec_kw={"width_ratios": [1.4, 1]})
    ax.set_xlim(0, width)
    ax.set_ylim(height, 0)          # pixels: down is positive, as laid out
    ax.set_aspect("equal")
    ax.set_axis_off()
    joins = [ax.plot([], [], color="black", lw=3)[0] for _ in drawn.lines]
    (dots,) = ax.plot([], [], "o", color="chocolate", ms=8)
    stamp = ax.text(8, 20, "", fontsize=9)
    for state, values in d["positions"].items():
        axt.plot(d["t"], values, lw=0.8, label=state)
    cursor = axt.axvline(d["t"][0], color="tab:red", lw=0.8)
    axt.legend(loc="upper left", fontsize=8)
    axt.set_xlabel("t (s)")
    fig.tight_layout()

    def frame(k):
        for join, (a, b) in zip(joins, drawn.lines):
            join.set_data([drawn.points[a][0][k], drawn.points[b][0][k]], [drawn.points[a][1][k], drawn.points[b][1][k]])
        dots.set_data([p[0][k] for p in drawn.points.values()], [p[1][k] for p in drawn.points.values()])
        stamp.set_text(f"t = {d['t'][k]:.{decimals}f} s{pace}  {d['mode'][k]}")
        cursor.set_xdata([d["t"][k], d["t"][k]])
        return (*joins, dots, stamp, cursor)

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
