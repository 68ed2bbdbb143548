"""Is a residual only noise? Autocorrelation and input cross-correlation tests, as MATLAB's ``resid``.

Used by :mod:`pendc.ident.compare` on whichever residual it analyses. Each test returns
plain JSON-ready dicts: the correlation at every lag, the 99 % band, the lags outside it
and a verdict that keeps the false-alarm rate of the whole test below 5 %. The tests remove
the mean, so the residual's mean and its standard error come with them: :func:`biased` says
when a steady bias, which no correlation test sees, is beyond what the noise explains.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np

LAGS = 25                    # correlation lags, as MATLAB's resid
Z99 = 2.58                   # two-sided 99 % normal quantile
WHITENESS_DT = 0.01          # s: residual sample interval used for the correlation tests
MIN_WHITENESS_SAMPLES = 100  # decimate less than WHITENESS_DT asks when data are short


def decimate(y, q: int) -> np.ndarray:
    """Means of consecutive blocks of ``q`` samples (a trailing partial block is dropped).

    Block means are a crude but ringing-free anti-alias filter; they also smooth the
    encoder staircase, itself a fast component the whiteness test should not see."""
    n = len(y) // q * q
    return np.asarray(y[:n], dtype=np.float64).reshape(-1, q).mean(axis=1)


def allowed_outside(lags: int, p: float = 0.01, level: float = 0.05) -> int:
    """How many of ``lags`` independent 99 % tests a white signal fails, at most, in 95 % of cases.

    Demanding *every* lag inside the band would call white noise non-white one time
    in five with 25 lags (1 - 0.99^25 = 22 %); the binomial count keeps the false
    alarm below ``level``: 1 lag for 25, 2 for 51."""
    tail, k = 1.0, 0
    while True:
        tail -= math.comb(lags, k) * p**k * (1 - p) ** (lags - k)   # P(K > k)
        if tail <= level:
            return k
        k += 1


def _verdict(lags, values, band: float) -> dict:
    """Band test over ``lags``: it fails when more lags leave the 99 % band than
    :func:`allowed_outside` tolerates, or when one lag lies beyond ``limit``, the band
    widened (Bonferroni) so that white noise reaches it at any of the lags only 1 % of
    the time: a single huge spike is as damning as many small excursions."""
    z_limit = NormalDist().inv_cdf(1 - 0.005 / max(1, len(lags)))
    limit = band * z_limit / Z99
    outside = [k for k, r in zip(lags, values) if abs(r) > band]
    allowed = allowed_outside(len(lags))
    passed = len(outside) <= allowed and all(abs(r) <= limit for r in values)
    return {"band": band, "limit": limit, "outside": outside, "allowed": allowed, "passed": passed}


def _acf(e, lags: int) -> np.ndarray:
    """Normalized autocorrelation of mean-free ``e`` at lags 0..lags (biased estimator)."""
    n, energy = len(e), float(e @ e)
    if energy == 0.0:
        return np.r_[1.0, np.zeros(lags)]
    return np.array([float(e[: n - k] @ e[k:]) / energy for k in range(lags + 1)])


def autocorrelation(e, lags: int = LAGS) -> dict:
    """Normalized autocorrelation of ``e`` (mean removed) at lags 0..``lags`` and its verdict.

    ``band`` is ±2.58/sqrt(N), the 99 % interval of a white sequence; ``white`` is the
    :func:`_verdict` over lags 1..``lags``. A residual that is exactly constant has no
    structure and counts as white. The test removes the mean, so it is blind to a bias:
    ``mean``, ``std`` and ``mean_se`` (the mean's standard error) are there for :func:`biased`."""
    raw = np.asarray(e, dtype=np.float64)
    mean = float(np.mean(raw)) if raw.size else 0.0
    e = raw - mean
    n = len(e)
    lags = max(0, min(lags, n - 1))
    acf = _acf(e, lags)
    v = _verdict(range(1, lags + 1), acf[1:], Z99 / math.sqrt(n))
    white = v.pop("passed")
    return {"lags": list(range(lags + 1)), "acf": acf.tolist(), **v, "white": white, "samples": n,
            "mean": mean, "std": float(np.std(e)) if n else 0.0, "mean_se": _mean_error(e, acf)}


BIAS_SE = 5.0       # standard errors a residual's mean must reach to be no chance of the noise
BIAS_STEPS = 1.0    # sensor steps it must also reach: a reading's rounding shifts it half a step at most
BIAS_SHARE = 0.5    # with no sensor step known: the share of the residual's rms the mean must reach


def _mean_error(e: np.ndarray, acf: np.ndarray) -> float:
    """Standard error of the mean of a correlated sequence (Bartlett: s^2/N (1 + 2 sum (1 - k/N) r_k)
    over the tested lags), never taken below a white sequence's s/sqrt(N): a residual's samples
    are not independent, and a slow error must not pass for a precise mean."""
    n = len(e)
    if n == 0:
        return 0.0
    k = np.arange(1, len(acf))
    factor = max(1.0, 1.0 + 2.0 * float(np.sum((1.0 - k / n) * acf[1:])))
    return float(np.std(e)) * math.sqrt(factor / n)


def biased(a: dict, step: float | None) -> bool:
    """Whether the residual whose :func:`autocorrelation` is ``a`` has a bias the noise cannot
    explain: a mean beyond :data:`BIAS_SE` standard errors and beyond :data:`BIAS_STEPS` sensor
    steps (``step``; without one, beyond :data:`BIAS_SHARE` of the rms). A steady offset passes
    the whiteness test, which removes the mean (a hidden dead zone left 16 converter codes)."""
    mean = abs(float(a.get("mean", 0.0)))
    if mean == 0.0 or mean <= BIAS_SE * float(a.get("mean_se", 0.0)):
        return False
    if step:
        return mean > BIAS_STEPS * float(step)
    return mean >= BIAS_SHARE * math.hypot(mean, float(a.get("std", 0.0)))


def cross_correlation(e, v, lags: int = LAGS) -> dict:
    """Normalized cross-correlation ``ccf[k] = corr(e(t), v(t - k))`` for k = -lags..lags.

    k > 0 pairs the residual with *earlier* input: correlation there means the input
    drives part of the error, i.e. the model's input-to-output path is wrong. The 99 %
    band follows Bartlett (as MATLAB's resid): for independent e and v the variance of
    a lag is sum_m r_ee(m) r_vv(m) / N, which reduces to 1/N when either is white;
    it is never taken narrower than that white band."""
    e = np.asarray(e, dtype=np.float64) - np.mean(e)
    v = np.asarray(v, dtype=np.float64) - np.mean(v)
    n = len(e)
    lags = max(0, min(lags, n - 1))
    denom = math.sqrt(float(e @ e) * float(v @ v))
    ks = list(range(-lags, lags + 1))
    if denom == 0.0:
        ccf = np.zeros(len(ks))
    else:
        ccf = np.array([float(e[k:] @ v[: n - k]) if k >= 0 else float(e[: n + k] @ v[-k:]) for k in ks]) / denom
    factor = max(1.0, 1.0 + 2.0 * float(_acf(e, lags)[1:] @ _acf(v, lags)[1:]))
    verdict = _verdict(ks, ccf, Z99 * math.sqrt(factor / n))
    independent = verdict.pop("passed")
    return {"lags": ks, "ccf": ccf.tolist(), **verdict, "independent": independent, "samples": n}


INPUT_UNTESTED = {
    "missing": "the file has no u column (it was filled with a constant), so the residual cannot be tested "
               "against the input",
    "constant": "the input is constant over the run, so there is nothing to correlate the residual with",
}


def input_status(u, missing: bool = False) -> str:
    """``measured``, or why a cross-correlation with ``u`` means nothing: ``missing`` (the file
    had no u column) or ``constant`` (e.g. a free swing with the driven coordinate held and the
    input idle)."""
    if missing:
        return "missing"
    u = np.asarray(u, dtype=np.float64)
    return "constant" if u.size == 0 or float(np.ptp(u)) == 0.0 else "measured"


def untested(status: str) -> dict:
    """The cross-correlation entry of an input that cannot be tested: ``independent`` is None."""
    return {"input": status, "tested": False, "independent": None, "reason": INPUT_UNTESTED[status],
            "lags": [], "ccf": [], "outside": [], "band": None, "limit": None, "allowed": None}


def whiteness(t, residual: dict, u, input_missing: bool = False) -> dict:
    """Correlation tests of each residual, on a residual decimated to ~``WHITENESS_DT``.

    Why decimate: the data are sampled at ~1 kHz while a laboratory plant moves at ~1 Hz
    (a pendulum's 0.9 Hz swing, a servo cart's 0.12 s mechanical time constant), so at full
    rate 25 lags span 25 ms, in which any error is trivially correlated with itself. At
    10 ms a lag still resolves everything the stimuli excite (Nyquist 50 Hz) and 25 lags
    span 0.25 s, about such a time constant. Short runs are decimated less, to keep at
    least ``MIN_WHITENESS_SAMPLES``. Returns ``{output: autocorrelation + lag_seconds,
    ..., "xcorr": {output: cross-correlation with u + lag_seconds}}``. An input the file
    lacked (``input_missing``) or that never changes is not tested: its entries say so
    (``tested`` False, ``independent`` None, ``reason``) instead of calling the residual
    independent of it.
    """
    t = np.asarray(t, dtype=np.float64)
    h = float(np.median(np.diff(t)))
    q = max(1, min(int(round(WHITENESS_DT / h)), len(t) // MIN_WHITENESS_SAMPLES))
    status = input_status(u, input_missing)
    ud = decimate(u, q)
    out, xcorr = {}, {}
    for k, r in residual.items():
        rd = decimate(r, q)
        out[k] = {**autocorrelation(rd), "lag_seconds": q * h, "decimation": q}
        if status != "measured":
            xcorr[k] = {**untested(status), "lag_seconds": q * h, "decimation": q}
        else:
            xcorr[k] = {**cross_correlation(rd, ud), "input": status, "tested": True, "lag_seconds": q * h,
                        "decimation": q}
    out["xcorr"] = xcorr
    return out
