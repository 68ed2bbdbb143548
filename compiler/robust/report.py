"""The sweep's HTML page: one self-contained file (inline CSS, figures as base64 PNG).

It opens with the answer (success rate, its 95 % interval, the parameter that matters most), then
the success rate along each varied parameter, the failure region in the two parameters that
matter most, the sensitivity ranking, and the worst runs with the command that replays each.
Drawn with matplotlib's Agg backend, rendered in memory and written atomically, as
:mod:`pendc.ident.report_html` does. Imports matplotlib, numpy and the robust package.
"""

from __future__ import annotations

import base64
import html
import io
import math

import numpy as np

from ..atomic import write_atomic
from .scenario_runner import CRITERION_FIGURE

DPI = 80
BINS = 6
_CSS = """
body { font-family: sans-serif; max-width: 1100px; margin: 1em auto; padding: 0 1em; color: #222; }
h1 { font-size: 1.4em; } h2 { font-size: 1.15em; margin-top: 1.6em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: right; }
th { background: #f0f0f0; } td.l, th.l { text-align: left; } img { max-width: 100%; }
p.headline { font-size: 1.1em; background: #eef5ff; padding: 0.5em 0.8em; border-left: 4px solid #1f4e9a; }
code { background: #f7f7f7; padding: 0 0.2em; }
"""


def _png(fig) -> str:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, metadata={"Software": None})
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _img(fig, alt: str) -> str:
    return f'<p><img alt="{html.escape(alt)}" src="data:image/png;base64,{_png(fig)}"></p>'


def _figure():
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    return plt


def success_along(values: np.ndarray, passed: np.ndarray, bins: int = BINS) -> tuple:
    """(bin centres, success rate, runs) over equal-count bins of ``values``."""
    order = np.argsort(values, kind="stable")
    groups = [g for g in np.array_split(order, min(bins, len(values))) if g.size]
    return (np.array([values[g].mean() for g in groups]), np.array([passed[g].mean() for g in groups]),
            np.array([g.size for g in groups]))


