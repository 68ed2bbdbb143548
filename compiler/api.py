"""The identification commands as Python functions, for notebooks and scripts.

``pendc.compare``, ``pendc.diagnose`` and ``pendc.fit`` do what ``pendc compare``,
``pendc diagnose`` and ``pendc fit`` do, without the terminal: they take a model as a
file path or a :class:`~pendc.model.plant.PlantModel`, data as file paths or
:class:`~pendc.sim.measurements.Measurement` objects (one or a list), and return the
result objects the commands print. A notebook session::

    import pendc
    rig = "my_rig.toml"                                          # a plant file and its values
    report = pendc.compare(rig, "run1.csv")
    print(report)                                                # the text report, headline first
    d = pendc.diagnose(rig, "run1.csv")
    d.candidates[0].effect                                       # the catalogue effect that explains most
    new = pendc.fit(rig, "run1.csv", add=[d.candidates[0].effect], output="refit.toml")
    pendc.compare([rig, "refit.toml"], "run2.csv").write_html("compare.html")

(docs/identification.md runs this on the shipped plants' data.) Files are read with
:class:`~pendc.sim.readers.ReadOptions` given as keyword arguments (``columns={"angle":
"Theta1"}`` renames a column to the plant's state, ``<state>_unit="deg"``, ``experiment=``
one of the plant file's ``[experiments]``...),
exactly as the command line's reading options, resampled onto a uniform grid as the
commands do. The heavy modules (scipy, the identification package) are imported on the
first call, so ``import pendc`` stays light.
"""

from __future__ import annotations

import os
from dataclasses import dataclass



def _model(model):
    """A PlantModel from a PlantModel or a path (None: the default model)."""
    from .model.modelfile import load_model
    from .model.plant import PlantModel

    if isinstance(model, PlantModel):
        return model
    if model is None or isinstance(model, (str, os.PathLike)):
        return load_model(model)
    from .errors import PendcError
    raise PendcError(f"a model is a PlantModel or a model file path, not {type(model).__name__}")


def _as_list(x) -> list:
    return list(x) if isinstance(x, (list, tuple)) else [x]


def _datasets(data, reading: dict, model=None) -> list:
    """Measurements from Measurements or paths; paths are read with ``ReadOptions(**reading)``,
    for the signals of ``model`` unless ``reading`` names a ``plant``."""
    from .errors import PendcError
    from .sim.measurements import Measurement, read_measurements
    from .sim.readers import ReadOptions

    items = _as_list(data)
    if not items:
        raise PendcError("no data given")
    # the same rig-limit checks as the commands (millimetres, millivolts, outliers are refused)
    options = ReadOptions(**{"uniform": True, "plausible": True, "plant": model, **reading})
    out = []
    for d in items:
        if isinstance(d, Measurement):
            out.append(d)
        elif isinstance(d, (str, os.PathLike)):
            out.append(read_measurements(d, options=options))
        else:
            raise PendcError(f"data are Measurements or file paths, not {type(d).__name__}")
    return out


@dataclass(frozen=True)
class CompareReport:
    """What :func:`compare` returns: ``result`` is the
    :class:`~pendc.ident.sidebyside.SideBySide` (``result.runs[i][j]``: model j on data i,
    each a :class:`~pendc.ident.compare.Comparison`). ``str(report)`` is the text report,
    ``report.write_html(path)`` the HTML page, ``report.to_json()`` the ``--json`` output."""

    result: object

    @property
    def comparison(self):
        """The first model on the first data set (the only one for a single comparison)."""
        return self.result.runs[0][0]

    @property
    def headline(self) -> str:
        """The report's first line: which fit leads, its values and, for several models, the trend."""
        return self.text().splitlines()[0]

    @property
    def notes(self) -> list:
        """What was left out of the comparison and why (held or missing outputs)."""
        return self.result.notes()

    def text(self) -> str:
        """The plain-text report, as ``pendc compare`` prints it."""
        from .ident.report_text import text_report

        return text_report(self.result)

    def to_json(self) -> dict:
        """Plain JSON types, as ``pendc compare --json`` prints them."""
        single = len(self.result.runs) == 1 and len(self.result.labels) == 1
        return self.comparison.to_json() if single else self.result.to_json()

    def write_html(self, path, title: str | None = None) -> None:
        """Write the self-contained HTML report to ``path`` (atomically)."""
        import numpy as np

        from .ident.report_html import write_html_report

        with np.errstate(all="ignore"):
            write_html_report(self.result, path, title=title)

    def __str__(self) -> str:
        return self.text()


