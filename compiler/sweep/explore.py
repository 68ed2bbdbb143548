"""``pendc explore``'s work: one design point per (target, schedule), built and synthesised on a worker.

A design point is a synthesis target and a schedule: a ``pendc build --preset P`` or a ``pendc
build --ii N`` (the build takes one of the two). Its task runs ``pendc build`` itself (the
command, in a child interpreter, into a temporary folder on the worker) and :func:`pendc.synth.flow.
synthesize` on what it wrote (cached by design hash), and returns the synthesis figures with the
build's files, so that the client keeps the build beside the table wherever the worker ran. The
model travels inside the task as self-contained text (a worker needs no model file).

A point whose build the compiler refuses (no schedule in N cycles, a product wider than a preset's
DSP budget) or whose synthesis fails is a row with the reason in ``error``: a finding about the
design space, kept, never run again. So is a point the part is too small for (``fits`` false, what
it lacks in ``misfit``): its figures are kept, and it takes no part in the Pareto front.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..atomic import write_atomic
from ..errors import PendcError

MANIFEST = "explore.json"
ROWS = "rows"
BUILDS = "builds"
MANIFEST_VERSION = 1
FIGURES = ("ii", "fmax_mhz", "step_ns", "estimated_step_ns", "dsp", "lut", "ff", "carry", "bram", "logic_depth")


@dataclass(frozen=True)
class Point:
    """One design point: a synthesis target and a schedule (``preset`` NAME or ``ii`` N)."""

    target: str
    schedule: str          # "preset" or "ii"
    value: str | int

    @property
    def label(self) -> str:
        return f"{self.schedule} {self.value}"

    @property
    def name(self) -> str:
        """Its build folder's name."""
        return f"{self.target}_{self.schedule}-{self.value}"


def build_target_for(target: str) -> str:
    """The ``pendc build --target`` whose multiplier shape the synthesis target has: the target
    itself when the compiler knows it, else one of the same shape (formats fit the multiplier)."""
    from ..passes.qformats import MULT_SHAPES
    from ..synth.flow import TARGETS

    if target in MULT_SHAPES:
        return target
    shape = tuple(TARGETS[target].multiplier)
    same = [t for t, s in MULT_SHAPES.items() if tuple(s) == shape]
    if not same:
        raise PendcError(f"explore: --target {target}: no build target has its {shape[0]}x{shape[1]} multiplier "
                         f"(pendc build --target takes {', '.join(MULT_SHAPES)})")
    return same[0]


def points_for(presets, targets, iis) -> list:
    """Every (target, schedule) point of the options, after checking each value (a one-line error
    names the first bad one)."""
    from ..passes.schedule import PRESETS
    from ..synth.flow import TARGETS

    if not presets and not iis:
        raise PendcError("explore: give at least one schedule: --preset NAME or --ii N (each repeatable)")
    for p in presets:
        if p not in PRESETS:
            raise PendcError(f"explore: --preset {p}: unknown preset (known: {', '.join(PRESETS)})")
    for t in targets:
        if t not in TARGETS:
            raise PendcError(f"explore: --target {t}: unknown synthesis target (known: {', '.join(TARGETS)})")
        build_target_for(t)
    for n in iis:
        if n < 1:
            raise PendcError(f"explore: --ii must be at least 1, got {n}")
    schedules = [("preset", p) for p in dict.fromkeys(presets)] + [("ii", n) for n in dict.fromkeys(iis)]
    return [Point(t, kind, value) for t in dict.fromkeys(targets) for kind, value in schedules]


def write_manifest(folder: Path, model_text: str, model_source: str, points: list, freq_mhz: float) -> None:
    """``explore.json``: what the sweep is, for a resume."""
    (folder / ROWS).mkdir(parents=True, exist_ok=True)
    data = {"version": MANIFEST_VERSION, "model_source": model_source, "freq_mhz": freq_mhz,
            "points": [{"target": p.target, "schedule": p.schedule, "value": p.value} for p in points],
            "model_text": model_text}
    write_atomic(folder / MANIFEST, json.dumps(data, indent=1) + "\n")