def figure_success_per_parameter(names, X, passed):
    plt = _figure()
    from matplotlib.ticker import MaxNLocator
    cols = min(3, len(names))
    rows = math.ceil(len(names) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 2.6 * rows), squeeze=False)
    for j, name in enumerate(names):
        ax = axes[j // cols][j % cols]
        centres, rate, _ = success_along(X[:, j], passed)
        ax.plot(centres, rate, "o-", color="#1f4e9a")
        ax.plot(X[passed, j], np.full(passed.sum(), 1.04), "|", color="#2a9d4a", ms=6)
        ax.plot(X[~passed, j], np.full((~passed).sum(), -0.04), "|", color="#c0392b", ms=6)
        ax.set_ylim(-0.1, 1.1)
        ax.xaxis.set_major_locator(MaxNLocator(4))     # long tick labels (1.2e-3) must not overlap
        ax.set_xlabel(name)
        ax.set_ylabel("success rate")
        ax.grid(alpha=0.3)
    for j in range(len(names), rows * cols):
        axes[j // cols][j % cols].axis("off")
    fig.tight_layout()
    return fig


def figure_failure_region(a: str, b: str, xa, xb, passed, nominal: dict):
    plt = _figure()
    fig, ax = plt.subplots(figsize=(6, 4.6))
    ax.scatter(xa[passed], xb[passed], marker="o", s=18, color="#2a9d4a", label="passed")
    ax.scatter(xa[~passed], xb[~passed], marker="X", s=28, color="#c0392b", label="failed")
    ax.plot([nominal[a]], [nominal[b]], marker="*", ms=14, color="k", ls="none", label="nominal")
    ax.set_xlabel(a)
    ax.set_ylabel(b)
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def figure_ranking(ranking):
    plt = _figure()
    names = [e[0] for e in ranking.entries][::-1]
    s1 = [e[1] for e in ranking.entries][::-1]
    conf = [e[2] for e in ranking.entries][::-1]
    fig, ax = plt.subplots(figsize=(6, 0.35 * len(names) + 1.2))
    ax.barh(names, s1, xerr=conf, color="#1f4e9a", ecolor="#888")
    ax.set_xlabel(f"first-order index (RBD-FAST) of {ranking.outcome}")
    ax.xaxis.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig


def _fmt(v) -> str:
    return "-" if v is None else f"{v:.4g}" if isinstance(v, float) else html.escape(str(v))


def render_report(rows, spec, plan, summary, ranking) -> str:
    """The page as one HTML string (no external references)."""
    e = html.escape
    names = list(plan.names)
    X = np.array([[r[n] for n in names] for r in rows], dtype=float).reshape(len(rows), len(names))
    passed = np.array([bool(r.get("passed")) for r in rows])
    rate, ci = summary["success_rate"], summary["success_rate_95"]
    parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>pendc robust: {e(spec.model_source)}</title>"
             f"<style>{_CSS}</style></head><body>",
             f"<h1>Monte-Carlo HIL: {e(spec.scenario)} on the {e(spec.plant)} plant</h1>"]
    if rate is None:
        parts.append("<p class='headline'>No run finished.</p>")
    else:
        top = summary["most_important"]
        parts.append(f"<p class='headline'>{summary['passed']} of {summary['finished']} runs passed: success rate "
                     f"<b>{100 * rate:.1f} %</b> (95 % Wilson interval {100 * ci[0]:.1f}–{100 * ci[1]:.1f} %)"
                     + (f"; the parameter that matters most: <b>{e(top)}</b>" if top else "") + ".</p>")
    parts.append(f"<p>Plants sampled around <code>{e(spec.model_source)}</code>, controller "
                 f"<code>{e(spec.controller)}</code> designed on <code>{e(spec.design_source)}</code>; "
                 f"{plan.count} samples ({e(plan.method)}, seed {plan.seed}) from {e(plan.origin)}.</p><ul>"
                 + "".join(f"<li>{e(line)}</li>" for line in plan.describe()) + "</ul>")
    if rows and names:
        parts += ["<h2>Success along each parameter</h2>",
                  "<p>Success rate over equal-count bins of each parameter; ticks: passed runs (top), failed (bottom).</p>",
                  _img(figure_success_per_parameter(names, X, passed), "success rate along each parameter")]
        order = [p for p, _, _ in ranking.entries] if ranking else names
        if len(order) >= 2:
            a, b = order[0], order[1]
            parts += [f"<h2>Failure region: {e(a)} and {e(b)}</h2>",
                      _img(figure_failure_region(a, b, X[:, names.index(a)], X[:, names.index(b)], passed,
                                                 plan.nominal), "failure region")]
    if ranking is not None:
        parts += ["<h2>Sensitivity ranking</h2>", f"<p>SALib RBD-FAST first-order indices of {e(ranking.outcome)} "
                  "with 95 % bootstrap half-widths.</p>", _img(figure_ranking(ranking), "sensitivity ranking"),
                  "<table><tr><th class='l'>parameter</th><th>S1</th><th>± 95 %</th></tr>"
                  + "".join(f"<tr><td class='l'>{e(p)}</td><td>{s:.3f}</td><td>{c:.3f}</td></tr>"
                            for p, s, c in ranking.entries) + "</table>"]
    figure = CRITERION_FIGURE[spec.scenario]
    parts += ["<h2>Worst runs</h2>", f"<table><tr><th>run</th><th class='l'>outcome</th><th>{e(figure)}</th>"
              + "".join(f"<th>{e(n)}</th>" for n in names) + "<th class='l'>replay</th></tr>"]
    for w in summary["worst_runs"]:
        parts.append(f"<tr><td>{w['index']}</td><td class='l'>{e(w['why'])}</td><td>{_fmt(w[figure])}</td>"
                     + "".join(f"<td>{_fmt(w['parameters'][n])}</td>" for n in names)
                     + f"<td class='l'><code>{e(w['replay'])}</code></td></tr>")
    parts.append("</table></body></html>\n")
    return "\n".join(parts)


def write_report(path, rows, spec, plan, summary, ranking) -> None:
    write_atomic(path, render_report(rows, spec, plan, summary, ranking))
