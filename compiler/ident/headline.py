"""Which fit figure ``compare`` leads with, decided from the data, and why.

A free-run fit says how well a model reproduces a whole run, but only where a free run
is reproducible at all. A swing-up that goes over the top, or a cart that sticks or
slips on a hair's difference, makes the free run depend on the initial state far below
what the encoders resolve: two simulations of the *same* model started one encoder
count apart end up as different as the model and the data. There the free-run figure
measures chaos, not the model, and it can go down when the model gets better (the demo's
fitted spring changes how often the simulated pendulum goes over the top).

The test: simulate the model from the data's initial state and from that state moved by
one sensor step (encoder count or converter code) of each position (its plant file's sensor) up and down; when the two runs
differ, anywhere in the run, by more than ``SENSITIVITY`` of the data's spread (their
fit% against each other falls below ``100 (1 - SENSITIVITY)``), the free run is not
meaningful for these data and the headline is the horizon fit.

A record made under feedback (its metadata name a controller, ``# controller: ...`` as
``pendc hil`` writes) has the horizon fit as its headline whatever the twins say: its input
was computed from its own outputs, and a free run replays that input without the controller.
Both twins then leave the record the same way (an upright pendulum falls), so they agree with
each other and not with the data: on the four hidden-effect records of
tests/test_closed_loop_ident.py the true plants score angle free-run fits of -3 to -43 %,
and fitting the free run biased every estimate (docs/identification.md, "Closed-loop recordings").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..sim.signals import signals_of

SENSITIVITY = 0.10   # a twin run one count apart may differ by this fraction of the data's spread (rms)
FREE_RUN, HORIZON = "free_run", "horizon"


@dataclass(frozen=True)
class Headline:
    """The metric ``compare`` leads with: ``metric`` is ``"free_run"`` or ``"horizon"``,
    ``label`` its name in words, ``reason`` one sentence why it was chosen, and
    ``twin_fit`` the free-run fit% (per output) of the model against itself started one
    encoder count away: 100 means the free run is perfectly reproducible."""

    metric: str
    label: str
    reason: str
    twin_fit: dict

    def to_json(self) -> dict:
        """Plain JSON types (NaN as None)."""
        return {"metric": self.metric, "label": self.label, "reason": self.reason,
                "twin_fit": {k: (float(v) if np.isfinite(v) else None) for k, v in self.twin_fit.items()},
                "twin_fit_threshold": 100.0 * (1.0 - SENSITIVITY)}


def horizon_label(horizon: float) -> str:
    """The horizon fit's name, e.g. ``0.5 s horizon fit``."""
    return f"{horizon:g} s horizon fit"


def count_step(signals) -> np.ndarray:
    """One sensor step (encoder count or converter code) on every position a sensor reads, zero elsewhere, as a state vector."""
    sig = signals_of(signals)
    step = np.zeros(len(sig.mechanical))
    for p in sig.positions:
        step[sig.index(p)] = sig.resolution(p) or 0.0
    return step


def twin_fit(simulate, x0, measured: dict, signals=None) -> dict:
    """fit% of the model's free run started one encoder count away (up and down, both
    positions at once) against the run from ``x0``, per output; the worse direction counts.

    ``simulate(x0)`` returns ``{output: array}``; ``measured`` holds the data of each
    output, whose spread normalises the difference as fit% does. NaN for a constant output.
    ``signals``: the plant's (default: the default model's), whose encoders give the count.
    """
    base = simulate(np.asarray(x0, dtype=np.float64))
    out = {k: 100.0 for k in measured}
    step = count_step(signals)
    for sign in (1.0, -1.0):
        moved = np.asarray(x0, dtype=np.float64) + sign * step
        twin = simulate(moved)
        for k, y in measured.items():
            spread = float(np.linalg.norm(y - np.mean(y)))
            if spread == 0.0:
                out[k] = float("nan")
                continue
            out[k] = min(out[k], 100.0 * (1.0 - float(np.linalg.norm(base[k] - twin[k])) / spread))
    return out


def one_step_words(signals=None) -> str:
    """What one step of the plant's sensors is called: "one encoder count", "one converter
    code" or, with both kinds, "one sensor step"."""
    from ..model.sensors import ADC

    sig = signals_of(signals)
    kinds = {s.kind for s in (sig.interface.sensor_of(p) for p in sig.positions) if s is not None}
    if kinds == {ADC}:
        return "one converter code"
    return "one sensor step" if ADC in kinds else "one encoder count"


def choose(twin: dict, horizon: float, controller: str | None = None, signals=None) -> Headline:
    """The headline for one model on one run, from its ``twin`` fit (see :func:`twin_fit`);
    ``controller``: the controller the run's metadata name, if it was recorded under feedback;
    ``signals``: the plant's, whose sensors name the step."""
    threshold = 100.0 * (1.0 - SENSITIVITY)
    step = one_step_words(signals)
    if controller:
        reason = (f"a free run is not meaningful on these data: they were recorded under feedback (controller: "
                  f"{controller}), and a free run replays their input without the controller")
        return Headline(HORIZON, horizon_label(horizon), reason, dict(twin))
    defined = {k: v for k, v in twin.items() if np.isfinite(v)}
    bad = {k: v for k, v in defined.items() if v < threshold}
    if bad:
        k = min(bad, key=bad.get)
        reason = (f"a free run is not meaningful on these data: the same model started {step} away "
                  f"scores only {bad[k]:.1f} % free-run fit of {k} against itself (below {threshold:g} %), so the "
                  f"free-run figure measures what {step} at the start grows to (a sensitive plant, or data that "
                  f"move only a few steps), not the model")
        return Headline(HORIZON, horizon_label(horizon), reason, dict(twin))
    worst = min(defined.values()) if defined else float("nan")
    reason = (f"a free run is meaningful on these data: the same model started {step} away still "
              f"scores {worst:.1f} % free-run fit against itself" if defined else
              "no output varies in these data")
    return Headline(FREE_RUN, "free-run fit", reason, dict(twin))


def common(headlines: list, horizon: float) -> Headline:
    """One headline for several models on the same run: the horizon fit as soon as the free
    run of any of them is not meaningful (figures compared must be the same metric)."""
    for h in headlines:
        if h.metric == HORIZON:
            return h
    return headlines[0]
