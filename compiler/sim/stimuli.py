"""Input signals used for training, testing and benchmarks (all in volts, ZOH samples).

Each function returns ``(t, u)`` sampled at ``fs`` Hz; the signal centres on
``center`` (the drive's zero-force voltage) and is clipped to the drive's 0-10 V.
Random signals take an explicit ``seed`` so every run is reproducible.
"""

from __future__ import annotations

import numpy as np

V_CENTER = 5.2646   # V_off of the thesis' final model, rounded as the issues quote it


def _time(duration: float, fs: float) -> np.ndarray:
    return np.arange(int(round(duration * fs)) + 1) / fs


def _clip(u: np.ndarray) -> np.ndarray:
    return np.clip(u, 0.0, 10.0)


def chirp(duration=20.0, f0=0.3, f1=2.0, amplitude=1.0, center=V_CENTER, fs=1000.0):
    """Linear-frequency sine sweep from f0 to f1 Hz over ``duration`` s."""
    t = _time(duration, fs)
    phase = 2 * np.pi * (f0 * t + (f1 - f0) / (2 * duration) * t**2)
    return t, _clip(center + amplitude * np.sin(phase))


def steps(duration=5.0, levels=(0.8, -0.8, 1.4, -1.4, 0.0), center=V_CENTER, fs=1000.0):
    """Piecewise-constant offsets from ``center``, equal time on each level."""
    t = _time(duration, fs)
    idx = np.minimum((t / duration * len(levels)).astype(int), len(levels) - 1)
    return t, _clip(center + np.asarray(levels)[idx])


def multisine(duration=10.0, freqs=(0.2, 0.45, 0.9, 1.7, 3.1, 5.3), amplitude=1.2, center=V_CENTER,
              fs=1000.0, seed=1):
    """Sum of sines with random (seeded) phases, scaled to peak ``amplitude``."""
    rng = np.random.default_rng(seed)
    t = _time(duration, fs)
    s = sum(np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in freqs)
    return t, _clip(center + amplitude * s / np.max(np.abs(s)))


def swing_up(duration=5.0, f_pend=0.9, amplitude=2.5, center=V_CENTER, fs=1000.0):
    """Open-loop swing-up-like drive: a square wave at the pendulum's natural
    frequency whose amplitude ramps up, pumping energy into the swing while the
    cart reverses every half period (so it stays near the middle of the track)."""
    t = _time(duration, fs)
    ramp = np.minimum(1.0, 0.3 + t / duration)
    return t, _clip(center + amplitude * ramp * np.sign(np.sin(2 * np.pi * f_pend * t)))


def random_levels(duration=5.0, hold=0.05, amplitude=4.5, center=V_CENTER, fs=1000.0, seed=2):
    """Full-scale random steps: a new uniformly drawn level every ``hold`` s."""
    rng = np.random.default_rng(seed)
    t = _time(duration, fs)
    levels = rng.uniform(-amplitude, amplitude, int(np.ceil(duration / hold)) + 1)
    return t, _clip(center + levels[(t / hold).astype(int)])


def named_stimuli() -> dict:
    """The standard set used to train ranges and to test: name -> (t, u)."""
    return {
        "chirp_low": chirp(),
        "chirp_high": chirp(duration=10.0, f0=2.0, f1=12.0, amplitude=1.5),
        "steps": steps(),
        "swing_up": swing_up(),
        "random": random_levels(),
    }
