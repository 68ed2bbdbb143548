"""MATLAB .mat files (v4, v5, v7 through scipy.io.loadmat) as a :class:`~pendc.sim.table.Table`.

Every numeric signal in the file becomes a named column; the names are what
``--columns`` maps onto pendc's, and what an error lists when a file cannot be mapped:

- a vector variable ``v`` -> ``v``; a matrix with k columns (samples along the longer
  dimension) -> ``v:1`` ... ``v:k`` (MATLAB's 1-based column numbers);
- Simulink To Workspace "Structure with time" / "Structure" (a struct with ``time``
  and ``signals``, ``signals`` one struct or an array of them with ``values``,
  ``label``, ``blockName``): one signal in the struct is named after the variable,
  several after their ``label`` (else the last part of ``blockName``), each suffixed
  ``:j`` when its ``values`` has several columns; the struct's ``time`` is kept as that
  signal's own time vector (``v.time`` is also a column);
- timeseries-like structs with ``Time`` and ``Data`` fields, named like a variable;
- other structs: each field, named ``struct.field``, and cell arrays: each cell,
  named ``cell{i}`` (1-based, column-major as MATLAB counts), by the same rules;
- a text variable or a scalar -> metadata (so ``experiment = '<name>'`` in the
  file declares the experiment, ``Ts = 1e-4`` can give a sample time).

MATLAB objects (timeseries, Simulink.SimulationOutput, saved without ``-v7`` struct
conversion) cannot be read by scipy; they are named in the error. v7.3 files are HDF5
and are refused with the way out (save with ``-v7``).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import PendcError
from .table import Table

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def is_mat_file(head: bytes, name: str) -> bool:
    """Whether a file starting with ``head`` (its first 128 bytes or more) is a .mat file."""
    return head.startswith(b"MATLAB") or name.lower().endswith(".mat")


def read_mat_table(path: str) -> Table:
    """Read the numeric signals of a .mat file (see the module docstring)."""
    from scipy.io import loadmat

    with open(path, "rb") as f:
        head = f.read(520)
    if b"MATLAB 7.3" in head[:128] or head[512:520] == HDF5_SIGNATURE or head.startswith(HDF5_SIGNATURE):
        raise PendcError(f"{path}: MATLAB v7.3 (HDF5) file, which pendc cannot read: save it again in MATLAB "
                         f"with save(..., '-v7')")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # scipy's MatReadWarning: what matters is checked below
            content = loadmat(path, simplify_cells=True)
    except NotImplementedError as exc:
        raise PendcError(f"{path}: cannot read this .mat file ({exc})") from None
    except Exception as exc:  # scipy raises ValueError, TypeError, OSError... on a damaged file
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise PendcError(f"{path}: not a readable MATLAB .mat file ({first})") from None
    walker = _Walker()
    for name, value in content.items():
        if not name.startswith("__"):
            walker.add(name, value)
    if not walker.columns:
        what = f"; MATLAB objects scipy cannot read: {', '.join(walker.objects)} (convert them to structs or "
        what = (what + "arrays, or save from To Workspace as 'Structure with time')") if walker.objects else ""
        found = ", ".join(list(content_names(content))) or "nothing"
        raise PendcError(f"{path}: no numeric signal in the file (variables found: {found}){what}")
    return Table(columns=walker.columns, meta=walker.meta, source=str(path), first_line=0,
                 times=walker.times, aliases=walker.aliases, unreadable=tuple(walker.objects))


def content_names(content: dict):
    """The variable names of a loadmat result, without scipy's ``__header__`` entries."""
    return (n for n in content if not n.startswith("__"))


