"""``pendc compare --html``: one self-contained HTML page for one model or several side by side.

Everything is inline (CSS in a ``<style>`` block, plots as base64 PNG data URIs), so
the file can be mailed or archived alone and opens without a network. Figures are
drawn with matplotlib's object API (:class:`~matplotlib.figure.Figure` on an Agg
canvas), never through pyplot, so no global figure registry or backend choice
leaks into the caller's process; matplotlib is imported only when a figure is
drawn. The page is rendered completely in memory and then written with
:func:`pendc.atomic.write_atomic`: a failure leaves no half-written file.

The page starts with the headline (as the text report does), then per data file: a
table of every labelled figure per model with the change from the first, the free run
and the horizon simulation overlaid on the data for every model, and per model the
worst windows, regimes, residual clouds and whiteness of the residual it examined.
"""

from __future__ import annotations

import base64
import html
import io

import numpy as np

from ..atomic import write_atomic
from . import headline as hl
from .compare import WINDOW, Comparison, model_name, worst_windows, wrap_angle, wrap_difference
from .report_text import concentrated, format_side_by_side, short, side_by_side_headline
from .sidebyside import SideBySide, as_side_by_side

MAX_SCATTER = 4000       # points per scatter panel: enough to see a trend, keeps the PNG small
DPI = 80
ZOOM = 2.5              # s of the zoomed horizon figure: about two pendulum periods
MEASURED, RESID, BAND = "#1f4e9a", "#444444", "#2a9d8f"
MODEL_COLOURS = ("#d1495b", "#2a9d8f", "#8d6cab", "#e9a23b", "#6b8e23")
_SCALE = {"x": (1e3, "x (mm)"), "theta": (1.0, "theta (rad)")}
_RSCALE = {"x": (1e3, "x residual (mm)"), "theta": (1e3, "theta residual (mrad)")}
_UNIT = {"x": "mm", "theta": "mrad"}

_CSS = """
body { font-family: sans-serif; max-width: 1200px; margin: 1em auto; padding: 0 1em; color: #222; }
h1 { font-size: 1.4em; } h2 { font-size: 1.15em; margin-top: 1.6em; border-bottom: 1px solid #ccc; }
h3 { font-size: 1.0em; margin-top: 1.2em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: right; }
th { background: #f0f0f0; } td.l, th.l { text-align: left; }
tr.hot td { background: #fde2e2; } tr.head td { font-weight: bold; background: #eef5ff; }
img { max-width: 100%; } pre { background: #f7f7f7; padding: 0.6em; font-size: 0.8em; overflow-x: auto; }
p.note { color: #555; font-size: 0.9em; }
p.headline { font-size: 1.1em; background: #eef5ff; padding: 0.5em 0.8em; border-left: 4px solid #1f4e9a; }
"""


def write_html_report(c, path, title: str | None = None) -> None:
    """Render the report of ``c`` (a Comparison or a SideBySide) and write it to ``path`` atomically."""
    write_atomic(path, render_html(c, title))


def render_html(c, title: str | None = None) -> str:
    """The report as one HTML string (no external references)."""
    s = c if isinstance(c, SideBySide) else as_side_by_side(c)
    e = html.escape
    first = s.runs[0]
    models = " vs ".join(model_name(x.model) for x in first)
    data = ", ".join(run[0].data_source or "data" for run in s.runs)
    title = title or f"pendc compare: {data} vs {models}"
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             f"<title>{e(title)}</title><style>{_CSS}</style></head><body>", f"<h1>{e(title)}</h1>"]
    for i in range(len(s.runs)):
        head = side_by_side_headline(s, i)
        parts.append(f'<p class="headline">{e(head[0])}<br><small>{e(head[1].strip())}</small></p>')
    for i, run in enumerate(s.runs):
        parts += _run_section(s, i, run)
    parts += ["<h2>Summary as text</h2>", f"<pre>{e(format_side_by_side(s))}</pre>", "</body></html>"]
    return "\n".join(parts) + "\n"


