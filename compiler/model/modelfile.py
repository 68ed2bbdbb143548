"""Model files (spec §7): reading TOML into a :class:`~pendc.model.plant.PlantModel`.

Reading uses the standard library's ``tomllib`` and follows ``extends`` chains; writing
(deterministic, atomic) lives in :mod:`pendc.model.model_writer`.
"""

from __future__ import annotations

import hashlib
import os
import tomllib
from functools import lru_cache
from pathlib import Path

from ..errors import PendcError, open_input
from .fit_uncertainty import FitTableError, FitUncertainty, check_fit_table, uncertainty_of
from .plant import PlantModel
from .plantfile import PHYSICS, PLANT_META, read_definition

TOP_LEVEL = ("extends", "plant", "effects", "input", "fit", "meta", "hardware") + PHYSICS
# physics tables no build reads: identification's advice, HIL's operating points, the animation
NOT_READ_BY_THE_BUILD = ("identification", "operating_points", "drawing")
MAX_EXTENDS = 8      # a chain of files extending each other longer than this is a mistake (or a loop)


DEFAULT_MARKER = "DEFAULT"   # models/DEFAULT: one line, the file name of the model read without --model


def models_dir() -> Path:
    """The shipped models: ``pendc/models/`` of an installed wheel, else the source tree's
    ``models/``."""
    from importlib import resources

    shipped = Path(str(resources.files("pendc"))) / "models"
    if (shipped / DEFAULT_MARKER).is_file():
        return shipped
    return Path(__file__).resolve().parents[2] / "models"


