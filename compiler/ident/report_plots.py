"""The plots of the HTML report (:mod:`pendc.ident.report_html`): matplotlib figures, no HTML.

Figures are drawn with matplotlib's object API (:class:`~matplotlib.figure.Figure` on an
Agg canvas), never through pyplot, so no global figure registry or backend choice leaks
into the caller's process; matplotlib is imported only when a figure is drawn. Each
function returns a Figure; the page turns it into an inline PNG.
"""

from __future__ import annotations

import numpy as np

from . import headline as hl
from ..sim.signals import signals_of
from .compare import Comparison, worst_windows, wrap_angle, wrap_difference
from .units import axis_label, small_scale, trajectory_scale, unit_of
from .whiteness import biased
from .report_text import short
from .sidebyside import SideBySide

MAX_SCATTER = 4000       # points per scatter panel: enough to see a trend, keeps the PNG small
ZOOM = 2.5              # s of the zoomed horizon figure: about two pendulum periods
MEASURED, RESID, BAND = "#1f4e9a", "#444444", "#2a9d8f"
MODEL_COLOURS = ("#d1495b", "#2a9d8f", "#8d6cab", "#e9a23b", "#6b8e23")


def scale(c: Comparison, output: str) -> tuple:
    """``(factor, axis label)`` of a plotted trajectory: ``<output> (mm)`` for a position in
    metres, ``<output> (rad)`` for an angle."""
    factor, unit = trajectory_scale(unit_of(c.model, output))
    return factor, axis_label(output, unit)


def residual_scale(c: Comparison, output: str) -> tuple:
    """``(factor, axis label)`` of a plotted residual: ``<output> residual (mm)`` for metres,
    ``<output> residual (mrad)`` for radians."""
    factor, unit = small_scale(unit_of(c.model, output))
    return factor, axis_label(f"{output} residual", unit)


def _periodic(c: Comparison, output: str) -> bool:
    return c.model is not None and signals_of(c.model).period(output) is not None


def new_figure(width: float, height: float, rows: int = 1, cols: int = 1):
    """A new Figure on its own Agg canvas, laid out for a ``rows`` x ``cols`` grid with fixed
    margins in inches (room for titles, tick labels and axis labels). Fixed margins rather
    than matplotlib's constrained layout: that costs 40 % of the rendering time here.
    Imported here, not at module level, so the text report never loads matplotlib."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height))
    FigureCanvasAgg(fig)
    left, right, top, bottom, vgap, hgap = 0.85, 0.2, 0.35, 0.55, 0.75, 0.75   # inches
    axes_h = max(0.1, (height - top - bottom - (rows - 1) * vgap) / rows)
    axes_w = max(0.1, (width - left - right - (cols - 1) * hgap) / cols)
    fig.subplots_adjust(left=left / width, right=1 - right / width, top=1 - top / height, bottom=bottom / height,
                        hspace=vgap / axes_h, wspace=hgap / axes_w)
    return fig


def _colour(j: int) -> str:
    return MODEL_COLOURS[j % len(MODEL_COLOURS)]


def _fits(values: list, labels: tuple) -> str:
    return ", ".join(f"{short(lab)} {v:.2f} %" if np.isfinite(v) else f"{short(lab)} undefined"
                     for lab, v in zip(labels, values)) if len(labels) > 1 else \
        (f"{values[0]:.2f} %" if np.isfinite(values[0]) else "undefined")


def _shade(ax, c: Comparison, output: str) -> None:
    """Shade the worst windows of ``c``'s analysed residual of ``output``."""
    for w in c.windows:
        if w["output"] == output:
            ax.axvspan(w["t0"], w["t1"], color="#f4a261", alpha=0.25, lw=0)


def _band(ax, c: Comparison, output: str, factor: float, colour: str, horizon: bool = False,
          around=None, wrapped: bool = False) -> None:
    """Shade ``c``'s 95 % prediction band of ``output`` (free run, or ``horizon``), minus
    ``around`` when given (the band as a residual's bounds: the residual lies inside where the
    measurement does); ``wrapped``: for an angle residual wrapped to (-pi, pi], the band's
    bounds are clipped to it (a band wider than a turn holds every wrapped residual)."""
    if c.band is None or output not in c.band.free:
        return
    low, high = (c.band.horizon if horizon else c.band.free)[output]
    base = 0.0 if around is None else around
    low, high = low - base, high - base
    if wrapped:
        low, high = np.clip(low, -np.pi, np.pi), np.clip(high, -np.pi, np.pi)
    ax.fill_between(c.simulated.t, factor * low, factor * high, color=colour, alpha=0.22, lw=0,
                    label=f"95 % prediction band ({c.band.samples} draws)")