def _run_section(s: SideBySide, i: int, run) -> list:
    """The part of the page about data file ``i``."""
    e = html.escape
    c0 = run[0]
    h, _ = s.headline(i)
    horizon = hl.horizon_label(c0.horizon)
    out = [f"<h2>{e(c0.data_source or 'data')} (experiment {e(c0.experiment)})</h2>",
           "<h3>Every figure, labelled</h3>", _figures_table(s, i),
           f'<p class="note">Free-run fit: one simulation from the data\'s initial state on the measured input '
           f"(zero-order hold), {e(c0.method)} step {c0.dt:g} s; each extra turn of the simulated pendulum counts "
           f"as 2π of theta error, the wrapped figure folds the angle error into (-π, π]. {e(horizon.capitalize())}: "
           f"the simulation restarts from the measured state every {c0.horizon:g} s (what diagnose and fit "
           f"use). Headline: <b>{e(h.label)}</b>, because {e(h.reason)}.</p>"]
    horizon_first = h.metric == hl.HORIZON
    free = ["<h3>Free run: measured and simulated outputs</h3>", _img(_figure_free(s, run), "free-run outputs"),
            '<p class="note">Theta residual wrapped to (-π, π].'
            + (f" Shaded: the worst {WINDOW:g} s windows of the first model's free run." if not horizon_first else "")
            + "</p>"]
    seg = [f"<h3>{e(horizon.capitalize())}: segments restarting from the measured state</h3>",
           _img(_figure_horizon(s, run), f"{horizon} segments over the data"),
           _img(_figure_horizon(s, run, zoom=True), f"{horizon} segments, zoomed on the worst stretch"),
           f'<p class="note">Each line starts at the measured state and runs {c0.horizon:g} s on the measured '
           "input; the lower panels are measured minus simulated. "
           + (f"Shaded: the worst {WINDOW:g} s windows of the first model. " if horizon_first else "")
           + "The second figure zooms on the "
           f"{ZOOM:g} s where the first model's horizon error is largest.</p>"]
    out += seg + free if horizon_first else free + seg
    for lab, c in zip(s.labels, run):
        out += _model_section(lab if len(s.labels) > 1 else "", c)
    return out


def _model_section(label: str, c: Comparison) -> list:
    """Windows, regimes, residual clouds and whiteness of one model's analysed residual."""
    e = html.escape
    who = f"{label}: " if label else ""
    of = f"residual of the {c.residual_of}"
    return [
        f"<h3>{e(who)}worst windows ({e(of)})</h3>", _windows_table(c),
        f"<h3>{e(who)}error by operating regime ({e(of)})</h3>",
        '<p class="note">Share of each output\'s squared residual falling in the regime, next to the share '
        "of time spent there. A ratio well above 1 (highlighted) means the error concentrates in that regime. "
        f"Cart motion uses {e(c.dx_source or 'the measured cart velocity')}.</p>",
        _regimes_table(c),
        f"<h3>{e(who)}residual against the state ({e(of)})</h3>",
        '<p class="note">A trend or a step in these clouds names the missing physics: against dx friction, '
        "against theta a pendulum torque, against u - V_off the drive law, against x a force that depends "
        "on the position.</p>",
        _img(_figure_scatter(c), "residual against dx, theta, u - V_off and x"),
        f"<h3>{e(who)}whiteness (free-run residual, theta wrapped)</h3>",
        *(['<p class="note">Caution: the free run is not meaningful on these data (see the headline), so '
           "these verdicts describe its divergence more than the model.</p>"] if c.headline is not None
          and c.headline.metric == hl.HORIZON else []),
        _img(_figure_correlations(c), "residual autocorrelation and cross-correlation"), _whiteness_table(c)]


def _figure(width: float, height: float, rows: int = 1, cols: int = 1):
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


