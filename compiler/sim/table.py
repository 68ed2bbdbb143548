"""A file's named numeric columns before they are mapped onto the plant interface's names.

Both readers (CSV text, MATLAB .mat) produce a :class:`Table`; the mapping, units,
plausibility checks and resampling (:mod:`pendc.sim.readers`) work on it without
knowing which format it came from.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, eq=False)
class Table:
    """Named 1-D float64 columns of one length, metadata, and where they came from.

    ``times`` maps a column name to its own time vector when the file stored one per
    signal (Simulink "Structure with time" blocks); ``first_line`` is the file line of
    row 0 for text files (0 when rows have no line numbers, as in .mat files).
    """

    columns: dict
    meta: dict
    source: str
    first_line: int = 0
    times: dict = field(default_factory=dict)
    aliases: dict = field(default_factory=dict)  # other name -> column name (.mat labels)
    unreadable: tuple = ()  # variables the reader could not make sense of (MATLAB objects...)
    notes: tuple = ()       # what the reader decided (decimal commas...), one line each
    headerless: bool = False  # a text file without a header row: columns are named 1, 2, ...
    text_columns: dict = field(default_factory=dict)  # skipped text column -> (line, first value)

    def where(self, row: int) -> str:
        """How a message names row ``row`` (0-based): the file line, or the 1-based row."""
        return f"line {self.first_line + row}" if self.first_line else f"row {row + 1}"

    def names(self) -> list:
        """Every name a column can be mapped by, for error messages."""
        return list(self.columns) + [a for a in self.aliases if a not in self.columns]

    def lookup(self, name: str):
        """The column called ``name`` (exact, then alias, then case-insensitive), or None."""
        for candidates in (self.columns, self.aliases):
            if name in candidates:
                return candidates[name] if candidates is self.aliases else name
        folded = [n for n in self.names() if n.lower() == name.lower()]
        if len(folded) == 1:
            return self.aliases.get(folded[0], folded[0])
        return None


def as_float_column(values) -> np.ndarray:
    """A read-only contiguous float64 copy-or-view of ``values``."""
    arr = np.ascontiguousarray(values, dtype=np.float64)
    arr.setflags(write=False)
    return arr