def default_model_path() -> Path:
    """The shipped default model: the file ``models/DEFAULT`` names (which plant is the default
    is the models folder's business, not the compiler's)."""
    folder = models_dir()
    try:
        name = (folder / DEFAULT_MARKER).read_text(encoding="utf-8").strip()
    except OSError as exc:
        raise PendcError(f"{folder / DEFAULT_MARKER}: cannot read the default model's name ({exc.strerror})") from None
    if not name or "/" in name or "\\" in name or not (folder / name).is_file():
        raise PendcError(f"{folder / DEFAULT_MARKER}: '{name}' is not a model file in {folder}")
    return folder / name


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
    effects, ``[hardware]`` table and physics, in a canonical form): equal for the same model wherever
    its file is and whatever its comments, layout, ``[meta]`` and ``[fit]`` tables or the physics
    tables only identification and HIL read (:data:`NOT_READ_BY_THE_BUILD`) say."""
    import json

    physics = {k: v for k, v in model.definition.physics.items() if k not in NOT_READ_BY_THE_BUILD}
    d = model.definition
    read = {"plant": model.plant, "effects": model.effects, "hardware": model.hardware,
            "physics": json.dumps(physics, sort_keys=True, default=repr),
            "names": [d.name, d.core, d.summary, d.source]}     # module names and header comments
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


def parse_model(text: str, source: str = "<model>", _chain: tuple = ()) -> PlantModel:
    """Read a model file's text (``source`` names it in errors) into a validated :class:`PlantModel`.

    The physics come from the file's own tables, from the file it ``extends`` (a path
    relative to it; its values are overridden by this file's ``[plant]`` numbers, and its
    active effects by this file's ``[effects]`` when it has that table), or, for a file of
    values alone, from the shipped plant its ``[plant] body = "NAME"`` names (the default
    model's plant when it names none)."""
    doc = _merged(text, source, _chain)
    fit = doc.get("fit", {})
    try:
        check_fit_table(fit)
    except FitTableError as exc:
        raise PendcError(f"{source}: {exc}") from None
    free = fit.get("free", [])
    hardware = doc.get("hardware", {})
    if not isinstance(hardware, dict):
        raise PendcError(f"{source}: [hardware] must be a table")
    plant = doc["plant"]
    definition = read_definition(doc, source)
    constants = {k: v for k, v in plant.items() if k not in PLANT_META and k != "body"}
    for name in definition.constants:        # a value given in the declaration instead of [plant]
        declared = doc.get("constants", {}).get(name)
        if name not in constants and isinstance(declared, dict) and "value" in declared:
            constants[name] = declared["value"]
    return PlantModel(plant=constants, effects=doc.get("effects", {}), free=tuple(free), source=source,
                      hardware=hardware, definition=definition, input_range=_input_range(doc.get("input"), source))


def _load_toml(text: str, source: str) -> dict:
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise PendcError(f"{source}: not valid TOML ({exc})") from None
    unknown = [k for k in doc if k not in TOP_LEVEL]
    if unknown:
        raise PendcError(f"{source}: unknown top-level key(s) {', '.join(sorted(unknown))} (allowed: {', '.join(TOP_LEVEL)})")
    if "plant" not in doc:
        raise PendcError(f"{source}: missing [plant] table")
    if not isinstance(doc["plant"], dict):
        raise PendcError(f"{source}: [plant] must be a table")
    return doc


def has_physics(doc: dict) -> bool:
    """Whether a parsed file declares physics of its own (a plant file, not values alone)."""
    return any(k in doc for k in PHYSICS) or "name" in doc.get("plant", {})


def _merged(text: str, source: str, chain: tuple) -> dict:
    """The file's document with the physics (and values) of what it extends filled in."""
    doc = _load_toml(text, source)
    base_path = None
    if "extends" in doc:
        if has_physics(doc) or "body" in doc["plant"]:
            found = [f"[{k}]" for k in PHYSICS if k in doc] + [f"[plant] {k}" for k in ("name", "body")
                                                                if k in doc.get("plant", {})]
            raise PendcError(f"{source}: extends: a file that extends another declares no physics (and no body) "
                             f"of its own; remove {', '.join(found)} (the name, too, is the extended plant's)")
        if not isinstance(doc["extends"], str) or not doc["extends"]:
            raise PendcError(f"{source}: extends must be the path of a plant file, got {doc['extends']!r}")
        here = Path(source).parent if source not in (STDIN_SOURCE, "<model>") else Path.cwd()
        base_path = (here / doc["extends"]).resolve()
        shipped = models_dir() / doc["extends"]
        if not base_path.is_file() and shipped.is_file():   # a copied model still finds the shipped plant
            base_path = shipped.resolve()
    elif not has_physics(doc):
        base_path = _shipped_plant(doc["plant"].get("body"), source)
    if base_path is None:
        return doc
    if str(base_path) in chain or len(chain) >= MAX_EXTENDS:
        raise PendcError(f"{source}: extends: {base_path.name} extends itself through a loop of files")
    base_text, base_source = read_model_text(base_path)
    base = _merged(base_text, base_source, chain + (str(base_path),))
    # the physics come from the base; values only through extends (a file of values alone
    # names every constant itself, as model files always have), effects never: a model file
    # lists the effects it has
    out = {k: v for k, v in base.items() if k in PHYSICS}
    inherited = base["plant"] if "extends" in doc else {k: v for k, v in base["plant"].items() if k in PLANT_META}
    out["plant"] = {**inherited, **{k: v for k, v in doc["plant"].items() if k != "body"}}
    for key in ("effects", "input", "hardware", "fit", "meta"):
        if key in doc:
            out[key] = doc[key]
    return out


def shipped_plants() -> dict:
    """Plant name -> the shipped model file of it that declares its physics (the first in
    name order), as a :class:`PlantModel`. Read once per process: every command's parser
    names the shipped plants' experiments in its help."""
    return dict(_shipped_models())


@lru_cache(maxsize=1)
def _shipped_models() -> tuple:
    return tuple((name, load_model(path)) for name, path in _shipped_files().items())


def _shipped_files() -> dict:
    known = {}
    for path in sorted(models_dir().glob("*.toml")):
        try:
            plant = tomllib.loads(path.read_text(encoding="utf-8")).get("plant", {})
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
            continue
        if isinstance(plant, dict) and isinstance(plant.get("name"), str):
            known.setdefault(plant["name"], path)
    return known


def _shipped_plant(name, source: str) -> Path:
    """The shipped model file whose plant is called ``name`` (the default model for None)."""
    if name is None:
        return default_model_path()
    if not isinstance(name, str):
        raise PendcError(f"{source}: plant.body must be a string naming a shipped plant, got {name!r}")
    known = _shipped_files()
    if name not in known:
        raise PendcError(f"{source}: plant.body = '{name}' is not a shipped plant (known: {', '.join(sorted(known))}); "
                         f"declare the plant's physics in the file or extend a plant file")
    return known[name]


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


def load_fit_uncertainty(path: str | os.PathLike | None) -> FitUncertainty | None:
    """What the fit that wrote model file ``path`` left uncertain (see :func:`fit_uncertainty_of`)."""
    text, source = read_model_text(path)
    return fit_uncertainty_of(text, source, parse_model(text, source=source))


def fit_uncertainty_of(text: str, source: str, model: PlantModel) -> FitUncertainty | None:
    """The ``[fit]`` covariance (else intervals) of a model file's ``text`` around the values of
    ``model`` (that text, read); None for a file no fit wrote."""
    try:
        return uncertainty_of(tomllib.loads(text).get("fit", {}), model.parameter_values())
    except FitTableError as exc:
        raise PendcError(f"{source}: {exc}") from None


def data_fingerprint(path: str | os.PathLike) -> str:
    """``name (sha256 first 16 hex)``: which data a fit used, reproducibly (no dates)."""
    digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]
    return f"{Path(path).name} (sha256 {digest})"


def fitted_parameters(path: str | os.PathLike | None) -> tuple:
    """The parameters the fit that wrote model file ``path`` freed (its ``[meta] fitted``, which
    ``pendc fit`` writes); empty for a model no fit wrote, the default model or standard input."""
    if path is None or str(path) == STDIN:
        return ()
    try:
        meta = tomllib.loads(read_model_text(path)[0]).get("meta", {})
    except (PendcError, tomllib.TOMLDecodeError):
        return ()
    if not isinstance(meta, dict) or meta.get("generator") != "pendc fit":
        return ()
    return tuple(p.strip() for p in str(meta.get("fitted", "")).split(",") if p.strip())
