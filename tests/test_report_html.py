"""The HTML report of pendc compare: self-contained, labelled, horizon plot, models overlaid, atomic.

Rendering PNGs is the slow part, so each real page is rendered once per module; the
tests about writing replace the PNG encoder by a stub that returns a constant.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from pendc.errors import PendcError
from pendc.ident import report_html
from pendc.ident.compare import compare
from pendc.ident.report_html import render_html, write_html_report
from pendc.ident.sidebyside import compare_models
from pendc.model.modelfile import load_model
from plants import STIMULI as stimuli
from pendc.sim.measurements import Measurement
from pendc.sim.simulator import Simulator

SPRING = {"k_c": 200.0, "x_0": 0.0}


def measured(model, t, u) -> Measurement:
    r = Simulator(model, dt=1e-4, method="rk4")(t, u)
    return Measurement(t=t, u=u, columns={"t": t, "u": u, **{k: r[k] for k in ("x", "theta", "dx", "dtheta")}},
                       meta={}, source="spring.csv")


@pytest.fixture(scope="module")
def model():
    return load_model()


@pytest.fixture(scope="module")
def data(model):
    t, u = stimuli.chirp(duration=2)
    return measured(model.with_effect("cart_spring", SPRING), t, u)


@pytest.fixture(scope="module")
def single(model, data):
    return compare(model, data)


@pytest.fixture(scope="module")
def single_page(single):
    return render_html(single)


@pytest.fixture(scope="module")
def pair(model, data):
    return compare_models([model, model.with_effect("cart_spring", SPRING)], [data])


@pytest.fixture(scope="module")
def pair_page(pair):
    return render_html(pair)


@pytest.fixture
def cheap_png(monkeypatch):
    monkeypatch.setattr(report_html, "_png", lambda fig: "AAAA")


def _refs(text):
    return re.findall(r"""(?:src|href)\s*=\s*["']?([^"'\s>]*)""", text, re.IGNORECASE)


def test_page_is_self_contained(single_page):
    text = single_page
    assert text.startswith("<!DOCTYPE html>")
    # horizon segments (whole run and zoom), free run, residual clouds, correlations
    assert len(re.findall(r"data:image/png;base64,", text)) == 5
    refs = _refs(text)
    assert refs and all(r.startswith("data:image/png;base64,") for r in refs)
    assert "<link" not in text and "@import" not in text and "url(" not in text


def test_every_figure_is_labelled(single_page, single):
    text = single_page
    head = re.search(r'<p class="headline">(.*?)<br>', text).group(1)
    assert head.startswith("headline: free-run fit x ")
    assert "0.5 s horizon fit: segments restarting from the measured state" in text
    assert "Free run: measured and simulated outputs" in text
    for k in ("x", "theta"):
        assert f"free-run fit {k} (%)</td><td>{single.fit[k]:.2f}</td>" in text
        assert f"0.5 s horizon fit {k} (%)</td><td>{single.fit_horizon[k]:.2f}</td>" in text
    assert "free-run fit theta, angle wrapped (%)" in text
    assert "worst windows (residual of the free run)" in text and "cart motion" in text
    assert "whiteness (free-run residual, theta wrapped)" in text


def test_two_models_overlaid_with_changes(pair_page, pair):
    text = pair_page
    a, b = pair.labels
    assert a.startswith("A: ") and b.startswith("B: ")
    head = re.search(r'<p class="headline">(.*?)<br>', text).group(1)
    assert "A -&gt; B: the error falls" in head
    fits = [c.fit_horizon["x"] for c in pair.runs[0]]
    assert f"<td>{fits[0]:.2f}</td><td>{fits[1]:.2f}</td><td>{fits[1] - fits[0]:+.2f}</td>" in text
    assert "<th>B − A</th>" in text
    # one horizon figure pair and one free-run figure for the run, then clouds and correlations per model
    assert len(re.findall(r"data:image/png;base64,", text)) == 3 + 2 * 2
    assert text.count("worst windows (residual of the free run)") == 2


def test_written_atomically(single, tmp_path, monkeypatch, cheap_png):
    path = tmp_path / "report.html"
    path.write_text("old report")
    calls = []
    real = report_html.write_atomic
    monkeypatch.setattr(report_html, "write_atomic", lambda p, text: (calls.append(p), real(p, text)))
    write_html_report(single, path, title="run <7>")
    assert calls == [path] and "run &lt;7&gt;" in path.read_text()

    def broken(fig):
        raise RuntimeError("renderer died")
    path.write_text("old report")
    monkeypatch.setattr(report_html, "_png", broken)
    with pytest.raises(RuntimeError):
        write_html_report(single, path)
    assert path.read_text() == "old report"                      # a failed render leaves the old file
    assert [p.name for p in tmp_path.iterdir()] == ["report.html"]


def test_into_missing_folder(single, tmp_path, cheap_png):
    with pytest.raises(PendcError) as info:
        write_html_report(single, tmp_path / "missing" / "r.html")
    assert "does not exist" in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_zoom_limits_to_the_worst_stretch(single):
    fig = report_html._figure_horizon(report_html.as_side_by_side(single), (single,), zoom=True)
    t0, t1 = report_html._zoom_span(single)
    assert t1 - t0 == pytest.approx(min(report_html.ZOOM, single.simulated.t[-1]))
    for ax in fig.axes:
        assert ax.get_xlim() == pytest.approx((t0, t1))
        lo, hi = ax.get_ylim()
        assert np.isfinite(lo) and np.isfinite(hi) and hi > lo
