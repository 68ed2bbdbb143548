"""Model files (spec §7): TOML in, TOML out.

Reading uses the standard library's ``tomllib``; writing is a small, deterministic
emitter (the format needs only tables of floats and one list of strings), so no
TOML-writing dependency is needed. Files are written with :func:`pendc.atomic.write_atomic`,
so a failed write never leaves half a model behind.
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import tomllib
from dataclasses import replace
from pathlib import Path

from ..atomic import write_atomic
from ..errors import PendcError, open_input
from .bodies import DEFAULT_BODY
from .plant import PlantModel

TOP_LEVEL = ("plant", "effects", "input", "fit", "meta", "hardware")


def default_model_path() -> Path:
    """``models/sct_thesis_final.toml`` (Table 14 of the thesis): the copy shipped in the
    package (``pendc/models/`` of an installed wheel), else the source tree's ``models/``."""
    from importlib import resources

    shipped = Path(str(resources.files("pendc"))) / "models" / "sct_thesis_final.toml"
    if shipped.is_file():
        return shipped
    return Path(__file__).resolve().parents[2] / "models" / "sct_thesis_final.toml"


STDIN = "-"    # the path that means standard input, as for every file pendc reads
STDIN_SOURCE = "<stdin>"   # what errors and provenance call a model read from standard input


def read_model_text(path: str | os.PathLike | None = None) -> tuple[str, str]:
    """The text of a model file and the name errors give it: ``None`` is the shipped default
    model, ``-`` standard input (named ``<stdin>``)."""
    if path is not None and str(path) == STDIN:
        import sys

        data, source = sys.stdin.buffer.read(), STDIN_SOURCE
    else:
        path = Path(path) if path is not None else default_model_path()
        source = str(path)
        with open_input(path, "model file") as f:
            data = f.read()
    try:
        return data.decode("utf-8"), source
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise PendcError(f"{source}: line {line}: not UTF-8 text ({exc.reason}); a model file is UTF-8") from None


def load_model(path: str | os.PathLike | None = None) -> PlantModel:
    """Read and validate a model file; ``None`` means the shipped default model, ``-`` standard input."""
    text, source = read_model_text(path)
    return parse_model(text, source=source)


def model_fingerprint(model: PlantModel) -> str:
    """``sha256:`` and 16 hex digits of what the compiler reads from ``model`` (its constants,
    effects and ``[hardware]`` table, in a canonical form): equal for the same model wherever
    its file is and whatever its comments, layout or ``[meta]`` and ``[fit]`` tables say."""
    import json

    read = {"plant": model.plant, "effects": model.effects, "hardware": model.hardware}
    if model.body != DEFAULT_BODY:     # the cart-pendulum's fingerprints stay what they were
        read["body"] = model.body
    if model.input_range is not None:  # the input port's full scale follows the range
        read["input"] = list(model.input_range)
    canonical = json.dumps(read, sort_keys=True, separators=(",", ":"), default=repr)
    return "sha256:" + hashlib.sha256(canonical.encode("utf-8")).hexdigest()[:16]


def build_source(model: PlantModel) -> str:
    """How a build names its model (file headers, report.json, and through them the build id):
    the model's fingerprint and the compiler version, never a path, so the same model builds
    byte-identical files wherever it lies and wherever it is built from."""
    from .. import __version__

    return f"model {model_fingerprint(model)}, pendc {__version__}"


def parse_model(text: str, source: str = "<model>") -> PlantModel:
    """Read a model file's text (``source`` names it in errors) into a validated :class:`PlantModel`."""
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
    if not isinstance(fit, dict) or set(fit) - {"free", "intervals"}:
        raise PendcError(f"{source}: [fit] may only hold 'free = [...]' and an [fit.intervals] table")
    free = fit.get("free", [])
    if not isinstance(free, list) or not all(isinstance(p, str) for p in free):
        raise PendcError(f"{source}: [fit] free must be a list of parameter names")
    _check_intervals(fit.get("intervals", {}), source)
    hardware = doc.get("hardware", {})
    if not isinstance(hardware, dict):
        raise PendcError(f"{source}: [hardware] must be a table")
    plant = doc["plant"]
    if not isinstance(plant, dict):
        raise PendcError(f"{source}: [plant] must be a table")
    # [plant] body = "..." selects the rigid body (pendc.model.bodies); the rest are its constants
    body = plant.get("body", DEFAULT_BODY)
    constants = {k: v for k, v in plant.items() if k != "body"}
    return PlantModel(plant=constants, effects=doc.get("effects", {}), free=tuple(free), source=source,
                      hardware=hardware, body=body, input_range=_input_range(doc.get("input"), source))


