"""Input signals used for training, testing and benchmarks (ZOH samples on a plant's input).

The generators (:func:`chirp`, :func:`steps`, ...) write each signal as *levels*: offsets
from the input's neutral value in reference units, where the input's whole range spans
:data:`REFERENCE_SPAN` units. :class:`Stimuli` puts them on one plant's input: a level ``v``
becomes ``neutral + v * (hi - lo) / REFERENCE_SPAN``, clipped to ``lo .. hi``. So the same
chirp excites a 0-10 V drive by ±1 V about its idle voltage and a ±20 N force by ±4 N about
zero; on a 10-unit range the level is the offset itself. Every signal is sampled at ``fs`` Hz;
random signals take an explicit ``seed`` so every run is reproducible.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

REFERENCE_SPAN = 10.0       # the range, in reference units, the levels below are written for


def _time(duration: float, fs: float) -> np.ndarray:
    return np.arange(int(round(duration * fs)) + 1) / fs


def chirp(duration=20.0, f0=0.3, f1=2.0, amplitude=1.0, fs=1000.0):
    """Linear-frequency sine sweep from f0 to f1 Hz over ``duration`` s (levels)."""
    t = _time(duration, fs)
    phase = 2 * np.pi * (f0 * t + (f1 - f0) / (2 * duration) * t**2)
    return t, amplitude * np.sin(phase)


def steps(duration=5.0, levels=(0.8, -0.8, 1.4, -1.4, 0.0), fs=1000.0):
    """Piecewise-constant ``levels``, equal time on each."""
    t = _time(duration, fs)
    idx = np.minimum((t / duration * len(levels)).astype(int), len(levels) - 1)
    return t, np.asarray(levels, float)[idx]


def multisine(duration=10.0, freqs=(0.2, 0.45, 0.9, 1.7, 3.1, 5.3), amplitude=1.2, fs=1000.0, seed=1):
    """Sum of sines with random (seeded) phases, scaled to peak level ``amplitude``."""
    rng = np.random.default_rng(seed)
    t = _time(duration, fs)
    s = sum(np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in freqs)
    return t, amplitude * s / np.max(np.abs(s))


def swing_up(duration=5.0, f_pend=0.9, amplitude=2.5, fs=1000.0):
    """Open-loop swing-up-like drive: a square wave at ``f_pend`` (near a pendulum's natural
    frequency) whose amplitude ramps up, pumping energy into the swing while the driven
    coordinate reverses every half period (so it stays near where it started)."""
    t = _time(duration, fs)
    ramp = np.minimum(1.0, 0.3 + t / duration)
    return t, amplitude * ramp * np.sign(np.sin(2 * np.pi * f_pend * t))


def random_levels(duration=5.0, hold=0.05, amplitude=4.5, fs=1000.0, seed=2):
    """Full-scale random steps: a new uniformly drawn level every ``hold`` s."""
    rng = np.random.default_rng(seed)
    t = _time(duration, fs)
    levels = rng.uniform(-amplitude, amplitude, int(np.ceil(duration / hold)) + 1)
    return t, levels[(t / hold).astype(int)]


def tap(duration=5.0, level=0.01, width=0.02, fs=1000.0):
    """A small tap and then the neutral input: ``level`` for ``width`` s, then 0. The plant moves
    freely by little, where a sweeping or large input would average rounding away (a small
    acceleration rounded to zero is a velocity that never changes)."""
    t = _time(duration, fs)
    return t, np.where(t < width, level, 0.0)


def switching(duration=5.0, hold=(0.01, 0.1), seed=3, fs=1000.0):
    """The input's two ends in turn (levels of a whole span either way, clipped to the range on an
    input): a bang-bang drive, switching after random holds drawn uniformly from ``hold`` s."""
    rng = np.random.default_rng(seed)
    t = _time(duration, fs)
    edges = np.cumsum(rng.uniform(*hold, size=int(np.ceil(duration / hold[0])) + 1))
    first = rng.integers(0, 2)
    return t, np.where((first + np.searchsorted(edges, t, side="right")) % 2, REFERENCE_SPAN, -REFERENCE_SPAN)


@dataclass(frozen=True)
class Stimuli:
    """The standard signals on one input (an :class:`~pendc.model.interface.InputSpec`):
    each method takes its generator's arguments and returns ``(t, u)`` in the input's unit."""

    input: object

    def on_input(self, levels) -> np.ndarray:
        """Levels (reference units about neutral) as values of the input, clipped to its range."""
        inp = self.input
        scale = (inp.hi - inp.lo) / REFERENCE_SPAN
        return np.clip(inp.neutral + np.asarray(levels, float) * scale, inp.lo, inp.hi)

    def _put(self, tu):
        t, levels = tu
        return t, self.on_input(levels)

    def chirp(self, **kw):
        """:func:`chirp` on this input."""
        return self._put(chirp(**kw))

    def steps(self, **kw):
        """:func:`steps` on this input."""
        return self._put(steps(**kw))

    def multisine(self, **kw):
        """:func:`multisine` on this input."""
        return self._put(multisine(**kw))

    def swing_up(self, **kw):
        """:func:`swing_up` on this input."""
        return self._put(swing_up(**kw))

    def random_levels(self, **kw):
        """:func:`random_levels` on this input."""
        return self._put(random_levels(**kw))

    def switching(self, **kw):
        """:func:`switching` on this input."""
        return self._put(switching(**kw))

    def tap(self, **kw):
        """:func:`tap` on this input."""
        return self._put(tap(**kw))

    def named(self, fs: float = 1000.0) -> dict:
        """The standard set used to train ranges and to test: name -> (t, u), sampled at ``fs``
        Hz (a fast plant's test data need more than the default 1 kHz)."""
        return {
            "chirp_low": self.chirp(fs=fs),
            "chirp_high": self.chirp(duration=10.0, f0=2.0, f1=12.0, amplitude=1.5, fs=fs),
            "steps": self.steps(fs=fs),
            "swing_up": self.swing_up(fs=fs),
            "random": self.random_levels(fs=fs),
        }