class _Walker:
    """Collects columns, per-signal times, aliases and metadata from loadmat's output."""

    def __init__(self):
        self.columns, self.times, self.aliases, self.meta = {}, {}, {}, {}
        self.objects = []

    def add(self, name: str, value, depth: int = 0) -> None:
        if isinstance(value, str):
            self.meta[name] = value.strip()
        elif isinstance(value, dict):
            self._struct(name, value, depth)
        elif isinstance(value, (int, float, np.number, bool)):
            self.meta[name] = repr(float(value))
        elif isinstance(value, np.ndarray) and value.dtype.kind in "fiub":
            if value.size == 1:
                self.meta[name] = repr(float(value.reshape(())))
            elif value.size > 1:
                self._matrix(name, value)
        elif isinstance(value, np.ndarray) and value.dtype.kind == "U":
            self.meta[name] = " ".join(str(v) for v in value.ravel()).strip()
        elif isinstance(value, np.ndarray) and value.size == 0:
            return
        elif depth < 3 and (isinstance(value, list) or isinstance(value, np.ndarray) and value.dtype.kind == "O"):
            for i, item in enumerate(value.ravel(order="F") if isinstance(value, np.ndarray) else value):  # cells: name{i}
                self.add(f"{name}{{{i + 1}}}", item, depth + 1)
        else:
            self.objects.append(name)

    def _matrix(self, name: str, value: np.ndarray, time=None) -> list:
        """Add a vector or a matrix (samples along the longer dimension); returns column names."""
        try:
            value = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):  # a struct or text where numbers were expected
            self.objects.append(name)
            return []
        if value.size < 2:
            return []
        if value.ndim > 2:
            value = value.reshape(-1, value.shape[-1]).T if value.shape[-1] > max(value.shape[:-1]) else \
                value.reshape(value.shape[0], -1)
        if value.ndim == 2 and value.shape[0] < value.shape[1]:
            value = value.T
        if value.ndim == 1 or value.shape[1] == 1:
            names = [name]
            self.columns[name] = value.reshape(-1)
        else:
            names = [f"{name}:{j + 1}" for j in range(value.shape[1])]
            for j, n in enumerate(names):
                self.columns[n] = np.ascontiguousarray(value[:, j])
        if time is not None:
            for n in names:
                self.times[n] = time
        return names

    def _struct(self, name: str, value: dict, depth: int) -> None:
        fields = {k.lower(): k for k in value}
        if "signals" in fields and "time" in fields:
            self._simulink(name, value[fields["time"]], value[fields["signals"]])
        elif "time" in fields and "data" in fields:
            time = _time_vector(value[fields["time"]])
            self._matrix(name, value[fields["data"]], time)
            if time is not None:
                self.columns.setdefault(f"{name}.time", time)
        elif depth < 3:
            for key, sub in value.items():
                self.add(f"{name}.{key}", sub, depth + 1)

    def _simulink(self, name: str, time, signals) -> None:
        time = _time_vector(time)
        if time is not None:
            self.columns[f"{name}.time"] = time
        signals = signals if isinstance(signals, list) else [signals]
        for i, sig in enumerate(signals):
            if not isinstance(sig, dict) or "values" not in sig:
                self.objects.append(f"{name}.signals({i + 1})")
                continue
            label = _text(sig.get("label"))
            block = _text(sig.get("blockName")).rsplit("/", 1)[-1]
            if len(signals) == 1:
                base = name
            else:
                base = label or block or f"{name}.signals({i + 1})"
                base = base if base not in self.columns else f"{name}.{base}"
            names = self._matrix(base, sig["values"], time)
            for alias in (label, f"{name}.{label}" if label else ""):
                if alias and len(names) == 1 and alias not in self.columns:
                    self.aliases.setdefault(alias, names[0])


def _time_vector(value):
    """A struct's time field as a float vector, or None when it is empty (format "Structure")."""
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        return None
    return arr if arr.size > 1 else None


def _text(value) -> str:
    if isinstance(value, str):
        return value.strip()
    if isinstance(value, np.ndarray) and value.dtype.kind == "U":
        return " ".join(str(v) for v in value.ravel()).strip()
    return ""