def read_manifest(folder) -> dict:
    """The manifest of the explore sweep in ``folder``, its points as :class:`Point` (a one-line
    error if it holds none)."""
    path = Path(folder) / MANIFEST
    if not path.is_file():
        raise PendcError(f"{folder}: not an explore folder (no {MANIFEST}; pendc explore --out DIR makes one)")
    try:
        data = json.loads(path.read_text())
        if data.get("version") != MANIFEST_VERSION:
            raise ValueError(f"version {data.get('version')!r}, this pendc reads {MANIFEST_VERSION}")
        data["points"] = [Point(p["target"], p["schedule"], p["value"]) for p in data["points"]]
        if not isinstance(data["model_text"], str) or not isinstance(data["freq_mhz"], (int, float)):
            raise ValueError("model_text must be text, freq_mhz a number")
    except (ValueError, KeyError, TypeError) as exc:
        raise PendcError(f"{path}: not an explore manifest pendc can read ({exc})") from None
    return data


def sweep_key(manifest: dict) -> str:
    """The run's name on the scheduler: a hash of what it computes (two sweeps on one cluster differ)."""
    text = json.dumps([manifest["model_text"], manifest["freq_mhz"],
                       [(p.target, p.schedule, p.value) for p in manifest["points"]]])
    return "pendc-explore-" + hashlib.sha256(text.encode()).hexdigest()[:16]


def _last_error(text: str) -> str:
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    errors = [ln for ln in lines if ln.startswith("pendc: error: ")]
    return (errors or lines or ["no message"])[-1].removeprefix("pendc: error: ")


def build_and_synthesize(point: Point, model_text: str, freq_mhz: float) -> dict:
    """The task of one design point (runs on a worker): ``pendc build``, then ``synthesize``.
    Returns the row's figures and ``files`` (the build folder's files, name -> text)."""
    from ..synth.flow import synthesize

    row = {"target": point.target, "schedule": point.label, **{f: None for f in FIGURES},
           "step_time_ns": None, "step_source": None, "fits": None, "misfit": "", "fmax_bound": "",
           "real_time": None, "design_hash": None, "pnr_note": "", "error": None}
    with tempfile.TemporaryDirectory(prefix="pendc-explore-") as tmp:
        model, out = Path(tmp) / "model.toml", Path(tmp) / "build"
        model.write_text(model_text, encoding="utf-8")
        # the command itself, in a child interpreter: what `pendc build` writes is what a user's would
        cmd = [sys.executable, "-m", "pendc.cli", "build", "--model", str(model), "-o", str(out),
               "--target", build_target_for(point.target), f"--{point.schedule}", str(point.value)]
        run = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
        if run.returncode != 0:
            return {**row, "error": f"pendc build: {_last_error(run.stderr + run.stdout)}", "files": {}}
        try:
            result = synthesize(out, point.target, freq_mhz=freq_mhz)
        except PendcError as exc:
            return {**row, "error": f"synthesis: {exc}", "files": {}}
        files = {p.name: p.read_text(encoding="utf-8") for p in sorted(out.iterdir()) if p.is_file()}
    est = result.estimate.get("estimated_step_ns")
    step, source = (result.step_ns, "routed") if result.step_ns else (est, "estimated") if est else (None, None)
    return {**row, "ii": result.ii, "fmax_mhz": result.fmax_mhz, "step_ns": result.step_ns,
            "estimated_step_ns": est, "dsp": result.dsp, "lut": result.lut, "ff": result.ff,
            "carry": result.carry, "bram": result.bram, "logic_depth": result.logic_depth,
            "step_time_ns": step, "step_source": source, "fits": result.fits,
            "misfit": "; ".join(f"{what} {used} of {have}" for what, used, have in result.misfit),
            "fmax_bound": result.fmax_bound, "real_time": result.real_time, "design_hash": result.design_hash,
            "pnr_note": result.pnr_note, "files": files}


def keep_build(folder: Path, points: list):
    """The engine's ``keep``: the task's build files into ``folder/builds/NAME/`` (the way ``pendc
    build`` writes a folder: complete or not at all), the row without them."""
    from ..backend.hdl import write_hdl

    def keep(index: int, result: dict) -> dict:
        files = result.pop("files", None) or {}
        build = None
        if files:
            build = f"{BUILDS}/{points[index].name}"
            write_hdl(folder / build, files)
        return {**result, "build": build}
    return keep
