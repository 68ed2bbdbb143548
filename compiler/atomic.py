"""Atomic file output: nothing is ever half-written, and nothing the user has is damaged.

A writer refuses to replace something of another kind (a folder, a device, a socket),
every error names the user's path (never the temporary file's), and a new file gets
the mode the umask gives an ordinary file (an existing file keeps its own mode).
"""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

from .errors import PendcError


def current_umask() -> int:
    """The process umask (reading it means setting it, so it is set straight back)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


def _target_of(path: Path) -> Path:
    """The file a write to ``path`` lands in: a symlink is followed, so the link survives."""
    if path.is_symlink():
        return Path(os.path.realpath(path))
    return path


def write_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` (UTF-8, ``\\n`` line ends) to ``path`` via a temporary file and a rename.

    Raises :class:`PendcError` naming ``path`` if it is a folder or anything but a regular
    file, if its folder is missing or not writable, or if the write fails (disk full)."""
    write_bytes_atomic(path, text.encode("utf-8"))


def check_file_output(path: str | os.PathLike) -> Path:
    """Raise :class:`PendcError` naming ``path`` unless a file can be written there (no folder,
    device or socket in the way, its folder exists, no trailing '/'); the file a write lands in.
    Call it before long work whose result goes to ``path``."""
    if str(path).endswith(("/", os.sep)) and not Path(path).is_dir():
        raise PendcError(f"{path}: ends in '/', which names a folder; give a file name")
    shown = Path(path)
    path = _target_of(shown)
    folder = path.parent if str(path.parent) else Path(".")
    if path.exists() and not path.is_file():
        kind = "a folder" if path.is_dir() else "not a regular file"
        raise PendcError(f"{shown}: is {kind}; refusing to replace it with a file")
    if not folder.is_dir():
        raise PendcError(f"{shown}: folder {folder} does not exist")
    return path


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> None:
    """Binary :func:`write_atomic`: the same refusals, messages and modes (images, videos)."""
    shown = Path(path)
    path = check_file_output(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        mode = stat.S_IMODE(path.stat().st_mode) if path.exists() else 0o666 & ~current_umask()
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=folder)
    except OSError as exc:
        raise PendcError(f"{shown}: cannot write in folder {folder}: {_reason(exc)}") from None
    try:
        os.chmod(tmp, mode)   # mkstemp makes it private; the result is an ordinary file
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException as exc:
        if os.path.exists(tmp):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise PendcError(f"{shown}: cannot write: {_reason(exc)}") from None
        raise


def make_public_dir(prefix: str, parent: Path) -> Path:
    """A new empty folder in ``parent`` with the mode the umask gives (mkdtemp's is 0700)."""
    folder = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
    os.chmod(folder, 0o777 & ~current_umask())
    return folder
