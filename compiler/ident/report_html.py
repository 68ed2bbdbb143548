"""Reports of a :class:`~pendc.ident.compare.Comparison`: terminal text and one HTML page.

:func:`format_text` is the plain-words summary ``pendc compare`` prints.
:func:`write_html_report` is ``pendc compare --html``: one self-contained page.
Everything is inline (CSS in a ``<style>`` block, plots as base64 PNG data URIs), so
the file can be mailed or archived alone and opens without a network. Figures are
drawn with matplotlib's object API (:class:`~matplotlib.figure.Figure` on an Agg
canvas), never through pyplot, so no global figure registry or backend choice
leaks into the caller's process; matplotlib is imported only when a figure is
drawn, so the text report does not load it. The page is rendered completely in memory and then
written with :func:`pendc.atomic.write_atomic`: a failure leaves no half-written file.
"""

from __future__ import annotations

import base64
import html
import io
import math

import numpy as np

from ..atomic import write_atomic
from ..sim.encoders import THETA_COUNT, X_COUNT
from .compare import OUTPUTS, WINDOW, wrap_angle

FEW_COUNTS = 5           # rms residual (encoder counts) below which structure may be rounding
COUNT = {"x": X_COUNT, "theta": THETA_COUNT}
ALWAYS = 0.99            # a regime covering this much of the run tells nothing; the text skips it
MAX_SCATTER = 4000       # points per scatter panel: enough to see a trend, keeps the PNG small
DPI = 80
MEASURED, SIMULATED, RESID, BAND = "#1f4e9a", "#d1495b", "#444444", "#2a9d8f"
_SCALE = {"x": (1e3, "x (mm)"), "theta": (1.0, "theta (rad)")}
_RSCALE = {"x": (1e3, "x residual (mm)"), "theta": (1e3, "theta residual (mrad)")}

_CSS = """
body { font-family: sans-serif; max-width: 1200px; margin: 1em auto; padding: 0 1em; color: #222; }
h1 { font-size: 1.4em; } h2 { font-size: 1.15em; margin-top: 1.6em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: right; }
th { background: #f0f0f0; } td.l, th.l { text-align: left; }
tr.hot td { background: #fde2e2; }
img { max-width: 100%; } pre { background: #f7f7f7; padding: 0.6em; font-size: 0.8em; overflow-x: auto; }
p.note { color: #555; font-size: 0.9em; }
"""


def concentrated(regime: dict) -> bool:
    """Worth pointing at: the regime holds a fifth of the error or more, at 1.5x its share of time."""
    f = regime["fraction_of_time"]
    return f > 0 and regime["share"] >= 0.2 and regime["share"] / f >= 1.5


def _amount(output: str, value) -> str:
    """A length in mm, an angle in mrad below 1 rad and in rad above."""
    if value is None:
        return "n/a"
    if output == "theta" and abs(value) >= 1.0:
        return f"{value:.3g} rad"
    return f"{value * 1e3:.3g} {'mm' if output == 'x' else 'mrad'}"


def format_text(c) -> str:
    """Plain-words terminal summary: fit, worst windows, regimes by share, whiteness."""
    lines = [f"model {c.model.source if c.model is not None and c.model.source else '(in memory)'} "
             f"on {c.data_source or '(data)'}: free-run simulation, {c.method} step {c.dt:g} s", ""]
    rms = c.rms()
    for k in OUTPUTS:
        f = c.fit[k]
        spread = float(np.std(c.measured[k])) if k in c.measured else None
        fit = "undefined (the measured output is constant)" if not math.isfinite(f) else f"{f:6.2f} %"
        lines.append(f"fit {k:5s} {fit}   rms error {_amount(k, rms[k])}"
                     + (f" (data spread {_amount(k, spread)})" if spread is not None else ""))
    lines += ["", f"Worst {WINDOW:g} s windows (largest rms error):"]
    for k in OUTPUTS:
        for w in (w for w in c.windows if w["output"] == k):
            lines.append(f"  {k:5s} {w['t0']:8.2f} - {w['t1']:8.2f} s   rms {_amount(k, w['rms']):>11s}   "
                         f"{100 * w['share']:5.1f} % of the {k} error")
    lines += ["", "Where the error is (share of the squared error vs share of time; "
              "a ratio well above 1 means the error concentrates there):"]
    for k in OUTPUTS:
        rows = sorted((g for g in c.regimes if g["output"] == k and 0 < g["fraction_of_time"] < ALWAYS),
                      key=lambda g: -g["share"])
        lines += [f"  {k:5s} {100 * g['share']:5.1f} % of the error in {100 * g['fraction_of_time']:5.1f} % of the "
                  f"time: {g['name']} ({g['definition']}), ratio {g['share'] / g['fraction_of_time']:.2f}"
                  + ("  <- concentrated" if concentrated(g) else "") for g in rows]
    first = [g for g in c.regimes if g["output"] == OUTPUTS[0]]
    always = ", ".join(g["name"] for g in first if g["fraction_of_time"] >= ALWAYS)
    never = ", ".join(g["name"] for g in first if not g["samples"])
    notes = ([f"all or nearly all the run: {always}"] if always else []) + ([f"never: {never}"] if never else [])
    if notes:
        lines.append(f"  ({'; '.join(notes)})")
    lines += ["", "Is what is left noise? (99 % bands, residual sampled every "
              f"{1e3 * c.whiteness[OUTPUTS[0]]['lag_seconds']:.3g} ms)"]
    for k in OUTPUTS:
        lines += _whiteness_words(k, c.whiteness[k], c.whiteness["xcorr"][k], rms[k])
    return "\n".join(lines) + "\n"