def figure_free(s: SideBySide, run):
    """Per output: measured and every model's free run; then the residuals (angles wrapped)."""
    c0 = run[0]
    n = len(c0.outputs)
    fig = new_figure(12, 3.2 * n + 2.4 * n, rows=2 * n)
    t = c0.simulated.t
    for i, k in enumerate(c0.outputs):
        ax = fig.add_subplot(2 * n, 1, i + 1)
        sc, label = scale(c0, k)
        if c0.residual_of == "free run":
            _shade(ax, c0, k)
        ax.plot(t, sc * c0.measured[k], color=MEASURED, lw=1.0, label="measured")
        for j, (lab, c) in enumerate(zip(s.labels, run)):
            _band(ax, c, k, sc, _colour(j))
            ax.plot(t, sc * c.simulated.states[k], color=_colour(j), lw=1.0, ls="--", label=f"free run {lab}")
        ax.set_title(f"{k}: free-run fit {_fits([c.fit[k] for c in run], s.labels)}", fontsize=10)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    for i, k in enumerate(c0.outputs):
        ax = fig.add_subplot(2 * n, 1, n + i + 1)
        sc, label = residual_scale(c0, k)
        wrapped = _periodic(c0, k)
        for j, (lab, c) in enumerate(zip(s.labels, run)):
            r = wrap_difference(c.free_residual[k]) if wrapped else c.free_residual[k]
            _band(ax, c, k, sc, _colour(j), around=c.simulated.states[k], wrapped=wrapped)
            ax.plot(t, sc * r, color=_colour(j), lw=0.8, label=lab)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(label + (" wrapped" if wrapped else ""))
        if k == c0.angle:
            ax.set_title(f"{k} free-run residual, wrapped: fit "
                         + _fits([c.fit_wrapped for c in run], s.labels), fontsize=10)
        ax.grid(alpha=0.3)
        if len(run) > 1 or any(c.band is not None for c in run):
            ax.legend(loc="upper right", fontsize=8)
    ax.set_xlabel("t (s)")
    return fig


def zoom_span(c: Comparison) -> tuple[float, float]:
    """The ``ZOOM`` s stretch where ``c``'s horizon residual (first output, scaled by its spread) is largest."""
    t = c.simulated.t
    r = sum(np.nan_to_num(c.measured[k] - c.horizon_run.outputs[k]) / max(float(np.std(c.measured[k])), 1e-12)
            for k in c.outputs)
    w = worst_windows(t, r, "all", width=min(ZOOM, float(t[-1] - t[0])), count=1)[0]
    return w["t0"], w["t1"]


def figure_horizon(s: SideBySide, run, zoom: bool = False):
    """Per output: the data and every model's horizon segments; below, the horizon residuals
    (``zoom``: only the stretch of :func:`zoom_span`)."""
    c0 = run[0]
    n = len(c0.outputs)
    fig = new_figure(12, (4.4 if zoom else 5.6) * n, rows=2 * n)
    t = c0.simulated.t
    span = zoom_span(c0) if zoom else None
    for i, k in enumerate(c0.outputs):
        ax = fig.add_subplot(2 * n, 1, 2 * i + 1)
        sc, label = scale(c0, k)
        if c0.residual_of != "free run" and not zoom:
            _shade(ax, c0, k)
        ax.plot(t, sc * c0.measured[k], color=MEASURED, lw=1.6, alpha=0.6, label="measured")
        for j, (lab, c) in enumerate(zip(s.labels, run)):
            _band(ax, c, k, sc, _colour(j), horizon=True)
            tt, yy = c.horizon_run.plot_lines(k)
            ax.plot(tt, sc * yy, color=_colour(j), lw=1.0, ls="--", label=f"{c.horizon:g} s segments {lab}")
        ax.set_title(f"{k}: {hl.horizon_label(c0.horizon)} {_fits([c.fit_horizon[k] for c in run], s.labels)}",
                     fontsize=10)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
        ax = fig.add_subplot(2 * n, 1, 2 * i + 2)
        sr, rlabel = residual_scale(c0, k)
        for j, (lab, c) in enumerate(zip(s.labels, run)):
            _band(ax, c, k, sr, _colour(j), horizon=True, around=c.horizon_run.outputs[k])
            ax.plot(t, sr * (c0.measured[k] - c.horizon_run.outputs[k]), color=_colour(j), lw=0.8, label=lab)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(rlabel)
        ax.grid(alpha=0.3)
        if len(run) > 1 or any(c.band is not None for c in run):
            ax.legend(loc="upper right", fontsize=8)
    if span is not None:
        for ax in fig.axes:
            _zoom(ax, *span)
    ax.set_xlabel("t (s)")
    return fig


