"""On-disk cache of compiler results, so a second ``pendc build``/``report``/``simulate --fixed``
of the same model with the same options and the same compiler does not redo range
analysis and the error budget (about half a minute).

The key is a hash of the model file's canonical text, the build options and the source
of the compiler itself; any change to one of them is a miss. Entries are pickles written
atomically; an unreadable entry is ignored and rebuilt. Two processes that miss the same
entry at once (two test workers, two terminals) compile it once: a miss takes an exclusive
lock on a file next to the entry, and whoever waited for it reads the entry the first wrote.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import tempfile
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

try:
    import fcntl
except ImportError:     # no flock (Windows): concurrent misses compile twice, as before the lock
    fcntl = None

from ..codegen import cache_dir
from ..model.modelfile import model_fingerprint
from ..model.plant import PlantModel
from ..passes.pipeline import BuildOptions, BuildResult, compile_model, options_from_model

_PACKAGE = Path(__file__).resolve().parents[1]      # the package pendc (this module is in caching/)


# Everything the compile reads: the whole package minus the parts that only consume a build
# (identification, HIL, the command line, reports, synthesis). A rule over folders rather than
# "the modules imported now", because what is imported depends on the command that asked and the
# key must not; tests/test_package.py checks every module pipeline imports is covered.
_NOT_READ_BY_THE_COMPILE = ("ident/", "hil/", "cli", "api.py", "synth", "report_")


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
    """What a cached build is found by: the model as the compile reads it (its fingerprint: an
    edit of its identification advice or drawing rebuilds nothing), the options and the compiler."""
    text = model_fingerprint(model) + repr(options)
    return hashlib.sha256((text + _compiler_digest()).encode()).hexdigest()[:24]


def cache_path(model: PlantModel, options: BuildOptions) -> Path:
    return cache_dir("builds") / f"build_{build_key(model, options)}.pickle"


def _read_entry(path: Path, model: PlantModel) -> BuildResult | None:
    """The cached result at ``path`` for ``model``, or None (missing, stale or truncated)."""
    if not path.exists():
        return None
    try:
        with path.open("rb") as fh:
            cached = pickle.load(fh)
        return replace(cached, model=model)
    except Exception:  # a stale or truncated entry is just a miss
        return None


@contextmanager
def _entry_lock(path: Path):
    """Exclusive lock on ``<entry>.lock`` for the time of one compilation (released when the
    process ends, however it ends)."""
    if fcntl is None:
        yield
        return
    with open(path.with_name(path.name + ".lock"), "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def compile_cached(model: PlantModel, options: BuildOptions | None = None, use_cache: bool = True,
                   on_miss=None) -> BuildResult:
    """:func:`pendc.passes.pipeline.compile_model`, memoised on disk; ``on_miss()`` is called
    before a real compilation (to tell a user why this takes half a minute). A process that
    misses while another compiles the same entry waits for it and reads its result."""
    options = options or options_from_model(model)
    if not use_cache:
        if on_miss:
            on_miss()
        return compile_model(model, options)
    path = cache_path(model, options)
    cached = _read_entry(path, model)
    if cached is not None:
        return cached
    with _entry_lock(path):
        cached = _read_entry(path, model)       # written while this process waited for the lock
        if cached is not None:
            return cached
        if on_miss:
            on_miss()
        result = compile_model(model, options)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".build.")
        with os.fdopen(fd, "wb") as fh:
            pickle.dump(replace(result, model=None), fh)
        os.replace(tmp, path)
    return result
