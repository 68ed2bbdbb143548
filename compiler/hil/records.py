"""The files of a HIL run: ``run.csv``, ``summary.json``, ``run.png``; and reading run.csv back.

``run.csv`` follows the measurement-file format (plant spec §6) with a text column
``mode``: ``# key: value`` comment lines first, among them ``# status: complete`` or
``# status: stopped at t = ... s: <reason>`` for a partial run, then ``t,u,x,theta,mode``.
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
from .loop import HilRun

RUN_COLUMNS = ("t", "u", "x", "theta", "mode")


def run_csv_text(run: HilRun, meta: dict | None = None) -> str:
    """The text of run.csv (deterministic: fixed decimals, no timings)."""
    lines = ["# generator: pendc hil"]
    lines += [f"# {k}: {v}" for k, v in (meta or {}).items()]
    lines.append("# status: complete" if run.stopped is None else f"# status: stopped at {run.stopped}")
    lines.append(",".join(RUN_COLUMNS))
    lines += [f"{t:.6f},{u:.6f},{x:.7f},{th:.9f},{m}"
              for t, u, x, th, m in zip(run.t, run.u, run.x, run.theta, run.mode)]
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


def write_run(folder, run: HilRun, meta: dict | None = None, plot: bool = True) -> dict:
    """Write run.csv, summary.json and (``plot``) run.png into ``folder``; the summary."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise PendcError(f"{folder}: cannot create the output folder ({exc.strerror or exc})") from None
    summary = run.summary()
    write_atomic(folder / "run.csv", run_csv_text(run, meta))
    if plot:
        write_bytes_atomic(folder / "run.png", plot_png(run.t, run.u, run.x, run.theta, run.mode,
                                                         title=f"pendc hil ({run.plant} plant)"))
    write_atomic(folder / "summary.json", json.dumps(summary, indent=2) + "\n")
    return summary


def plot_png(t, u, x, theta, mode, title: str = "") -> bytes:
    """Angle from upright, cart position and input over time, balance periods shaded."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .controllers import wrap_upright

    phi = np.array([wrap_upright(v) for v in theta])
    fig, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    axes[0].plot(t, theta, lw=0.8, color="tab:blue")
    turns = int(np.max(np.abs(theta)) // (2 * math.pi)) + 1 if len(theta) else 1
    for k in range(-turns, turns + 1):   # the upright positions within the run's range
        axes[0].axhline((2 * k + 1) * math.pi, color="grey", lw=0.5, ls=":")
    axes[0].set_ylabel("theta (rad)\n(±pi upright)")
    axes[1].plot(t, x, lw=0.8, color="black")
    axes[1].axhline(0.375, color="tab:red", lw=0.6, ls="--")
    axes[1].axhline(-0.375, color="tab:red", lw=0.6, ls="--")
    axes[1].set_ylabel("x (m)\n(track ends dashed)")
    axes[2].plot(t, u, lw=0.5, color="tab:green")
    axes[2].set_ylabel("u (V)")
    axes[2].set_xlabel("t (s)")
    balancing = np.array([m == "balance" for m in mode])
    if balancing.any():
        for ax in axes:
            ax.fill_between(t, 0, 1, where=balancing, transform=ax.get_xaxis_transform(),
                            color="tab:orange", alpha=0.12, lw=0)
    upright = np.abs(phi) < 0.05
    if upright.any():
        axes[0].plot(t[upright], theta[upright], ".", ms=1, color="tab:orange")
    if title:
        axes[0].set_title(title)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    return buf.getvalue()


@dataclass(frozen=True)
class RunRecord:
    """run.csv read back: columns, metadata and the status line."""

    t: np.ndarray
    u: np.ndarray
    x: np.ndarray
    theta: np.ndarray
    mode: tuple
    meta: dict


def read_run(path) -> RunRecord:
    """Read a run.csv (or any CSV with t, x, theta; u and mode optional)."""
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
    names = [n.strip() for n in lines[k].split(",")]
    for need in ("t", "x", "theta"):
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
    if not cols["t"]:
        raise PendcError(f"{path}: no data rows")

    def numbers(name):
        try:
            v = np.array([float(c) for c in cols[name]])
        except ValueError as exc:
            raise PendcError(f"{path}: column '{name}' has a value that is not a number ({exc})") from None
        if not np.all(np.isfinite(v)):
            raise PendcError(f"{path}: column '{name}' has a non-finite value")
        return v

    t = numbers("t")
    if t.size > 1 and not np.all(np.diff(t) > 0):
        raise PendcError(f"{path}: column 't' is not strictly increasing")
    u = numbers("u") if "u" in cols else np.full(t.size, np.nan)
    mode = tuple(cols["mode"]) if "mode" in cols else ("",) * t.size
    return RunRecord(t=t, u=u, x=numbers("x"), theta=numbers("theta"), mode=mode, meta=meta)
