"""The identification commands as Python functions, for notebooks and scripts.

``pendc.compare``, ``pendc.diagnose`` and ``pendc.fit`` do what ``pendc compare``,
``pendc diagnose`` and ``pendc fit`` do, without the terminal: they take a model as a
file path or a :class:`~pendc.model.plant.PlantModel`, data as file paths or
:class:`~pendc.sim.measurements.Measurement` objects (one or a list), and return the
result objects the commands print. A notebook session::

    import pendc
    thesis = "models/sct_thesis_final.toml"
    report = pendc.compare(thesis, "data/hidden_spring.csv")
    print(report)                                                # the text report, headline first
    d = pendc.diagnose(thesis, "data/hidden_spring.csv")
    d.candidates[0].effect                                       # 'cart_spring'
    new = pendc.fit(thesis, "data/hidden_spring.csv", add=["cart_spring"], output="with_spring.toml")
    pendc.compare([thesis, "with_spring.toml"], "data/hidden_spring_validation.csv").write_html("compare.html")

Files are read with :class:`~pendc.sim.readers.ReadOptions` given as keyword arguments
(``columns={"theta": "Theta1"}``, ``theta_unit="deg"``, ``experiment="cart_held"``...),
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


def _datasets(data, reading: dict) -> list:
    """Measurements from Measurements or paths; paths are read with ``ReadOptions(**reading)``."""
    from .errors import PendcError
    from .sim.measurements import Measurement, read_measurements
    from .sim.readers import ReadOptions

    items = _as_list(data)
    if not items:
        raise PendcError("no data given")
    options = ReadOptions(**{"uniform": True, **reading})
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


def compare(model, data, *, horizon: float = 0.5, outputs=None, dt: float = 1e-4, method: str = "rk4",
            labels=None, **reading) -> CompareReport:
    """How well does ``model`` reproduce ``data``, where and why not (``pendc compare``).

    ``model``: a model file path or PlantModel (None: the thesis' final model), or a
    list of them to put side by side (a table of every figure per model with the change
    from the first; ``labels`` names them). ``data``: a file path or Measurement, or a
    list of them (a report per file). ``horizon``: seconds between restarts of the
    horizon fit. ``outputs``: ``("theta",)`` to compare theta only (default: every output
    the data move; ``report.notes`` says what was left out). ``**reading``: :class:`~pendc.sim.readers.ReadOptions` fields for paths.
    The headline (``report.headline``) is the free-run fit where a free run is meaningful
    on the data, else the horizon fit, and says why.
    """
    import numpy as np

    from .ident.sidebyside import compare_models

    models = [_model(m) for m in _as_list(model)]
    datasets = _datasets(data, reading)
    with np.errstate(all="ignore"):   # undefined figures are NaN by design, never a warning
        return CompareReport(compare_models(models, datasets, dt=dt, method=method, horizon=horizon, labels=labels,
                                            outputs=None if outputs is None else tuple(_as_list(outputs))))