def _png(fig) -> str:
    """base64 PNG of ``fig``; the Software tag is dropped so equal figures give equal bytes."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, metadata={"Software": None})
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _img(fig, alt: str) -> str:
    return f'<p><img alt="{html.escape(alt)}" src="data:image/png;base64,{_png(fig)}"></p>'


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


def _figure_free(s: SideBySide, run):
    """Per output: measured and every model's free run; then the residuals (theta wrapped)."""
    c0 = run[0]
    n = len(c0.outputs)
    fig = _figure(12, 3.2 * n + 2.4 * n, rows=2 * n)
    t = c0.simulated.t
    for i, k in enumerate(c0.outputs):
        ax = fig.add_subplot(2 * n, 1, i + 1)
        sc, label = _SCALE[k]
        if c0.residual_of == "free run":
            _shade(ax, c0, k)
        ax.plot(t, sc * c0.measured[k], color=MEASURED, lw=1.0, label="measured")
        for j, (lab, c) in enumerate(zip(s.labels, run)):
            ax.plot(t, sc * c.simulated.states[k], color=_colour(j), lw=1.0, ls="--", label=f"free run {lab}")
        ax.set_title(f"{k}: free-run fit {_fits([c.fit[k] for c in run], s.labels)}", fontsize=10)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    for i, k in enumerate(c0.outputs):
        ax = fig.add_subplot(2 * n, 1, n + i + 1)
        sc, label = _RSCALE[k]
        for j, (lab, c) in enumerate(zip(s.labels, run)):
            r = wrap_difference(c.free_residual[k]) if k == "theta" else c.free_residual[k]
            ax.plot(t, sc * r, color=_colour(j), lw=0.8, label=lab)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(label + (" wrapped" if k == "theta" else ""))
        if k == "theta":
            ax.set_title("theta free-run residual, wrapped: fit "
                         + _fits([c.fit_theta_wrapped for c in run], s.labels), fontsize=10)
        ax.grid(alpha=0.3)
        if len(run) > 1:
            ax.legend(loc="upper right", fontsize=8)
    ax.set_xlabel("t (s)")
    return fig


def _zoom_span(c: Comparison) -> tuple[float, float]:
    """The ``ZOOM`` s stretch where ``c``'s horizon residual (first output, scaled by its spread) is largest."""
    t = c.simulated.t
    r = sum(np.nan_to_num(c.measured[k] - c.horizon_run.outputs[k]) / max(float(np.std(c.measured[k])), 1e-12)
            for k in c.outputs)
    w = worst_windows(t, r, "all", width=min(ZOOM, float(t[-1] - t[0])), count=1)[0]
    return w["t0"], w["t1"]


def _figure_horizon(s: SideBySide, run, zoom: bool = False):
    """Per output: the data and every model's horizon segments; below, the horizon residuals
    (``zoom``: only the stretch of :func:`_zoom_span`)."""
    c0 = run[0]
    n = len(c0.outputs)
    fig = _figure(12, (4.4 if zoom else 5.6) * n, rows=2 * n)
    t = c0.simulated.t
    span = _zoom_span(c0) if zoom else None
    for i, k in enumerate(c0.outputs):
        ax = fig.add_subplot(2 * n, 1, 2 * i + 1)
        sc, label = _SCALE[k]
        if c0.residual_of != "free run" and not zoom:
            _shade(ax, c0, k)
        ax.plot(t, sc * c0.measured[k], color=MEASURED, lw=1.6, alpha=0.6, label="measured")
        for j, (lab, c) in enumerate(zip(s.labels, run)):
            tt, yy = c.horizon_run.plot_lines(k)
            ax.plot(tt, sc * yy, color=_colour(j), lw=1.0, ls="--", label=f"{c.horizon:g} s segments {lab}")
        ax.set_title(f"{k}: {hl.horizon_label(c0.horizon)} {_fits([c.fit_horizon[k] for c in run], s.labels)}",
                     fontsize=10)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
        ax = fig.add_subplot(2 * n, 1, 2 * i + 2)
        sr, rlabel = _RSCALE[k]
        for j, (lab, c) in enumerate(zip(s.labels, run)):
            ax.plot(t, sr * (c0.measured[k] - c.horizon_run.outputs[k]), color=_colour(j), lw=0.8, label=lab)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(rlabel)
        ax.grid(alpha=0.3)
        if len(run) > 1:
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