def _zoom(ax, t0: float, t1: float) -> None:
    """Limit ``ax`` to [t0, t1] and its y range to what its lines show there (autoscale
    would keep the whole run's range)."""
    ax.set_xlim(t0, t1)
    ys = []
    for line in ax.get_lines():
        x, y = (np.asarray(a, dtype=np.float64) for a in line.get_data())
        if x.shape == y.shape and x.size > 2:
            ys.append(y[(x >= t0) & (x <= t1) & np.isfinite(y)])
    ys = np.concatenate(ys) if ys else np.array([])
    if ys.size:
        lo, hi = float(ys.min()), float(ys.max())
        pad = 0.05 * (hi - lo) if hi > lo else max(abs(hi), 1.0) * 0.05
        ax.set_ylim(lo - pad, hi + pad)


def scatter_axes(c: Comparison) -> list:
    """``(label, values)`` the residual is plotted against: the measured rates, the periodic
    positions wrapped to one turn, the input about its centre, the translations; those that
    vary in the run."""
    sig = signals_of(c.model)
    spec = sig.interface.input
    against = [(axis_label(r, sig.unit(r)), c.measured[r]) for r in sig.rates if r in c.measured]
    against += [(axis_label(f"{p} wrapped to ±π", sig.unit(p)), wrap_angle(c.measured[p], sig.period(p)))
                for p in sig.periodic if p in c.measured]
    centre = f"{spec.name} - {c.centre_name}" if c.v_off else spec.name
    against.append((axis_label(centre, spec.unit), c.simulated.u - c.v_off))
    against += [(axis_label(p, sig.unit(p)), c.measured[p]) for p in sig.positions if sig.period(p) is None
                and p in c.measured]
    return [(name, v) for name, v in against if np.ptp(v) > 0]   # a held or absent signal shows nothing


def figure_scatter(c: Comparison):
    """Rows: each output's residual; columns: against the signals of :func:`scatter_axes`."""
    n = len(c.simulated.t)
    pick = np.linspace(0, n - 1, min(n, MAX_SCATTER)).astype(int)   # even subsample keeps the time spread
    against = scatter_axes(c)
    rows, cols = len(c.outputs), max(1, len(against))
    fig = new_figure(14 if cols > 2 else 3.5 * cols + 1, 3 * rows, rows=rows, cols=cols)
    for i, k in enumerate(c.outputs):
        sc, label = residual_scale(c, k)
        for j, (name, v) in enumerate(against):
            ax = fig.add_subplot(rows, cols, cols * i + j + 1)
            ax.scatter(np.asarray(v)[pick], sc * c.residual[k][pick], s=2, alpha=0.3, color=RESID, lw=0)
            ax.axhline(0.0, color="k", lw=0.5)
            ax.grid(alpha=0.3)
            if i == rows - 1:
                ax.set_xlabel(name)
            if j == 0:
                ax.set_ylabel(label)
    return fig


def figure_correlations(c: Comparison):
    """Per output: the residual autocorrelation and its cross-correlation with the input, with bands."""
    rows = len(c.outputs)
    fig = new_figure(12, 3 * rows, rows=rows, cols=2)
    for i, k in enumerate(c.outputs):
        for j, (key, what) in enumerate((("acf", "autocorrelation"), ("ccf", "cross-corr. with u"))):
            d = c.whiteness[k] if key == "acf" else c.whiteness["xcorr"][k]
            ax = fig.add_subplot(rows, 2, 2 * i + j + 1)
            if not d.get("tested", True):     # no input to correlate with: say so instead of a verdict
                ax.text(0.5, 0.5, f"{k} residual {what}: not tested\n({d['input']} input)", ha="center",
                        va="center", transform=ax.transAxes, fontsize=10)
                ax.set_axis_off()
                continue
            lag_ms = np.asarray(d["lags"]) * d["lag_seconds"] * 1e3
            ax.vlines(lag_ms, 0.0, d[key], color=RESID, lw=1.5)
            ax.plot(lag_ms, d[key], "o", color=RESID, ms=3)
            ax.axhspan(-d["band"], d["band"], color=BAND, alpha=0.2, lw=0)
            ax.axhline(0.0, color="k", lw=0.5)
            verdict = ("white" if d["white"] else "not white") if key == "acf" else \
                ("independent" if d["independent"] else "correlated")
            if key == "acf" and biased(d, signals_of(c.model).resolution(k)):
                verdict = f"biased by {d['mean']:+.3g}, {verdict} about it"
            ax.set_title(f"{k} residual {what}: {verdict} (99 % band ±{d['band']:.3f})", fontsize=10)
            ax.set_xlabel("lag (ms)" + ("; > 0: input earlier" if key == "ccf" else ""))
            ax.grid(alpha=0.3)
    return fig
