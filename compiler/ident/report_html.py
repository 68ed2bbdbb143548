"""``pendc compare --html``: one self-contained HTML page for one model or several side by side.

Everything is inline (CSS in a ``<style>`` block, plots as base64 PNG data URIs), so
the file can be mailed or archived alone and opens without a network. The plots are
drawn by :mod:`pendc.ident.report_plots`. The page is rendered completely in memory and
then written with :func:`pendc.atomic.write_atomic`: a failure leaves no half-written file.

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
from .compare import WORST_WINDOW, Comparison, model_name
from .report_plots import ZOOM, residual_scale, scatter_axes
from .report_plots import figure_correlations as _figure_correlations
from .report_plots import figure_free as _figure_free
from .report_plots import figure_horizon as _figure_horizon
from .report_plots import figure_scatter as _figure_scatter
from .report_plots import zoom_span as _zoom_span  # noqa: F401 (the zoomed figure's span, for tests)
from .report_text import concentrated, format_side_by_side, short, side_by_side_headline
from .sidebyside import SideBySide, as_side_by_side
from .units import labelled, small_scale, table_digits, unit_of
from ..model.interface import unit_name, with_unit
from ..sim.signals import signals_of

DPI = 80

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
           f"(zero-order hold), {e(c0.method)} step {c0.dt:g} s; "
           + (f"each extra turn of the simulated {e(_body(c0, c0.angle))} counts as 2π of {e(c0.angle)} error, the "
              "wrapped figure folds the angle error into (-π, π]. " if c0.angle else "")
           + f"{e(horizon.capitalize())}: "
           f"the simulation restarts from the measured state every {c0.horizon:g} s (what diagnose and fit "
           f"use). Headline: <b>{e(h.label)}</b>, because {e(h.reason)}.</p>"]
    horizon_first = h.metric == hl.HORIZON
    free = ["<h3>Free run: measured and simulated outputs</h3>", _img(_figure_free(s, run), "free-run outputs"),
            '<p class="note">' + (f"{e(c0.angle.capitalize())} residual wrapped to (-π, π]." if c0.angle else "")
            + (f" Shaded: the worst {WORST_WINDOW:g} s windows of the first model's free run." if not horizon_first else "")
            + "</p>"] + _band_notes(s, run)
    seg = [f"<h3>{e(horizon.capitalize())}: segments restarting from the measured state</h3>",
           _img(_figure_horizon(s, run), f"{horizon} segments over the data"),
           _img(_figure_horizon(s, run, zoom=True), f"{horizon} segments, zoomed on the worst stretch"),
           f'<p class="note">Each line starts at the measured state and runs {c0.horizon:g} s on the measured '
           "input; the lower panels are measured minus simulated. "
           + (f"Shaded: the worst {WORST_WINDOW:g} s windows of the first model. " if horizon_first else "")
           + "The second figure zooms on the "
           f"{ZOOM:g} s where the first model's horizon error is largest.</p>"]
    out += seg + free if horizon_first else free + seg
    for lab, c in zip(s.labels, run):
        out += _model_section(lab if len(s.labels) > 1 else "", c)
    return out


def _band_notes(s: SideBySide, run) -> list:
    """Per model with a prediction band: where it comes from and how often the measurement leaves it."""
    e = html.escape
    out = []
    for lab, c in zip(s.labels, run):
        if c.band is None:
            continue
        b = c.band
        who = f"{e(lab)}: " if len(s.labels) > 1 else ""
        rows = "".join(f"<tr><td>{e(k)}</td><td>{100 * b.outside_free[k]:.1f} %</td>"
                       f"<td>{100 * b.outside_horizon[k]:.1f} %</td></tr>" for k in b.outside_free)
        out += [f'<p class="note">{who}Band: the 95 % prediction band of {b.samples} parameter draws of '
                f"{e(b.uncertainty.describe())}, simulated in free run and on the {b.horizon_s:g} s horizon; in the "
                "residual panels it is drawn around the nominal simulation, so the residual leaves it where the "
                "measurement does. It holds the parameters' uncertainty and half a sensor count each side "
                "(quantisation), not sensor noise: a measurement that leaves it often has an error the fit's "
                "uncertainty does not explain.</p>",
                f"<table><tr><th>{who}output</th><th>outside the band, free run</th>"
                f"<th>outside the band, {b.horizon_s:g} s horizon</th></tr>{rows}</table>"]
        if b.diverged:
            out.append(f'<p class="note">{b.diverged} of {b.samples} draws diverged and are not in the band.</p>')
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
        f"{e(_body(c, signals_of(c.model).positions[0]).capitalize())} motion uses {e(c.motion_source or 'the measured velocity')}.</p>",
        _regimes_table(c),
        f"<h3>{e(who)}residual against the state ({e(of)})</h3>",
        '<p class="note">A trend or a step in these clouds names the missing physics: against a velocity '
        "friction, against an angle a torque that depends on it (gravity, a pendulum torque), against the input "
        "the drive law, against a position a force that depends on where the body is.</p>",
        _img(_figure_scatter(c), "residual against " + ", ".join(name.rsplit(" (", 1)[0] for name, _ in
                                                                  scatter_axes(c))),
        f"<h3>{e(who)}whiteness (free-run residual{e(f', {c.angle} wrapped' if c.angle else '')})</h3>",
        *(['<p class="note">Caution: the free run is not meaningful on these data (see the headline), so '
           "these verdicts describe its divergence more than the model.</p>"] if c.headline is not None
          and c.headline.metric == hl.HORIZON else []),
        _img(_figure_correlations(c), "residual autocorrelation and cross-correlation"), _whiteness_table(c)]


def _png(fig) -> str:
    """base64 PNG of ``fig``; the Software tag is dropped so equal figures give equal bytes."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, metadata={"Software": None})
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _img(fig, alt: str) -> str:
    return f'<p><img alt="{html.escape(alt)}" src="data:image/png;base64,{_png(fig)}"></p>'