def _figure_scatter(c: Comparison):
    """Rows: each output's residual; columns: against dx, wrapped theta, u - V_off, x (those
    that vary in the run)."""
    n = len(c.simulated.t)
    pick = np.linspace(0, n - 1, min(n, MAX_SCATTER)).astype(int)   # even subsample keeps the time spread
    theta = c.measured.get("theta", np.zeros(n))
    x = c.measured.get("x", np.zeros(n))
    against = [("dx (m/s)", c.measured["dx"]), ("theta wrapped to ±π (rad)", wrap_angle(theta)),
               ("u - V_off (V)", c.simulated.u - c.v_off), ("x (m)", x)]
    against = [(name, v) for name, v in against if np.ptp(v) > 0]   # a held or absent signal shows nothing
    rows, cols = len(c.outputs), max(1, len(against))
    fig = _figure(14 if cols > 2 else 3.5 * cols + 1, 3 * rows, rows=rows, cols=cols)
    for i, k in enumerate(c.outputs):
        sc, label = _RSCALE[k]
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


def _figure_correlations(c: Comparison):
    rows = len(c.outputs)
    fig = _figure(12, 3 * rows, rows=rows, cols=2)
    for i, k in enumerate(c.outputs):
        for j, (key, what) in enumerate((("acf", "autocorrelation"), ("ccf", "cross-corr. with u"))):
            d = c.whiteness[k] if key == "acf" else c.whiteness["xcorr"][k]
            ax = fig.add_subplot(rows, 2, 2 * i + j + 1)
            lag_ms = np.asarray(d["lags"]) * d["lag_seconds"] * 1e3
            ax.vlines(lag_ms, 0.0, d[key], color=RESID, lw=1.5)
            ax.plot(lag_ms, d[key], "o", color=RESID, ms=3)
            ax.axhspan(-d["band"], d["band"], color=BAND, alpha=0.2, lw=0)
            ax.axhline(0.0, color="k", lw=0.5)
            verdict = ("white" if d["white"] else "not white") if key == "acf" else \
                ("independent" if d["independent"] else "correlated")
            ax.set_title(f"{k} residual {what}: {verdict} (99 % band ±{d['band']:.3f})", fontsize=10)
            ax.set_xlabel("lag (ms)" + ("; > 0: input earlier" if key == "ccf" else ""))
            ax.grid(alpha=0.3)
    return fig


def _fmt(output: str, value, digits: int = 4) -> str:
    if value is None or not np.isfinite(value):
        return "–"
    sc, _ = _RSCALE[output]
    return f"{sc * value:.{digits}g}"


def _num(v, sign: bool = False, digits: int = 2) -> str:
    if v is None or not np.isfinite(v):
        return "–"
    return f"{v:+.{digits}f}" if sign else f"{v:.{digits}f}"


def _figures_table(s: SideBySide, i: int) -> str:
    """Every figure per model and its change from the first model; the headline's rows in bold."""
    e = html.escape
    h, _ = s.headline(i)
    lead = "free-run fit " if h.metric == hl.FREE_RUN else hl.horizon_label(s.runs[i][0].horizon) + " "
    changes = [f"{short(lab)} − {short(s.labels[0])}" for lab in s.labels[1:]]
    head = ("<tr><th class=l>figure</th>" + "".join(f"<th>{e(lab)}</th>" for lab in s.labels)
            + "".join(f"<th>{e(ch)}</th>" for ch in changes) + "</tr>")
    rows = []
    for name, unit, values in s.rows(i):
        cls = " class=head" if name.startswith(lead) and "wrapped" not in name else ""
        label = f"{name} ({unit})" if unit else name
        d = 0 if unit == "turns" else 2
        rows.append(f"<tr{cls}><td class=l>{e(label)}</td>" + "".join(f"<td>{_num(v, digits=d)}</td>" for v in values)
                    + "".join(f"<td>{_num(v - values[0], sign=True, digits=d)}</td>" for v in values[1:]) + "</tr>")
    return f"<table>{head}{''.join(rows)}</table>"


