"""One measured run as pendc holds it (:class:`Measurement`), apart from how it is read.

The readers (:mod:`pendc.sim.readers`) build it and :mod:`pendc.sim.measurements` reads and
writes files of it; both import it from here, so neither imports the other back.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import PendcError
from .signals import PlantSignals, signals_of

FIT_WINDOW = 0.010  # s, for initial_state's velocity estimate


@dataclass(frozen=True, eq=False)
class Measurement:
    """One measured run; arrays are float64 and read-only (``columns`` holds them all).

    ``experiment`` says what was held or removed (the simulation honours it);
    ``resolution`` maps a column to its measurement step (the encoder count or the
    quantisation, given or estimated; absent when unknown); ``missing`` lists the axes
    the file did not have, which hold a constant; ``notes`` say what the reader did
    (resampling, filling, unwrapping), one line each.
    """

    t: np.ndarray
    u: np.ndarray
    columns: dict
    meta: dict
    source: str = "<string>"
    warnings: tuple = ()
    first_line: int = field(default=0, repr=False)  # file line of row 0, for messages
    experiment: str = "free"    # a name of pendc.model.experiments.EXPERIMENTS
    resolution: dict = field(default_factory=dict)  # column -> quantisation step (given or estimated)
    missing: tuple = ()         # axes absent from the file, filled with a constant
    notes: tuple = ()           # what was done to the data (resampling, filling), one line each
    signals: PlantSignals = None  # the plant whose signals the columns are (None: the default model)

    @property
    def plant(self) -> PlantSignals:
        """The signals of the plant the file was read for."""
        return signals_of(self.signals)

    def column(self, name: str) -> np.ndarray:
        """The column called ``name``; PendcError if it is absent or not finite."""
        if name not in self.columns:
            raise PendcError(f"{self.source}: no column '{name}' (columns: {', '.join(self.columns)})")
        values = self.columns[name]
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            k = int(bad[0])
            where = f"line {self.first_line + k}" if self.first_line else f"row {k}"
            raise PendcError(f"{self.source}: {where}: column '{name}' is {values[k]} ({bad.size} non-finite "
                             f"value(s); NaN and inf are not allowed)")
        return values

    def __getattr__(self, name: str):
        """A plant signal by name (``m.<position>``): its column, or None when the file has none."""
        if name.startswith("_") or name in ("columns", "signals"):
            raise AttributeError(name)
        if name in self.columns:
            return self.columns[name]
        if name in self.plant.all_columns:
            return None
        raise AttributeError(f"'Measurement' has no attribute or signal '{name}'")

    def initial_state(self) -> tuple:
        """The plant's reported state at ``t[0]`` (each position and its rate, in the
        interface's order), for starting a simulation from the data.

        Positions come from the first row; an absent position column counts as 0 (the
        spec's default initial state). Velocities come from their rate columns
        (``d<position>``) when present; otherwise they are the slope of a least-squares line
        through the samples of the first ``FIT_WINDOW`` (10 ms) of the position, and at
        least 3 samples, which averages out the encoder quantisation that a plain
        first difference would amplify. With fewer than 2 samples the velocity is 0.
        """
        t = self.t
        n = max(3, int(np.searchsorted(t, t[0] + FIT_WINDOW, side="right")))
        sig = self.plant
        state = dict.fromkeys(sig.mechanical, 0.0)
        for pos in sig.positions:
            vel = sig.rate(pos)
            p = self.columns.get(pos)
            v = self.columns.get(vel) if vel is not None else None
            state[pos] = float(p[0]) if p is not None else 0.0
            if vel is None:
                continue
            if v is not None:
                state[vel] = float(v[0])
            elif p is not None and len(t) >= 2:
                state[vel] = float(np.polyfit(t[:n] - t[0], p[:n], 1)[0])
        return tuple(state.values())
