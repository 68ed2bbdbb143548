"""Several models compared on the same measured runs: ``pendc compare DATA --model A --model B``.

Each model is compared with each run exactly as :func:`pendc.ident.compare.compare`
does; what is added is one headline per run shared by all models (the same metric for
every model, or the comparison would mean nothing), and the change of every figure from
the first model to each other one, so "watch the error fall" is one command.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

from ..errors import PendcError
from . import headline as hl
from .compare import Comparison, _clean, compare, model_name
from .horizon import DEFAULT_HORIZON
from .prediction_band import BAND_SAMPLES, prediction_band
from .units import small_scale, unit_of


@dataclass(frozen=True)
class SideBySide:
    """``runs[i][j]`` is model ``j`` compared with data file ``i``; ``labels[j]`` names model j
    (``A: file stem``, ``B: ...``)."""

    labels: tuple
    runs: tuple

    def headline(self, i: int) -> tuple[hl.Headline, int]:
        """The headline of run ``i`` shared by every model, and the index of the model that
        decided it: the horizon fit as soon as one model's free run is not meaningful."""
        heads = [c.headline for c in self.runs[i]]
        for j, h in enumerate(heads):
            if h.metric == hl.HORIZON:
                return h, j
        worst = min(range(len(heads)), key=lambda j: min(heads[j].twin_fit.values(), default=100.0))
        return heads[worst], worst

    def headline_fits(self, i: int) -> list:
        """Per model, the fit% per output of run ``i``'s shared headline metric."""
        h, _ = self.headline(i)
        return [c.fit_horizon if h.metric == hl.HORIZON else c.fit for c in self.runs[i]]

    def rows(self, i: int) -> list:
        """The table of run ``i``: ``(figure, unit, [value per model])``, headline metric first."""
        h, _ = self.headline(i)
        cs = self.runs[i]
        outputs = cs[0].outputs
        free = [(f"free-run fit {k}", "%", [c.fit[k] for c in cs]) for k in outputs]
        horizon = [(f"{hl.horizon_label(cs[0].horizon)} {k}", "%", [c.fit_horizon[k] for c in cs]) for k in outputs]
        out = horizon + free if h.metric == hl.HORIZON else free + horizon
        a = cs[0].angle
        if a in outputs:
            out.append((f"free-run fit {a}, angle wrapped", "%", [c.fit_wrapped for c in cs]))
            out.append((f"free-run {a}, whole turns apart (max)", "turns", [float(c.turns) for c in cs]))
        for k in outputs:
            out.append(_rms_row(f"free-run rms error {k}", unit_of(cs[0].model, k),
                                [c.rms_free_run()[k] for c in cs]))
        if a in outputs:
            out.append(_rms_row(f"free-run rms error {a}, wrapped", unit_of(cs[0].model, a),
                                [c.rms_free_run()[f"{a}_wrapped"] for c in cs]))
        return out

    def notes(self) -> list:
        """What was left out of each run's comparison and why (one line each, once per run)."""
        return [n for run in self.runs for n in run[0].notes]

    def to_json(self) -> dict:
        """Plain JSON: per run, the shared headline, every model's comparison and the changes."""
        runs = []
        for i, cs in enumerate(self.runs):
            h, j = self.headline(i)
            fits = self.headline_fits(i)
            runs.append({
                "data": cs[0].data_source,
                "headline": {**h.to_json(), "decided_by": self.labels[j],
                             "fit": {lab: f for lab, f in zip(self.labels, fits)},
                             "change": {lab: {k: f[k] - fits[0][k] for k in f} for lab, f in
                                        zip(self.labels[1:], fits[1:])}},
                "table": [{"figure": name, "unit": unit, "values": dict(zip(self.labels, values)),
                           "change": {lab: v - values[0] for lab, v in zip(self.labels[1:], values[1:])}}
                          for name, unit, values in self.rows(i)],
                "models": [c.to_json() for c in cs]})
        return _clean({"models": list(self.labels), "runs": runs})


def _rms_row(figure: str, unit: str, values: list) -> tuple:
    """A table row of rms errors, every model in one unit: the small one (mm, mV) unless the
    largest is one of ``unit`` or more."""
    finite = [abs(v) for v in values if v is not None and math.isfinite(v)]
    scale, shown = small_scale(unit, max(finite, default=None))
    return figure, shown, [scale * v for v in values]


def labels_for(models) -> tuple:
    """``A: stem``, ``B: stem``...: short, distinct names for the table's columns. Two models
    from the same file (one changed in memory) are told apart by the effects they differ in."""
    out, seen = [], []
    for j, m in enumerate(models):
        letter = chr(ord("A") + j) if j < 26 else f"M{j + 1}"
        name = Path(model_name(m)).stem if m is not None and m.source else model_name(m)
        if name in seen and m is not None:
            first = models[seen.index(name)]
            diff = [f"+{e}" for e in m.effects if e not in first.effects] + \
                [f"-{e}" for e in first.effects if e not in m.effects]
            name = f"{name} {' '.join(diff)}" if diff else f"{name} #{j + 1}"
        seen.append(Path(model_name(m)).stem if m is not None and m.source else model_name(m))
        out.append(f"{letter}: {name}")
    return tuple(out)


def compare_models(models, datasets, dt: float = 1e-4, method: str = "rk4",
                   horizon: float = DEFAULT_HORIZON, labels=None, outputs=None, uncertainties=None,
                   band_samples: int = BAND_SAMPLES, seed: int = 0) -> SideBySide:
    """Compare every model in ``models`` with every run in ``datasets`` (see :class:`SideBySide`);
    ``labels`` name the models (default: :func:`labels_for`), ``outputs`` restricts what is
    compared (see :func:`pendc.ident.compare.compare`). ``uncertainties``: per model, what its
    fit left uncertain (:class:`~pendc.model.fit_uncertainty.FitUncertainty`) or None; each
    model that has one gets a prediction band of ``band_samples`` draws (``seed``) on every run."""
    if labels is not None and len(labels) != len(models):
        raise PendcError(f"{len(labels)} labels for {len(models)} models")
    uncertainties = list(uncertainties or [None] * len(models))

    def one(m, d, unc):
        c = compare(m, d, dt=dt, method=method, horizon=horizon, outputs=outputs)
        if unc is None or band_samples == 0:
            return c
        return replace(c, band=prediction_band(c.model, d, unc, samples=band_samples, seed=seed, dt=dt,
                                               method=method, horizon=horizon, outputs=c.outputs))

    runs = tuple(tuple(one(m, d, unc) for m, unc in zip(models, uncertainties)) for d in datasets)
    return SideBySide(labels=tuple(labels) if labels is not None else labels_for(models), runs=runs)


def change_words(before: float, after: float) -> str:
    """``+5.5 points`` / ``-1.2 points`` / ``n/a``: the change of a fit%."""
    if not (math.isfinite(before) and math.isfinite(after)):
        return "n/a"
    return f"{after - before:+.2f} points"


def as_side_by_side(c: Comparison) -> SideBySide:
    """One comparison as a one-model, one-run :class:`SideBySide`."""
    return SideBySide(labels=labels_for([c.model]), runs=((c,),))