def _whiteness_words(k: str, a: dict, x: dict, rms: float) -> list:
    """The verdicts of one output's autocorrelation ``a`` and input cross-correlation ``x``."""
    step = 1e3 * a["lag_seconds"]
    if a["white"]:
        out = [f"  {k:5s} residual looks white: only noise is left to explain"]
    else:
        lag = max(a["outside"] or a["lags"][1:], key=lambda j: abs(a["acf"][j]))
        out = [f"  {k:5s} residual is not white: {len(a['outside'])} of {len(a['lags']) - 1} lags outside the band "
               f"(r = {a['acf'][lag]:+.2f} at {lag * step:.3g} ms): the error is systematic, the model misses or "
               "mis-sets some dynamics"]
        counts = rms / COUNT[k]
        if counts < FEW_COUNTS:   # a whiteness test sees structure far below what matters
            out.append(f"        but it is only {counts:.1f} encoder counts rms: at this level the structure may be "
                       "the encoder's rounding or the integration step")
    if x["independent"]:
        return out + [f"  {k:5s} residual shows no significant correlation with the input"]
    mid = len(x["lags"]) // 2
    lag = max(x["outside"] or x["lags"], key=lambda j: abs(x["ccf"][j + mid]))
    when = (f"the input {lag * step:.3g} ms earlier" if lag >= 0
            else f"the input {-lag * step:.3g} ms later, i.e. feedback or a slow drift")
    return out + [f"  {k:5s} residual follows the input: {len(x['outside'])} of {len(x['lags'])} lags outside the "
                  f"band (r = {x['ccf'][lag + mid]:+.2f} with {when}): the drive, friction or delay is wrong"]


def write_html_report(c, path, title: str | None = None) -> None:
    """Render the report of Comparison ``c`` and write it to ``path`` atomically."""
    write_atomic(path, render_html(c, title))