def compare(model, data, *, horizon: float | None = None, outputs=None, dt: float = 1e-4, method: str = "rk4",
            labels=None, band: int = 20, seed: int = 0, **reading) -> CompareReport:
    """How well does ``model`` reproduce ``data``, where and why not (``pendc compare``).

    ``model``: a model file path or PlantModel (None: the default model), or a
    list of them to put side by side (a table of every figure per model with the change
    from the first; ``labels`` names them). ``data``: a file path or Measurement, or a
    list of them (a report per file). ``horizon``: seconds between restarts of the
    horizon fit (None: 0.5 s, longer where the data move too little in it: :func:`_horizon`). ``outputs``: a tuple of state names to compare only those (default: every output
    the data move; ``report.notes`` says what was left out). ``**reading``: :class:`~pendc.sim.readers.ReadOptions` fields for paths.
    The headline (``report.headline``) is the free-run fit where a free run is meaningful
    on the data, else the horizon fit, and says why. A model given by the file a fit wrote gets
    the 95 % prediction band of ``band`` parameter draws (``seed``) from its ``[fit.covariance]``
    (0: none; see :mod:`pendc.ident.prediction_band`).
    """
    import numpy as np

    from .ident.sidebyside import compare_models
    from .model.modelfile import load_fit_uncertainty

    given = _as_list(model)
    models = [_model(m) for m in given]
    uncertainties = [load_fit_uncertainty(m) if isinstance(m, (str, os.PathLike)) and band else None for m in given]
    datasets = _datasets(data, reading, models[0] if models else None)
    with np.errstate(all="ignore"):   # undefined figures are NaN by design, never a warning
        horizon = _horizon(horizon, datasets, models[0] if models else _model(None))
        return CompareReport(compare_models(models, datasets, dt=dt, method=method, horizon=horizon, labels=labels,
                                            outputs=None if outputs is None else tuple(_as_list(outputs)),
                                            uncertainties=uncertainties, band_samples=band, seed=seed))


def _horizon(given, datasets: list, model) -> float:
    """``given``, or the data's horizon (:func:`pendc.ident.horizon.chosen_horizon`)."""
    from .ident.horizon import chosen_horizon

    return chosen_horizon(given, datasets, model)[0]


def _names(value) -> list:
    """``"a,b"`` or ``["a", "b"]`` (or None) as a list of stripped names."""
    if value is None:
        return []
    items = value.split(",") if isinstance(value, str) else list(value)
    return [str(v).strip() for v in items if str(v).strip()]


def diagnose(model, data, *, outputs=None, workers: int = 1, dt: float = 1e-4, segment: float | None = None,
             effects=None, **reading):
    """Which catalogue effect is missing from ``model``, judged on ``data`` (``pendc diagnose``).

    ``model``: a model file path or PlantModel (None: the default model); ``data``: a
    path or Measurement, or a list of them (each simulated under its own experiment).
    ``segment``: the horizon in seconds (None: as :func:`compare`'s).
    ``outputs``: a tuple of state names to judge on those only; ``workers`` > 1 tests candidates in
    parallel processes; ``effects`` (``"a,b"`` or a list) tests only those catalogue effects.
    Returns a :class:`~pendc.ident.diagnose.Diagnosis`: ``candidates`` best first (``effect``,
    ``params``, ``score``, ``evidence``), ``unexplained``, ``at_noise_level``, ``correlations``,
    ``notes`` and ``tie`` (the best candidates the data cannot separate, or None).
    """
    import numpy as np

    from .ident.diagnose import diagnose as run

    m = _model(model)
    datasets = _datasets(data, reading, m)
    with np.errstate(all="ignore"):
        return run(m, datasets, dt=dt, segment=_horizon(segment, datasets, m), workers=workers,
                   outputs=None if outputs is None else tuple(_as_list(outputs)),
                   effects=None if effects is None else _names(effects))


@dataclass(frozen=True)
class FitReport:
    """What :func:`fit` returns: ``result`` is the :class:`~pendc.ident.fit.FitResult`
    (``values``, ``ci95``, ``unidentifiable``, the fitted ``model``); ``before``/``after``
    the labelled 0.5 s horizon figures and ``free_run_before``/``free_run_after`` the free-run
    figures (pooled and per file) on the validation data; ``path`` the model file written
    (None when not asked)."""

    result: object
    free: tuple
    before: dict
    after: dict
    free_run_before: dict
    free_run_after: dict
    path: str | None = None

    @property
    def model(self):
        """The fitted PlantModel."""
        return self.result.model

    def __str__(self) -> str:
        lines = []
        for when, figures in (("before", self.before), ("after", self.after),
                              ("before", self.free_run_before), ("after", self.free_run_after)):
            fits = ", ".join(f"{k} {v:.2f} %" for k, v in figures["pooled"].items())
            lines.append(f"{when + ':':7s} {figures['label']}: {fits}")
        for p in self.free:
            lo, hi = self.result.ci95[p]
            flag = "   NOT IDENTIFIED" if p in (self.result.unidentifiable or {}) else ""
            lines.append(f"  {p:10s} = {self.result.values[p]:.6g}   95 % CI [{lo:.6g}, {hi:.6g}]{flag}")
        if self.path:
            lines.append(f"wrote {self.path}")
        return "\n".join(lines) + "\n"