def _windows_table(c: Comparison) -> str:
    rows = "".join(
        f"<tr><td class=l>{w['output']}</td><td>{w['t0']:.3f}</td><td>{w['t1']:.3f}</td>"
        f"<td>{_fmt(w['output'], w['rms'])} {_UNIT[w['output']]}</td>"
        f"<td>{100 * w['share']:.1f} %</td></tr>" for w in c.windows)
    return ("<table><tr><th class=l>output</th><th>from (s)</th><th>to (s)</th><th>rms residual</th>"
            f"<th>share of the output's squared error</th></tr>{rows}</table>")


def _regimes_table(c: Comparison) -> str:
    """One row per regime, the outputs side by side, partitions in their fixed order."""
    by_key = {(g["partition"], g["name"], g["output"]): g for g in c.regimes}
    head = ("<tr><th class=l>partition</th><th class=l>regime</th><th class=l>definition</th><th>time</th>"
            + "".join(f"<th>{k} share</th><th>{k} ratio</th><th>{k} rms</th>" for k in c.outputs) + "</tr>")
    rows = []
    for g in c.regimes:
        if g["output"] != c.outputs[0]:
            continue
        cells, hot = [], False
        for k in c.outputs:
            r = by_key[(g["partition"], g["name"], k)]
            ratio = r["share"] / r["fraction_of_time"] if r["fraction_of_time"] else None
            hot |= concentrated(r)
            cells.append(f"<td>{100 * r['share']:.1f} %</td><td>{'–' if ratio is None else f'{ratio:.2f}'}</td>"
                         f"<td>{_fmt(k, r['rms'], 3)}</td>")
        rows.append(f"<tr{' class=hot' if hot else ''}><td class=l>{html.escape(g['partition'])}</td>"
                    f"<td class=l>{html.escape(g['name'])}</td><td class=l>{html.escape(g['definition'])}</td>"
                    f"<td>{100 * g['fraction_of_time']:.1f} %</td>{''.join(cells)}</tr>")
    return f"<table>{head}{''.join(rows)}</table><p class=note>rms in mm (x) and mrad (theta).</p>"


def _whiteness_table(c: Comparison) -> str:
    rows = []
    for k in c.outputs:
        a, x = c.whiteness[k], c.whiteness["xcorr"][k]
        rows.append(f"<tr><td class=l>{k}</td><td class=l>autocorrelation, lags 1..{len(a['lags']) - 1}</td>"
                    f"<td>{a['band']:.3f}</td><td>{len(a['outside'])} (≤ {a['allowed']} allowed)</td>"
                    f"<td class=l>{'white' if a['white'] else 'not white'}</td></tr>")
        rows.append(f"<tr><td class=l>{k}</td><td class=l>cross-correlation with u, lags "
                    f"{x['lags'][0]}..{x['lags'][-1]}</td><td>{x['band']:.3f}</td>"
                    f"<td>{len(x['outside'])} (≤ {x['allowed']} allowed)</td>"
                    f"<td class=l>{'independent of u' if x['independent'] else 'correlated with u'}</td></tr>")
    step = c.whiteness[c.outputs[0]]["lag_seconds"]
    return ("<table><tr><th class=l>output</th><th class=l>test</th><th>99 % band</th><th>lags outside</th>"
            f"<th class=l>verdict</th></tr>{''.join(rows)}</table>"
            f"<p class=note>Residual and input are block-averaged to one sample per {1e3 * step:.3g} ms before "
            "correlating. The cross-correlation band widens with the autocorrelation of residual and input "
            "(Bartlett), as in MATLAB's resid.</p>")