def _input_range(table, source: str):
    """``[input] range = [low, high]`` (the input's unit): what the actuator takes; None when
    the file does not say (the body's own range holds). PlantModel checks the numbers."""
    if table is None:
        return None
    if not isinstance(table, dict) or set(table) - {"range"}:
        raise PendcError(f"{source}: [input] may only hold 'range = [low, high]' (in the input's unit)")
    if "range" not in table:
        raise PendcError(f"{source}: [input] lacks 'range = [low, high]'")
    pair = table["range"]
    if not isinstance(pair, list) or len(pair) != 2:
        raise PendcError(f"{source}: input.range must be [low, high], got {pair!r}")
    return tuple(pair)


def _check_intervals(intervals, source: str) -> None:
    """``[fit.intervals]``: parameter -> [low, high] (the 95 % interval a fit reported)."""
    if not isinstance(intervals, dict):
        raise PendcError(f"{source}: [fit.intervals] must be a table of [low, high] pairs")
    for name, pair in intervals.items():
        if (not isinstance(pair, list) or len(pair) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in pair)):
            raise PendcError(f"{source}: fit.intervals.{name} must be [low, high], got {pair!r}")


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
    if model.body != DEFAULT_BODY:
        lines.append(f"body = {_string(model.body)}")
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
    """Write ``model`` (and ``meta``) as a model file, atomically."""
    write_atomic(path, dumps_model(model, meta))


_TABLE = re.compile(r"^\s*\[([A-Za-z0-9_.]+)\]\s*(#.*)?$")
_ASSIGN = re.compile(r"^(\s*)([A-Za-z_][A-Za-z0-9_]*)(\s*=\s*)([^#]*?)(\s*#.*)?$")


def dumps_fitted(model: PlantModel, source_text: str, meta: dict, intervals: dict) -> str:
    """A fitted model's file written over its source model's text.

    The source's comments and layout stay; each value is replaced by the fitted one,
    effects the fit added are appended, ``[meta]`` records where the model came from and
    ``[fit.intervals]`` holds each fitted value's 95 % interval. The source's own ``[meta]``
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
    head = ["# Fitted by pendc; see [meta] for the data and the command, [fit.intervals] for 95 % intervals.", "",
            "[meta]"]
    head += [f"{k} = {_number(v) if isinstance(v, (int, float)) else _string(str(v))}" for k, v in meta.items()]
    tail = []
    if model.free:
        tail += ["", "[fit]", "free = [" + ", ".join(_string(p) for p in model.free) + "]"]
    finite = {k: v for k, v in intervals.items() if all(map(math.isfinite, v))}
    if finite:
        tail += ["", "[fit.intervals]"] + [f"{k} = [{_number(lo)}, {_number(hi)}]" for k, (lo, hi) in finite.items()]

    def assemble(body: str) -> str:
        return "\n".join(head) + "\n\n" + body.strip("\n") + "\n" + ("\n".join(tail) + "\n" if tail else "")

    text = assemble("\n".join(out))
    try:
        back = parse_model(text, source="<fitted model>")
        same = (back.plant == model.plant and back.effects == model.effects and back.body == model.body
                and back.input_range == model.input_range)
    except PendcError:
        same = False
    if not same:
        # the source's layout defeated the line editor (e.g. inline tables, a fitted optional
        # parameter the source left out): write the values plainly, keeping the provenance
        plain = replace(model, free=())
        text = assemble(dumps_model(plain))
    return text


def data_fingerprint(path: str | os.PathLike) -> str:
    """``name (sha256 first 16 hex)``: which data a fit used, reproducibly (no dates)."""
    digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]
    return f"{Path(path).name} (sha256 {digest})"