def fit(model, data, *, add=None, free=None, validate=None, output=None, force: bool = False, outputs=None,
        max_evaluations: int = 200, horizon: float | None = None, **reading) -> FitReport:
    """Add effects, fit parameters and (if ``output`` is given) write the new model (``pendc fit``).

    ``model``: a model file path or PlantModel (None: the default model); ``data``: a
    path or Measurement, or a list of them; ``add``: effects to add (their parameters are
    fitted; an effect the model has already is fitted from its current values), ``free``: more parameters (any plant constant or effect parameter), as lists or
    comma-separated strings; ``validate``: data to report the figures on (default: ``data``);
    ``horizon``: seconds between restarts (None: as :func:`compare`'s).
    Raises PendcError when the fit does not converge, and, when ``output`` is given, when
    the data do not identify a fitted parameter (unless ``force``): no file is written then.
    Without ``output`` nothing is written and ``report.result.unidentifiable`` says which
    parameters the data do not determine.
    """
    import numpy as np

    from .errors import PendcError
    from .ident.diagnose import free_parameters
    from .ident.figures import free_run_figures
    from .ident.fit import fit_parameters
    from .ident.shooting import horizon_figures

    m = _model(model)
    datasets = _datasets(data, reading, m)
    checks = _datasets(validate, reading, m) if validate is not None else datasets
    wanted = None if outputs is None else tuple(_as_list(outputs))
    horizon = _horizon(horizon, datasets, m)
    with np.errstate(all="ignore"):
        before = horizon_figures(m, checks, horizon, outputs=wanted)
        free_run_before = free_run_figures(m, checks, outputs=wanted)
        added = _names(add)
        for effect in added:
            if effect not in m.effects:   # as pendc fit: adding what is there means fitting it
                m = m.with_effect(effect)
        names = list(dict.fromkeys([p for e in added for p in free_parameters(e, m)] + _names(free))) or list(m.free)
        if not names:
            raise PendcError("nothing to fit: name effects with add= or parameters with free=")
        result = fit_parameters(m, datasets, names, segment=horizon, max_evaluations=max_evaluations, outputs=wanted)
        if not result.converged:
            raise PendcError(f"the fit did not converge ({result.message}, {result.evaluations} evaluations)"
                             + ("; no model written" if output else ""))
        if output is not None and result.unidentifiable and not force:
            raise PendcError(f"the data do not identify {', '.join(result.unidentifiable)} "
                             f"({result.refused()}); no model written (force=True writes it anyway)")
        after = horizon_figures(result.model, checks, horizon, outputs=wanted)
        free_run_after = free_run_figures(result.model, checks, outputs=wanted)
    if output is not None:
        _write_fitted(model, result, names, data, before, after, output)
    return FitReport(result=result, free=tuple(names), before=before, after=after, free_run_before=free_run_before,
                     free_run_after=free_run_after, path=None if output is None else str(output))


def _write_fitted(source, result, names: list, data, before: dict, after: dict, output) -> None:
    """The fitted model over its source model's text (comments kept), with provenance and intervals."""
    from pathlib import Path

    from .atomic import write_atomic
    from .model.modelfile import data_fingerprint, default_model_path
    from .model.model_writer import dumps_fitted, dumps_model

    # a model given as an object may differ from the file it was read from (an effect removed
    # in memory): only a model given by its file is written over that file's text
    if isinstance(source, (str, os.PathLike)) or source is None:
        path = Path(source) if source is not None else default_model_path()
    else:
        path = None
    fingerprints = [data_fingerprint(d) if isinstance(d, (str, os.PathLike)) else getattr(d, "source", "<data>")
                    for d in _as_list(data)]
    origin = str(path) if path else (getattr(source, "source", "") or "(in memory)") + " (given as a PlantModel)"
    meta = {"generator": "pendc.fit (Python API)", "source_model": origin,
            "data": "; ".join(fingerprints), "fitted": ", ".join(names)}
    for when, figures in (("before", before), ("after", after)):
        for o, v in figures["pooled"].items():
            meta[f"horizon_fit_{o}_{when}"] = round(v, 3)
    intervals = {p: result.ci95[p] for p in names if p not in (result.unidentifiable or {})}
    if path is not None and path.is_file():
        text = dumps_fitted(result.model, path.read_text(encoding="utf-8"), meta, intervals,
                            covariance=result.covariance_of(names))
    else:
        text = dumps_model(result.model, meta)
    write_atomic(output, text)
