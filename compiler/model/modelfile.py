"""Model files (spec §7): TOML in, TOML out.

Reading uses the standard library's ``tomllib``; writing is a small, deterministic
emitter (the format needs only tables of floats and one list of strings), so no
TOML-writing dependency is needed. Files are written with :func:`pendc.atomic.write_atomic`,
so a failed write never leaves half a model behind.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

from ..atomic import write_atomic
from ..errors import PendcError
from .plant import PlantModel

TOP_LEVEL = ("plant", "effects", "fit", "meta", "hardware")


def default_model_path() -> Path:
    """``models/sct_thesis_final.toml`` of the source tree (Table 14 of the thesis)."""
    return Path(__file__).resolve().parents[2] / "models" / "sct_thesis_final.toml"


def load_model(path: str | os.PathLike | None = None) -> PlantModel:
    """Read and validate a model file; ``None`` means the shipped default model."""
    path = Path(path) if path is not None else default_model_path()
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise PendcError(f"{path}: model file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PendcError(f"{path}: cannot read model file ({exc})") from None
    return parse_model(text, source=str(path))


def parse_model(text: str, source: str = "<model>") -> PlantModel:
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise PendcError(f"{source}: not valid TOML ({exc})") from None
    unknown = set(doc) - set(TOP_LEVEL)
    if unknown:
        raise PendcError(f"{source}: unknown top-level key(s) {', '.join(sorted(unknown))} (allowed: {', '.join(TOP_LEVEL)})")
    if "plant" not in doc:
        raise PendcError(f"{source}: missing [plant] table")
    fit = doc.get("fit", {})
    if not isinstance(fit, dict) or set(fit) - {"free"}:
        raise PendcError(f"{source}: [fit] may only hold 'free = [...]'")
    free = fit.get("free", [])
    if not isinstance(free, list) or not all(isinstance(p, str) for p in free):
        raise PendcError(f"{source}: [fit] free must be a list of parameter names")
    hardware = doc.get("hardware", {})
    if not isinstance(hardware, dict):
        raise PendcError(f"{source}: [hardware] must be a table")
    return PlantModel(plant=doc["plant"], effects=doc.get("effects", {}), free=tuple(free), source=source,
                      hardware=hardware)


def _number(v: float) -> str:
    text = repr(float(v))
    return text if ("." in text or "e" in text or "n" in text) else text + ".0"


def _string(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def dumps_model(model: PlantModel, meta: dict | None = None) -> str:
    """The TOML text of ``model``; ``meta`` (str -> str or number) goes into ``[meta]``."""
    lines = []
    if meta:
        lines.append("[meta]")
        for key, value in meta.items():
            lines.append(f"{key} = {_number(value) if isinstance(value, (int, float)) else _string(str(value))}")
        lines.append("")
    lines.append("[plant]")
    lines += [f"{k} = {_number(v)}" for k, v in model.plant.items()]
    for name, params in model.effects.items():
        lines += ["", f"[effects.{name}]"]
        lines += [f"{k} = {_number(v)}" for k, v in params.items()]
    if model.free:
        lines += ["", "[fit]", "free = [" + ", ".join(_string(p) for p in model.free) + "]"]
    scalars = {k: v for k, v in model.hardware.items() if not isinstance(v, dict)}
    tables = {k: v for k, v in model.hardware.items() if isinstance(v, dict)}
    if scalars:
        lines += ["", "[hardware]"] + [f"{k} = {_value(v)}" for k, v in scalars.items()]
    for name, table in tables.items():
        lines += ["", f"[hardware.{name}]"] + [f"{k} = {_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return _number(v)
    return _string(str(v))


def save_model(model: PlantModel, path: str | os.PathLike, meta: dict | None = None) -> None:
    write_atomic(path, dumps_model(model, meta))