def _fmt(c: Comparison, output: str, value, digits: int = 4) -> str:
    """A residual of ``output`` in the unit :func:`_unit` names (mm, mrad)."""
    if value is None or not np.isfinite(value):
        return "–"
    sc, _ = residual_scale(c, output)
    return f"{sc * value:.{digits}g}"


def _unit(c: Comparison, output: str) -> str:
    """The unit residuals of ``output`` are printed in: ``mm``, ``mrad``."""
    return small_scale(unit_of(c.model, output))[1]


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
        label = labelled(name, unit)
        d = table_digits(values, unit)
        rows.append(f"<tr{cls}><td class=l>{e(label)}</td>" + "".join(f"<td>{_num(v, digits=d)}</td>" for v in values)
                    + "".join(f"<td>{_num(v - values[0], sign=True, digits=d)}</td>" for v in values[1:]) + "</tr>")
    return f"<table>{head}{''.join(rows)}</table>"


def _windows_table(c: Comparison) -> str:
    rows = "".join(
        f"<tr><td class=l>{w['output']}</td><td>{w['t0']:.3f}</td><td>{w['t1']:.3f}</td>"
        f"<td>{with_unit(_fmt(c, w['output'], w['rms']), _unit(c, w['output']))}</td>"
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
                         f"<td>{_fmt(c, k, r['rms'], 3)}</td>")
        rows.append(f"<tr{' class=hot' if hot else ''}><td class=l>{html.escape(g['partition'])}</td>"
                    f"<td class=l>{html.escape(g['name'])}</td><td class=l>{html.escape(g['definition'])}</td>"
                    f"<td>{100 * g['fraction_of_time']:.1f} %</td>{''.join(cells)}</tr>")
    units = " and ".join(f"{unit_name(_unit(c, k))} ({k})" for k in c.outputs)
    return f"<table>{head}{''.join(rows)}</table><p class=note>rms in {html.escape(units)}.</p>"


def _body(c: Comparison, state: str) -> str:
    """The body a state belongs to, in words ("pendulum")."""
    return signals_of(c.model).body_of(state) if state else ""


def _acf_verdict(c: Comparison, k: str, a: dict) -> str:
    """'white' / 'not white', with the bias the whiteness test cannot see (it removes the mean)."""
    from .whiteness import biased

    verdict = "white" if a["white"] else "not white"
    if biased(a, signals_of(c.model).resolution(k)):
        return f"biased by {a['mean']:+.3g} (noise cannot explain it); {verdict} about it"
    return verdict


def _whiteness_table(c: Comparison) -> str:
    rows = []
    for k in c.outputs:
        a, x = c.whiteness[k], c.whiteness["xcorr"][k]
        rows.append(f"<tr><td class=l>{k}</td><td class=l>autocorrelation, lags 1..{len(a['lags']) - 1}</td>"
                    f"<td>{a['band']:.3f}</td><td>{len(a['outside'])} (≤ {a['allowed']} allowed)</td>"
                    f"<td class=l>{_acf_verdict(c, k, a)}</td></tr>")
        if not x.get("tested", True):
            rows.append(f"<tr><td class=l>{k}</td><td class=l>cross-correlation with u</td><td>–</td><td>–</td>"
                        f"<td class=l>not tested: {html.escape(x['reason'])}</td></tr>")
            continue
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
