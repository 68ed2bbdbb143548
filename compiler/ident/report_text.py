"""Plain-text reports of ``pendc compare``: one model on one run, or several side by side.

The first line is always the headline: which fit figure leads, its values, and (next
line) why that metric was chosen. Every figure after it says what it is: free-run fit,
horizon fit (with its horizon), wrapped-angle fit, and which residual the windows,
regimes and whiteness tests examine. This module imports :mod:`pendc.ident.compare`,
never the other way round.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.sensors import ConverterStep
from ..sim.signals import signals_of
from . import headline as hl
from .compare import WORST_WINDOW, Comparison, model_name
from .sidebyside import SideBySide, as_side_by_side
from .units import amount_in, labelled, table_digits, unit_of
from .whiteness import biased

FEW_COUNTS = 5           # rms residual (encoder counts) below which structure may be rounding
ALWAYS = 0.99            # a regime covering this much of the run tells nothing; the text skips it


def concentrated(regime: dict) -> bool:
    """Worth pointing at: the regime holds a fifth of the error or more, at 1.5x its share of time."""
    f = regime["fraction_of_time"]
    return f > 0 and regime["share"] >= 0.2 and regime["share"] / f >= 1.5


def amount(output: str, value, plant=None) -> str:
    """A value of ``output`` (of ``plant``, default the default model) in its unit: a length in
    mm, an angle in mrad below 1 rad and in rad above."""
    return amount_in(unit_of(plant, output), value)


def percent(value) -> str:
    """A fit% with two decimals, or ``undefined`` (a constant measured output)."""
    return f"{value:.2f} %" if value is not None and math.isfinite(value) else "undefined"


def fits_words(fits: dict) -> str:
    """``<output> 94.55 %, <output> 99.76 %`` (each output's name and fit)."""
    return ", ".join(f"{k} {percent(v)}" for k, v in fits.items())


def trend(before: dict, after: dict) -> str:
    """``the error falls`` / ``rises`` / ``is mixed`` / ``is unchanged`` from one model's fit% to another's."""
    deltas = [after[k] - before[k] for k in before if math.isfinite(before[k]) and math.isfinite(after.get(k, math.nan))]
    if not deltas or all(abs(d) < 0.005 for d in deltas):
        return "the error is unchanged"
    if all(d >= 0 for d in deltas):
        return "the error falls"
    if all(d <= 0 for d in deltas):
        return "the error rises"
    return "mixed: " + ", ".join(f"{k} {'better' if after[k] > before[k] else 'worse'}" for k in before
                                 if math.isfinite(before[k]) and math.isfinite(after.get(k, math.nan)))


def format_text(c: Comparison) -> str:
    """The report of one model on one run: headline first, then every labelled figure and the analyses."""
    h = c.headline
    lines = [f"headline: {h.label} {fits_words(c.headline_fit())}  ({c.data_source or '(data)'}, "
             f"model {model_name(c.model)})", f"  why: {h.reason}", ""]
    lines += _figures(c) + [""] + _analyses(c)
    return "\n".join(lines) + "\n"


def _figures(c: Comparison) -> list:
    """Free-run and horizon fits with their labels, the turn note and the wrapped figure."""
    free = [f"free-run fit (one simulation from the data's initial state, {c.method} step {c.dt:g} s, "
            f"experiment {c.experiment}): {fits_words(c.fit)}"]
    rms = c.rms_free_run()
    for k in c.outputs:
        spread = float(np.std(c.measured[k]))
        free.append(f"  {k:5s} rms error {amount(k, rms[k], c.model)} (data spread {amount(k, spread, c.model)})")
    a = c.angle
    if c.turns:
        body = signals_of(c.model).body_of(a)
        free.append(f"  {a}: the simulated {body} ends up {c.turns} whole turn{'s' if c.turns > 1 else ''} "
                    f"away from the measured one (first at t = {c.turn_time:.2f} s); the free-run fit counts "
                    f"each extra turn as 2π of error")
    if a in c.outputs and (c.turns or abs(c.fit_wrapped - c.fit[a]) >= 0.005):
        free.append(f"  {a} with the angle error wrapped to (-π, π]: free-run fit {percent(c.fit_wrapped)}, "
                    f"rms error {amount(a, rms[f'{a}_wrapped'], c.model)}")
    horizon = [f"{hl.horizon_label(c.horizon)} (restarting every {c.horizon:g} s from the measured state; the "
               f"figure diagnose and fit report): {fits_words(c.fit_horizon)}"]
    band = c.band.lines() if c.band is not None else []
    return (horizon + free if h_is_horizon(c) else free + horizon) + band


def h_is_horizon(c: Comparison) -> bool:
    """Whether the headline of ``c`` is the horizon fit."""
    return c.headline is not None and c.headline.metric == hl.HORIZON


def _analyses(c: Comparison) -> list:
    """Worst windows, regimes and whiteness of ``c.residual``, saying which residual that is."""
    of = f"(residual of the {c.residual_of})"
    lines = [f"Worst {WORST_WINDOW:g} s windows {of}, largest rms error first:"]
    for k in c.outputs:
        for w in (w for w in c.windows if w["output"] == k):
            lines.append(f"  {k:5s} {w['t0']:8.2f} - {w['t1']:8.2f} s   rms {amount(k, w['rms'], c.model):>11s}   "
                         f"{100 * w['share']:5.1f} % of the {k} error")
    lines += ["", f"Where the error is {of}: share of the squared error vs share of time; "
              "a ratio well above 1 means the error concentrates there:"]
    for k in c.outputs:
        rows = sorted((g for g in c.regimes if g["output"] == k and 0 < g["fraction_of_time"] < ALWAYS),
                      key=lambda g: -g["share"])
        lines += [f"  {k:5s} {100 * g['share']:5.1f} % of the error in {100 * g['fraction_of_time']:5.1f} % of the "
                  f"time: {g['name']} ({g['definition']}), ratio {g['share'] / g['fraction_of_time']:.2f}"
                  + ("  <- concentrated" if concentrated(g) else "") for g in rows]
    first = [g for g in c.regimes if g["output"] == c.outputs[0]]
    always = ", ".join(g["name"] for g in first if g["fraction_of_time"] >= ALWAYS)
    never = ", ".join(g["name"] for g in first if not g["samples"])
    notes = ([f"all or nearly all the run: {always}"] if always else []) + ([f"never: {never}"] if never else [])
    if notes:
        lines.append(f"  ({'; '.join(notes)})")
    wrapped = f", {c.angle} wrapped" if c.angle in c.outputs else ""
    lines += ["", f"Is what is left noise? (free-run residual{wrapped}), 99 % bands, residual sampled every "
              f"{duration_text(c.whiteness[c.outputs[0]]['lag_seconds'])}"]
    if h_is_horizon(c):
        lines.append("  caution: the free run is not meaningful on these data (see the headline), so these "
                     "verdicts describe its divergence more than the model")
    rms = c.rms_free_run()
    for k in c.outputs:
        lines += whiteness_words(k, c.whiteness[k], c.whiteness["xcorr"][k],
                                 rms[f"{k}_wrapped" if k == c.angle else k], c.model)
    return lines


def duration_text(seconds: float) -> str:
    """A lag in words: milliseconds below a second, seconds from there (a heater's minutes)."""
    return f"{1e3 * seconds:.3g} ms" if abs(seconds) < 1.0 else f"{seconds:.3g} s"


def whiteness_words(k: str, a: dict, xc: dict, rms: float, plant=None) -> list:
    """The verdicts of one output's autocorrelation ``a`` and input cross-correlation ``xc``
    (``plant``: whose encoder count on ``k`` says what is rounding; default the default model)."""
    step = a["lag_seconds"]
    count = signals_of(plant).resolution(k)
    sensor = "converter" if isinstance(count, ConverterStep) else "encoder"
    unit = "codes" if sensor == "converter" else "counts"
    bias = biased(a, count)
    out = [_bias_line(k, a, count, f"{sensor} {unit}", plant)] if bias else []
    if a["white"]:
        out.append("        around that bias the residual looks white" if out else
                   f"  {k:5s} residual looks white: only noise is left to explain")
    else:
        lag = max(a["outside"] or a["lags"][1:], key=lambda j: abs(a["acf"][j]))
        out.append(f"  {k:5s} residual is not white: {len(a['outside'])} of {len(a['lags']) - 1} lags outside the band "
                   f"(r = {a['acf'][lag]:+.2f} at {duration_text(lag * step)}): the error is systematic, the model misses "
                   "or mis-sets some dynamics")
        # the test sees the scatter about the mean, which a bias would hide in the rms
        scatter = math.sqrt(max(rms * rms - float(a["mean"]) ** 2, 0.0)) if bias else rms
        counts = scatter / float(count) if count else math.inf
        if counts < FEW_COUNTS:   # a whiteness test sees structure far below what matters
            out.append(f"        but it is only {counts:.1f} {sensor} {unit} rms{' about that bias' if bias else ''}: "
                       f"at this level the structure may be the {sensor}'s rounding or the integration step")
    if not xc.get("tested", True):
        return out + [f"  {k:5s} residual against the input: not tested: {xc['reason']}"]
    if xc["independent"]:
        return out + [f"  {k:5s} residual shows no significant correlation with the input"]
    mid = len(xc["lags"]) // 2
    lag = max(xc["outside"] or xc["lags"], key=lambda j: abs(xc["ccf"][j + mid]))
    when = (f"the input {duration_text(lag * step)} earlier" if lag >= 0
            else f"the input {duration_text(-lag * step)} later, i.e. feedback or a slow drift")
    return out + [f"  {k:5s} residual follows the input: {len(xc['outside'])} of {len(xc['lags'])} lags outside the "
                  f"band (r = {xc['ccf'][lag + mid]:+.2f} with {when}): the drive, friction or delay is wrong"]


def _bias_line(k: str, a: dict, count, steps: str, plant) -> str:
    """The verdict on a residual :func:`biased` calls biased: its size, in sensor steps and in
    standard errors of the mean, and which side of the model the data sit."""
    mean, se = float(a["mean"]), float(a["mean_se"])
    sizes = ([f"{abs(mean) / float(count):.1f} {steps}"] if count else []) + \
        ([f"{abs(mean) / se:.0f} standard errors of its mean"] if se > 0 else ["constant"])
    return (f"  {k:5s} residual has a bias of {amount(k, mean, plant)} ({', '.join(sizes)}) that the model does not "
            f"explain: the data sit {'above' if mean > 0 else 'below'} the model, which noise does not do (an offset, "
            f"a gain, or a missing effect that shifts the working point)")


def short(label: str) -> str:
    """A model's short name: the letter of ``A: stem``, else the whole label."""
    return label.split(":")[0] if ":" in label else label


def side_by_side_headline(s: SideBySide, i: int) -> list:
    """The two first lines of run ``i``: the shared headline with every model's value and the trend."""
    h, j = s.headline(i)
    fits = s.headline_fits(i)
    data = s.runs[i][0].data_source or "(data)"
    if len(fits) == 1:
        return [f"headline: {h.label} {fits_words(fits[0])}  ({data}, model {model_name(s.runs[i][0].model)})",
                f"  why: {h.reason}"]
    per_output = []
    for k in fits[0]:
        values = " -> ".join(percent(f[k]) for f in fits)
        per_output.append(f"{k} {values}")
    trends = "; ".join(f"{short(s.labels[0])} -> {short(lab)}: {trend(fits[0], f)}"
                       for lab, f in zip(s.labels[1:], fits[1:]))
    return [f"headline: {h.label} on {data}, {' -> '.join(s.labels)}: {', '.join(per_output)} ({trends})",
            f"  why: {h.reason} (model {s.labels[j]})"]


def format_side_by_side(s: SideBySide) -> str:
    """Several models (and/or several runs): per run the headline, a table of every figure per
    model with the change from the first model, then each model's own report."""
    if len(s.labels) == 1 and len(s.runs) == 1:
        return format_text(s.runs[0][0])
    lines = []
    for i, cs in enumerate(s.runs):
        lines += side_by_side_headline(s, i) + [""]
        if len(s.labels) > 1:
            lines += _table(s, i) + [""]
            lines += ["models: " + "; ".join(f"{lab} = {model_name(c.model)}" for lab, c in zip(s.labels, cs)), ""]
        for lab, c in zip(s.labels, cs):
            lines += [f"--- {lab} on {c.data_source or '(data)'} ---"] + _figures(c) + [""] + _analyses(c) + [""]
    return "\n".join(lines).rstrip("\n") + "\n"


def _table(s: SideBySide, i: int) -> list:
    """Fixed-width table: figure, one column per model, the change of each later model from the first."""
    rows = s.rows(i)
    first = max(len(labelled(name, unit)) for name, unit, _ in rows)
    width = max(12, *(len(lab) for lab in s.labels))
    changes = [f"{short(lab)} - {short(s.labels[0])}" for lab in s.labels[1:]]
    head = f"{'figure':{first}s}  " + "  ".join(f"{lab:>{width}s}" for lab in s.labels) + "  " + \
        "  ".join(f"{ch:>{max(9, len(ch))}s}" for ch in changes)
    out = [head]
    for name, unit, values in rows:
        label = labelled(name, unit)
        digits = table_digits(values, unit)
        cells = "  ".join(f"{_num(v, digits=digits):>{width}s}" for v in values)
        delta = "  ".join(f"{_num(v - values[0], sign=True, digits=digits):>{max(9, len(ch))}s}"
                          for v, ch in zip(values[1:], changes))
        out.append(f"{label:{first}s}  {cells}  {delta}")
    return out


def _num(v, sign: bool = False, digits: int = 2) -> str:
    """A table cell: fixed decimals, ``n/a`` for an undefined figure."""
    if v is None or not math.isfinite(v):
        return "n/a"
    return f"{v:+.{digits}f}" if sign else f"{v:.{digits}f}"


def text_report(c) -> str:
    """The report of a :class:`Comparison` or a :class:`SideBySide`."""
    return format_side_by_side(c if isinstance(c, SideBySide) else as_side_by_side(c))
