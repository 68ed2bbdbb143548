"""Writing model files: a model as deterministic TOML, and a fitted model over its source's text.

A small emitter (the format needs only tables of floats, a few strings and lists), so no
TOML-writing dependency; files go out through :func:`pendc.atomic.write_atomic`, so a failed
write never leaves half a model behind. Reading lives in :mod:`pendc.model.modelfile`.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from dataclasses import replace

from ..atomic import write_atomic
from ..errors import PendcError
from .modelfile import parse_model
from .plant import PlantModel
from .plantfile import PHYSICS


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
    physics = model.definition.physics
    lines.append("[plant]")
    lines += [f"{k} = {_inline(v)}" for k, v in physics.get("plant", {}).items()]
    lines += [f"{k} = {_number(v)}" for k, v in model.plant.items()]
    for name, params in model.effects.items():
        lines += ["", f"[effects.{name}]"]
        lines += [f"{k} = {_number(v)}" for k, v in params.items()]
    if model.input_range is not None:
        lines += ["", "[input]", f"range = [{_number(model.input_range[0])}, {_number(model.input_range[1])}]"]
    if model.free:
        lines += ["", "[fit]", "free = [" + ", ".join(_string(p) for p in model.free) + "]"]
    scalars = {k: v for k, v in model.hardware.items() if not isinstance(v, dict)}
    tables = {k: v for k, v in model.hardware.items() if isinstance(v, dict)}
    if scalars:
        lines += ["", "[hardware]"] + [f"{k} = {_value(v)}" for k, v in scalars.items()]
    for name, table in tables.items():
        lines += ["", f"[hardware.{name}]"] + [f"{k} = {_value(v)}" for k, v in table.items()]
    for key in PHYSICS:
        if key in physics:
            lines += _table_lines(key, physics[key])
    return "\n".join(lines) + "\n"


_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if _BARE.match(k) else _string(k)


def _inline(v) -> str:
    """A TOML value written on one line (lists and tables inline)."""
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_inline(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ", ".join(_inline(x) for x in v) + "]"
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return _value(v)


def _table_lines(path: str, table: dict) -> list:
    """``[path]`` with its values, then its sub-tables as their own headers."""
    out = ["", f"[{path}]"]
    subs = {}
    for k, v in table.items():
        if isinstance(v, dict):
            subs[k] = v
        else:
            out.append(f"{_key(k)} = {_inline(v)}")
    for k, v in subs.items():
        out += _table_lines(f"{path}.{_key(k)}", v)
    return out


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return _number(v)
    return _string(str(v))


def save_model(model: PlantModel, path: str | os.PathLike, meta: dict | None = None) -> None:
    """Write ``model`` (and ``meta``) as a model file, atomically."""
    write_atomic(path, dumps_model(model, meta))


_TABLE = re.compile(r"^\s*\[([A-Za-z0-9_.]+)\]\s*(#.*)?$")
_ASSIGN = re.compile(r"^(\s*)([A-Za-z_][A-Za-z0-9_]*)(\s*=\s*)([^#]*?)(\s*#.*)?$")


def dumps_fitted(model: PlantModel, source_text: str, meta: dict, intervals: dict,
                 covariance: tuple | None = None) -> str:
    """A fitted model's file written over its source model's text.

    The source's comments and layout stay; each value is replaced by the fitted one,
    effects the fit added are appended, ``[meta]`` records where the model came from and
    ``[fit.intervals]`` holds each fitted value's 95 % interval, ``[fit.covariance]`` the
    covariance ``(names, matrix)`` of those values when given. The source's own ``[meta]``
    and ``[fit]`` tables are replaced. The result reads back as exactly ``model``."""
    values = {"plant": model.plant, **{f"effects.{e}": p for e, p in model.effects.items()}}
    out, table, seen, skip = [], None, set(), False
    for line in source_text.splitlines():
        head = _TABLE.match(line)
        if head:
            table = head.group(1)
            skip = table in ("meta", "fit") or table.startswith(("meta.", "fit.")) or \
                (table.startswith("effects.") and table not in values)
            seen.add(table)
            if skip:
                continue
        elif skip:
            continue
        else:
            assign = _ASSIGN.match(line)
            if assign and table in values and assign.group(2) in values[table]:
                indent, key, eq, _, comment = assign.groups()
                line = f"{indent}{key}{eq}{_number(values[table][key])}{comment or ''}"
        out.append(line)
    for table, params in values.items():
        if table not in seen:
            out += ["", f"[{table}]"] + [f"{k} = {_number(v)}" for k, v in params.items()]
    head = ["# Fitted by pendc; see [meta] for the data and the command, [fit.intervals] for 95 % intervals,",
            "# [fit.covariance] for the covariance of the fitted values.", "",
            "[meta]"]
    head += [f"{k} = {_number(v) if isinstance(v, (int, float)) else _string(str(v))}" for k, v in meta.items()]
    tail = []
    if model.free:
        tail += ["", "[fit]", "free = [" + ", ".join(_string(p) for p in model.free) + "]"]
    finite = {k: v for k, v in intervals.items() if all(map(math.isfinite, v))}
    if finite:
        tail += ["", "[fit.intervals]"] + [f"{k} = [{_number(lo)}, {_number(hi)}]" for k, (lo, hi) in finite.items()]
    if covariance is not None and len(covariance[0]):
        names, matrix = covariance
        rows = "".join("\n  [" + ", ".join(_number(v) for v in row) + "]," for row in matrix)
        tail += ["", "[fit.covariance]", "names = [" + ", ".join(_string(n) for n in names) + "]",
                 f"matrix = [{rows}\n]"]

    def assemble(body: str) -> str:
        return "\n".join(head) + "\n\n" + body.strip("\n") + "\n" + ("\n".join(tail) + "\n" if tail else "")

    text = assemble("\n".join(out))
    try:
        back = parse_model(text, source="<fitted model>")
        same = "extends" not in tomllib.loads(source_text) and (
            back.plant == model.plant and back.effects == model.effects and back.definition == model.definition
                and back.input_range == model.input_range)
    except PendcError:
        same = False
    if not same:
        # the source's layout defeated the line editor (e.g. inline tables, a fitted optional
        # parameter the source left out): write the values plainly, keeping the provenance
        plain = replace(model, free=())
        text = assemble(dumps_model(plain))
    return text
