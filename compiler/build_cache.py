"""On-disk cache of compiler results, so a second ``pendc build``/``report``/``simulate --fixed``
of the same model with the same options and the same compiler does not redo range
analysis and the error budget (about half a minute).

The key is a hash of the model file's canonical text, the build options and the source
of the compiler itself; any change to one of them is a miss. Entries are pickles written
atomically; an unreadable entry is ignored and rebuilt.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import tempfile
from dataclasses import replace
from pathlib import Path

from .codegen import cache_dir
from .model.modelfile import dumps_model
from .model.plant import PlantModel
from .passes.pipeline import BuildOptions, BuildResult, compile_model, options_from_model

_PACKAGE = Path(__file__).resolve().parent


# Everything the compile reads: the whole package minus the parts that only consume a build
# (identification, HIL, the command line, reports, synthesis). A rule over folders rather than
# "the modules imported now", because what is imported depends on the command that asked and the
# key must not; tests/test_package.py checks every module pipeline imports is covered.
_NOT_READ_BY_THE_COMPILE = ("ident/", "hil/", "cli", "api.py", "reports.py", "synth", "report_")


def _compiler_digest() -> str:
    """Hash of the source of every module the compile can read (see the rule above)."""
    h = hashlib.sha256()
    for f in sorted(_PACKAGE.rglob("*.py")):
        rel = f.relative_to(_PACKAGE).as_posix()
        if rel.startswith(_NOT_READ_BY_THE_COMPILE):
            continue
        h.update(rel.encode() + b"\0")
        h.update(f.read_bytes())
    return h.hexdigest()


def build_key(model: PlantModel, options: BuildOptions) -> str:
    text = dumps_model(model) + repr(sorted(getattr(model, "hardware", {}).items())) + repr(options)
    return hashlib.sha256((text + _compiler_digest()).encode()).hexdigest()[:24]


def cache_path(model: PlantModel, options: BuildOptions) -> Path:
    return cache_dir("builds") / f"build_{build_key(model, options)}.pickle"


def compile_cached(model: PlantModel, options: BuildOptions | None = None, use_cache: bool = True,
                   on_miss=None) -> BuildResult:
    """:func:`pendc.passes.pipeline.compile_model`, memoised on disk; ``on_miss()`` is called
    before a real compilation (to tell a user why this takes half a minute)."""
    options = options or options_from_model(model)
    path = cache_path(model, options)
    if use_cache and path.exists():
        try:
            with path.open("rb") as fh:
                cached = pickle.load(fh)
            return replace(cached, model=model)
        except Exception:  # a stale or truncated entry is just a miss
            pass
    if on_miss:
        on_miss()
    result = compile_model(model, options)
    if use_cache:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".build.")
        with os.fdopen(fd, "wb") as fh:
            pickle.dump(replace(result, model=None), fh)
        os.replace(tmp, path)
    return result
