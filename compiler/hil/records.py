"""The files of a HIL run: ``run.csv``, ``summary.json``, ``run.png``; and reading run.csv back.

``run.csv`` follows the measurement-file format (plant spec §6) with a text column
``mode``: ``# key: value`` comment lines first, among them ``# status: complete`` or
``# status: stopped at t = ... s: <reason>`` for a partial run, then ``t``, the plant's input,
each measured position (named by the states the plant interface's encoders read) and ``mode``.
It holds nothing that depends on the plant kind or the wall clock, so two bit-exact
plants give byte-identical files.
"""

from __future__ import annotations

import io
import json
import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from ..errors import PendcError
from ..model.interface import unit_name
from .loop import HilRun

TIME, MODE = "t", "mode"


# decimals of a position column of run.csv: far below one encoder count of either kind
DECIMALS_LINEAR, DECIMALS_ANGLE = 7, 9


def run_columns(run: HilRun) -> tuple:
    """The header of run.csv: time, the input, the measured positions, the mode."""
    return (TIME, run.input_name, *(state for state, _ in run.positions), MODE)


def run_csv_text(run: HilRun, meta: dict | None = None, digits: dict | None = None) -> str:
    """The text of run.csv (deterministic: fixed decimals, no timings). ``digits``: decimals per
    position column (default: :data:`DECIMALS_ANGLE` for the run's upright angle, else
    :data:`DECIMALS_LINEAR`)."""
    lines = ["# generator: pendc hil"]
    lines += [f"# {k}: {v}" for k, v in (meta or {}).items()]
    lines.append("# status: complete" if run.stopped is None else f"# status: stopped at {run.stopped}")
    lines.append(",".join(run_columns(run)))
    decimals = [(digits or {}).get(state, DECIMALS_ANGLE if state == run.angle else DECIMALS_LINEAR)
                for state, _ in run.positions]
    columns = [c for _, c in run.positions]
    for k in range(run.t.size):
        cells = [f"{run.t[k]:.6f}", f"{run.u[k]:.6f}"] + [f"{c[k]:.{d}f}" for c, d in zip(columns, decimals)]
        lines.append(",".join(cells + [run.mode[k]]))
    return "\n".join(lines) + "\n"


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Binary twin of :func:`pendc.atomic.write_atomic` (temporary file and rename)."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_run(folder, run: HilRun, meta: dict | None = None, plot: bool = True, digits: dict | None = None) -> dict:
    """Write run.csv, summary.json and (``plot``) run.png into ``folder``; the summary.
    ``digits``: decimals per position column of run.csv (see :func:`run_csv_text`)."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise PendcError(f"{folder}: cannot create the output folder ({exc.strerror or exc})") from None
    summary = run.summary()
    write_atomic(folder / "run.csv", run_csv_text(run, meta, digits))
    if plot:
        write_bytes_atomic(folder / "run.png", plot_png(run, title=f"pendc hil ({run.plant} plant)"))
    write_atomic(folder / "summary.json", json.dumps(summary, indent=2) + "\n")
    return summary


def upright_guides(column) -> list:
    """The upright positions ((2k + 1) pi) to mark on a plot of a pendulum angle: those within half
    a turn of the values it takes, and none when the angle never comes within 0.5 rad of one (a
    helicopter's yaw held near 0 was drawn flat between guides at -pi and 3 pi)."""
    from .controllers.measurement import wrap_upright
    column = np.asarray(column, dtype=float)
    if not column.size or min(abs(wrap_upright(v)) for v in column) >= 0.5:
        return []
    lo, hi = float(column.min()), float(column.max())
    first, last = math.ceil((lo - 2 * math.pi) / (2 * math.pi)), math.floor(hi / (2 * math.pi))
    return [(2 * k + 1) * math.pi for k in range(first, last + 1)
            if lo - math.pi <= (2 * k + 1) * math.pi <= hi + math.pi]


def plot_png(run: HilRun, title: str = "") -> bytes:
    """Each measured position and the input over time (a periodic angle with its upright
    positions dotted and the upright periods marked), balance periods shaded."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .controllers.measurement import wrap_upright

    t, mode = run.t, run.mode
    units = dict(run.units)
    fig, axes = plt.subplots(len(run.positions) + 1, 1, figsize=(8, 2.3 * (len(run.positions) + 1)), sharex=True)
    axes = list(np.atleast_1d(axes))
    for ax, (state, column) in zip(axes, run.positions):
        ax.plot(t, column, lw=0.8)
        ax.set_ylabel(f"{state} ({unit_name(units[state])})" if state in units else state)
        guides = upright_guides(column) if state == run.angle else []
        for y in guides:
            ax.axhline(y, color="grey", lw=0.5, ls=":")
        if guides:
            upright = np.abs(np.array([wrap_upright(v) for v in column])) < 0.05
            if upright.any():
                ax.plot(t[upright], column[upright], ".", ms=1, color="tab:orange")
    axes[-1].plot(t, run.u, lw=0.5, color="tab:green")
    axes[-1].set_ylabel(f"{run.input_name} ({unit_name(units.get(run.input_name, 'V'))})")
    axes[-1].set_xlabel("t (s)")
    balancing = np.array([m == "balance" for m in mode])
    if balancing.any():
        for ax in axes:
            ax.fill_between(t, 0, 1, where=balancing, transform=ax.get_xaxis_transform(),
                            color="tab:orange", alpha=0.12, lw=0)
    if title:
        axes[0].set_title(title)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    return buf.getvalue()


@dataclass(frozen=True)
class RunRecord:
    """run.csv read back: time, input (NaN if the file has none), the measured positions
    ``(state, column)`` (each also reads as ``record.<state>``), mode, metadata and the input's name."""

    t: np.ndarray
    u: np.ndarray
    positions: tuple
    mode: tuple
    meta: dict
    input_name: str = ""

    def __getattr__(self, name: str):
        # only reached when ordinary lookup fails: a measured state's column
        for key, column in self.__dict__.get("positions", ()):
            if key == name:
                return column
        raise AttributeError(f"the run record has no column '{name}'")

    def column(self, state: str) -> np.ndarray:
        """The measured position of ``state`` per row."""
        return dict(self.positions)[state]


def run_model(meta: dict, run_path) -> str | None:
    """The model file a run's header names (``# model: PATH``), found: as written (absolute, or
    relative to the current folder), else relative to the run file's folder or the one above it
    (``pendc hil --out DIR`` run where the model was); None when the header names none. A named
    model that is nowhere is a one-line error, never the default model drawn in its place."""
    named = meta.get("model")
    if not named:
        return None
    here = Path(run_path).resolve().parent
    for candidate in (Path(named), here / named, here.parent / named):
        if candidate.is_file():
            return str(candidate.resolve())
    raise PendcError(f"{run_path}: the run's model '{named}' (its header) is not found; give --model")


def read_run(path, ports=None) -> RunRecord:
    """Read a run.csv (or any CSV with t and the measured positions; the input and mode optional).
    ``ports`` (:class:`~pendc.hil.plants.core_ports.CorePorts`) names the input and the positions
    (default: the plant interface of the model the header names, ``# model: PATH`` as ``pendc
    hil`` writes it (found by :func:`run_model`, and the header's entry then the absolute path);
    the default model's when the header names none)."""
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise PendcError(f"{path}: cannot read ({getattr(exc, 'strerror', None) or exc})") from None
    meta, k = {}, 0
    while k < len(lines) and (lines[k].startswith("#") or not lines[k].strip()):
        key, sep, value = lines[k].lstrip("#").partition(":")
        if sep:
            meta[key.strip()] = value.strip()
        k += 1
    if k == len(lines):
        raise PendcError(f"{path}: no header row")
    if meta.get("model"):
        try:
            meta["model"] = run_model(meta, path)
        except PendcError:
            if ports is None:           # the caller's ports (--model) make the header's model moot
                raise
    if ports is None:
        from ..model.modelfile import load_model
        from .plants.core_ports import CorePorts
        ports = CorePorts.of_interface(load_model(meta.get("model")).interface)
    measured = list(ports.measured)
    names = [n.strip() for n in lines[k].split(",")]
    for need in (TIME, *measured):
        if need not in names:
            raise PendcError(f"{path}: line {k + 1}: no column '{need}' (columns: {', '.join(names)})")
    cols = {n: [] for n in names}
    for j, line in enumerate(lines[k + 1:], start=k + 2):
        if not line.strip() or line.startswith("#"):
            continue
        cells = line.split(",")
        if len(cells) != len(names):
            raise PendcError(f"{path}: line {j}: {len(cells)} fields, the header has {len(names)}")
        for n, c in zip(names, cells):
            cols[n].append(c.strip())
    if not cols[TIME]:
        raise PendcError(f"{path}: no data rows")

    def numbers(name):
        try:
            v = np.array([float(c) for c in cols[name]])
        except ValueError as exc:
            raise PendcError(f"{path}: column '{name}' has a value that is not a number ({exc})") from None
        if not np.all(np.isfinite(v)):
            raise PendcError(f"{path}: column '{name}' has a non-finite value")
        return v

    t = numbers(TIME)
    if t.size > 1 and not np.all(np.diff(t) > 0):
        raise PendcError(f"{path}: column '{TIME}' is not strictly increasing")
    u = numbers(ports.input) if ports.input in cols else np.full(t.size, np.nan)
    mode = tuple(cols[MODE]) if MODE in cols else ("",) * t.size
    return RunRecord(t=t, u=u, positions=tuple((s, numbers(s)) for s in measured), mode=mode, meta=meta,
                     input_name=ports.input)