def render_html(c, title: str | None = None) -> str:
    """The report as one HTML string (no external references)."""
    model = c.model.source if c.model is not None and c.model.source else "(model in memory)"
    title = title or f"pendc compare: {c.data_source or 'data'} vs {model}"
    e = html.escape
    parts = [
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{e(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{e(title)}</h1>",
        f'<p class="note">Free-run simulation from the data\'s initial state on the measured input '
        f"(zero-order hold), {e(c.method)} step {c.dt:g} s. Residual = measured - simulated.</p>",
        "<h2>Fit</h2>", _fit_table(c),
        "<h2>Measured and simulated outputs</h2>",
        _img(_figure_outputs(c), "measured and simulated x and theta"),
        f'<p class="note">Shaded: the worst {WINDOW:g} s windows of each output.</p>',
        "<h2>Residuals</h2>", _img(_figure_residuals(c), "residuals of x and theta over time"),
        "<h2>Worst windows</h2>", _windows_table(c),
        "<h2>Error by operating regime</h2>",
        '<p class="note">Share of each output\'s squared residual falling in the regime, next to the share '
        "of time spent there. A ratio well above 1 (highlighted) means the error concentrates in that regime. "
        f"Cart motion uses {e(c.dx_source or 'the measured cart velocity')}.</p>",
        _regimes_table(c),
        "<h2>Residual against the state</h2>",
        '<p class="note">A trend or a step in these clouds names the missing physics: against dx friction, '
        "against theta a pendulum torque, against u - V_off the drive law, against x a force that depends "
        "on the position.</p>",
        _img(_figure_scatter(c), "residual against dx, theta, u - V_off and x"),
        "<h2>Whiteness</h2>", _img(_figure_correlations(c), "residual autocorrelation and cross-correlation"),
        _whiteness_table(c),
        "<h2>Summary as text</h2>", f"<pre>{e(format_text(c))}</pre>",
        "</body></html>",
    ]
    return "\n".join(parts) + "\n"


def _figure(width: float, height: float):
    """A new Figure on its own Agg canvas. Imported here, not at module level, so the text
    report (and ``compare --json``) never load matplotlib."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _png(fig) -> str:
    """base64 PNG of ``fig``; the Software tag is dropped so equal figures give equal bytes."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, metadata={"Software": None})
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _img(fig, alt: str) -> str:
    return f'<p><img alt="{html.escape(alt)}" src="data:image/png;base64,{_png(fig)}"></p>'


def _shade_windows(ax, c, output):
    for w in c.windows:
        if w["output"] == output:
            ax.axvspan(w["t0"], w["t1"], color="#f4a261", alpha=0.25, lw=0)


def _figure_outputs(c) :
    fig = _figure(12, 6)
    t = c.simulated.t
    for i, k in enumerate(OUTPUTS):
        ax = fig.add_subplot(2, 1, i + 1)
        s, label = _SCALE[k]
        _shade_windows(ax, c, k)
        ax.plot(t, s * c.measured[k], color=MEASURED, lw=1.0, label="measured")
        ax.plot(t, s * c.simulated.states[k], color=SIMULATED, lw=1.0, ls="--", label="simulated")
        fit = c.fit[k]
        ax.set_title(f"{k}: fit {fit:.2f} %" if np.isfinite(fit) else f"{k}: fit undefined", fontsize=10)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    ax.set_xlabel("t (s)")
    return fig


def _figure_residuals(c) :
    fig = _figure(12, 5)
    t = c.simulated.t
    for i, k in enumerate(OUTPUTS):
        ax = fig.add_subplot(2, 1, i + 1)
        s, label = _RSCALE[k]
        _shade_windows(ax, c, k)
        ax.plot(t, s * c.residual[k], color=RESID, lw=0.8)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    ax.set_xlabel("t (s)")
    return fig


def _figure_scatter(c) :
    """Rows: x and theta residual; columns: against dx, wrapped theta, u - V_off, x."""
    n = len(c.simulated.t)
    pick = np.linspace(0, n - 1, min(n, MAX_SCATTER)).astype(int)   # even subsample keeps the time spread
    against = [("dx (m/s)", c.measured["dx"]), ("theta wrapped to ±π (rad)", wrap_angle(c.measured["theta"])),
               ("u - V_off (V)", c.simulated.u - c.v_off), ("x (m)", c.measured["x"])]
    fig = _figure(14, 6)
    for i, k in enumerate(OUTPUTS):
        s, label = _RSCALE[k]
        for j, (name, v) in enumerate(against):
            ax = fig.add_subplot(2, 4, 4 * i + j + 1)
            ax.scatter(np.asarray(v)[pick], s * c.residual[k][pick], s=2, alpha=0.3, color=RESID, lw=0)
            ax.axhline(0.0, color="k", lw=0.5)
            ax.grid(alpha=0.3)
            if i == 1:
                ax.set_xlabel(name)
            if j == 0:
                ax.set_ylabel(label)
    return fig


def _figure_correlations(c) :
    fig = _figure(12, 6)
    for i, k in enumerate(OUTPUTS):
        for j, (key, what) in enumerate((("acf", "autocorrelation"), ("ccf", "cross-corr. with u"))):
            d = c.whiteness[k] if key == "acf" else c.whiteness["xcorr"][k]
            ax = fig.add_subplot(2, 2, 2 * i + j + 1)
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
    s, _ = _RSCALE[output]
    return f"{s * value:.{digits}g}"


def _fit_table(c) -> str:
    rms = c.rms()
    rows = "".join(
        f"<tr><td class=l>{k}</td><td>{c.fit[k]:.2f} %</td><td>{_fmt(k, rms[k])} {'mm' if k == 'x' else 'mrad'}</td>"
        f"<td>{_fmt(k, float(np.std(c.measured[k])))} {'mm' if k == 'x' else 'mrad'}</td></tr>"
        if np.isfinite(c.fit[k]) else
        f"<tr><td class=l>{k}</td><td>undefined</td><td>{_fmt(k, rms[k])}</td><td>0</td></tr>"
        for k in OUTPUTS)
    return ("<table><tr><th class=l>output</th><th>fit</th><th>rms residual</th><th>data spread (std)</th></tr>"
            f"{rows}</table>")


def _windows_table(c) -> str:
    rows = "".join(
        f"<tr><td class=l>{w['output']}</td><td>{w['t0']:.3f}</td><td>{w['t1']:.3f}</td>"
        f"<td>{_fmt(w['output'], w['rms'])} {'mm' if w['output'] == 'x' else 'mrad'}</td>"
        f"<td>{100 * w['share']:.1f} %</td></tr>" for w in c.windows)
    return ("<table><tr><th class=l>output</th><th>from (s)</th><th>to (s)</th><th>rms residual</th>"
            f"<th>share of the output's squared error</th></tr>{rows}</table>")


def _regimes_table(c) -> str:
    """One row per regime, both outputs side by side, partitions in their fixed order."""
    by_key = {(g["partition"], g["name"], g["output"]): g for g in c.regimes}
    head = ("<tr><th class=l>partition</th><th class=l>regime</th><th class=l>definition</th><th>time</th>"
            + "".join(f"<th>{k} share</th><th>{k} ratio</th><th>{k} rms</th>" for k in OUTPUTS) + "</tr>")
    rows = []
    for g in c.regimes:
        if g["output"] != OUTPUTS[0]:
            continue
        cells, hot = [], False
        for k in OUTPUTS:
            r = by_key[(g["partition"], g["name"], k)]
            ratio = r["share"] / r["fraction_of_time"] if r["fraction_of_time"] else None
            hot |= concentrated(r)
            cells.append(f"<td>{100 * r['share']:.1f} %</td><td>{'–' if ratio is None else f'{ratio:.2f}'}</td>"
                         f"<td>{_fmt(k, r['rms'], 3)}</td>")
        rows.append(f"<tr{' class=hot' if hot else ''}><td class=l>{html.escape(g['partition'])}</td>"
                    f"<td class=l>{html.escape(g['name'])}</td><td class=l>{html.escape(g['definition'])}</td>"
                    f"<td>{100 * g['fraction_of_time']:.1f} %</td>{''.join(cells)}</tr>")
    return f"<table>{head}{''.join(rows)}</table><p class=note>rms in mm (x) and mrad (theta).</p>"


def _whiteness_table(c) -> str:
    rows = []
    for k in OUTPUTS:
        a, x = c.whiteness[k], c.whiteness["xcorr"][k]
        rows.append(f"<tr><td class=l>{k}</td><td class=l>autocorrelation, lags 1..{len(a['lags']) - 1}</td>"
                    f"<td>{a['band']:.3f}</td><td>{len(a['outside'])} (≤ {a['allowed']} allowed)</td>"
                    f"<td class=l>{'white' if a['white'] else 'not white'}</td></tr>")
        rows.append(f"<tr><td class=l>{k}</td><td class=l>cross-correlation with u, lags "
                    f"{x['lags'][0]}..{x['lags'][-1]}</td><td>{x['band']:.3f}</td>"
                    f"<td>{len(x['outside'])} (≤ {x['allowed']} allowed)</td>"
                    f"<td class=l>{'independent of u' if x['independent'] else 'correlated with u'}</td></tr>")
    step = c.whiteness[OUTPUTS[0]]["lag_seconds"]
    return ("<table><tr><th class=l>output</th><th class=l>test</th><th>99 % band</th><th>lags outside</th>"
            f"<th class=l>verdict</th></tr>{''.join(rows)}</table>"
            f"<p class=note>Residual and input are block-averaged to one sample per {1e3 * step:.3g} ms before "
            "correlating. The cross-correlation band widens with the autocorrelation of residual and input "
            "(Bartlett), as in MATLAB's resid.</p>")
