"""The lockstep loop: measure, ask the controller, hold its volts for one period, repeat.

One row per control period: the time, the encoder-derived x and theta the controller
saw, the volts it answered (after the 12-bit DAC) and its mode. A run ends early, with
the rows so far and the reason, when the plant or the controller fails; the caller
writes that partial record, it never silently continues.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import PendcError
from .controllers import U_MAX, U_MIN, Measurement, wrap_upright

DAC_BITS = 12
UPRIGHT_TOLERANCE = 0.05   # rad: "upright" for the summary and the scenarios


def dac(volts: float, bits: int = DAC_BITS) -> float:
    """Clamp to 0-10 V and quantise to the nearest code of a ``bits``-bit DAC."""
    if not math.isfinite(volts):
        raise PendcError(f"the controller answered {volts!r} volts")
    levels = 2**bits - 1
    code = round(min(max(volts, U_MIN), U_MAX) / (U_MAX - U_MIN) * levels)
    return U_MIN + code * (U_MAX - U_MIN) / levels


@dataclass(frozen=True)
class HilRun:
    """A closed-loop run: per-period columns and how it ended (``stopped`` is None if complete)."""

    t: np.ndarray
    u: np.ndarray
    x: np.ndarray
    theta: np.ndarray
    mode: tuple
    plant: str
    wall_s: float
    seconds: float
    stopped: str | None = None
    extra: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """The figures of merit written to summary.json."""
        phi = np.array([wrap_upright(th) for th in self.theta])
        up_at, rms = upright_stretch(self.t, phi)
        switches = sum(1 for a, b in zip(self.mode, self.mode[1:]) if a != b)
        out = {
            "upright_at_s": up_at,
            "balance_rms_rad": rms,
            "max_abs_x_m": float(np.max(np.abs(self.x))) if self.x.size else None,
            "switches": switches,
            "plant": self.plant,
            "wall_s": round(self.wall_s, 3),
            "seconds": self.seconds,
            "rows": int(self.t.size),
            "completed": self.stopped is None,
        }
        if self.stopped is not None:
            out["stopped"] = self.stopped
        out.update(self.extra)
        return out


def upright_stretch(t: np.ndarray, phi: np.ndarray, tol: float = UPRIGHT_TOLERANCE):
    """Start time and RMS angle of the final stretch with |phi| < tol, or (None, None) if
    the run does not end upright."""
    if phi.size == 0 or abs(phi[-1]) >= tol:
        return None, None
    outside = np.flatnonzero(np.abs(phi) >= tol)
    first = int(outside[-1]) + 1 if outside.size else 0
    return float(t[first]), float(np.sqrt(np.mean(phi[first:] ** 2)))


def steps_per_period(plant_dt: float, period: float) -> int:
    """Model steps in one control period; the period must be a whole number of them."""
    if not (math.isfinite(period) and period > 0):
        raise PendcError(f"control period must be a positive number of seconds, got {period}")
    n = round(period / plant_dt)
    if n < 1 or abs(n * plant_dt - period) > 1e-9 * period:
        raise PendcError(f"control period {period:g} s is not a whole number of plant steps of {plant_dt:g} s")
    return n


def run_closed_loop(plant, controller, seconds: float, period: float = 1e-3, plant_name: str = "",
                    progress=None, answer=None) -> HilRun:
    """Run ``controller`` against ``plant`` for ``seconds`` (one row per period).

    ``answer(measurement) -> volts`` replaces ``controller.step`` (the socket server
    uses it); ``progress(fraction)`` is called now and then. A :class:`PendcError` from
    the plant or the controller ends the run: the result keeps the rows so far and
    says why in ``stopped``.
    """
    if not (math.isfinite(seconds) and seconds > 0):
        raise PendcError(f"--seconds must be a positive number, got {seconds}")
    n_sub = steps_per_period(plant.dt, period)
    n_rows = int(round(seconds / period)) + 1
    step = answer if answer is not None else controller.step
    t = np.empty(n_rows)
    u = np.empty(n_rows)
    x = np.empty(n_rows)
    theta = np.empty(n_rows)
    modes = []
    stopped = None
    start = time.perf_counter()
    state = plant.reset()
    if controller is not None:
        controller.reset()
    k = 0
    report_every = max(1, n_rows // 100)
    try:
        for k in range(n_rows):
            meas = Measurement(t=k * period, enc_x=int(state.enc_x), enc_theta=int(state.enc_theta))
            volts = dac(float(step(meas)))
            t[k], u[k], x[k], theta[k] = meas.t, volts, meas.x, meas.theta
            modes.append(str(getattr(controller, "mode", "user")) if controller is not None else "external")
            if progress is not None and k % report_every == 0:
                progress(k / n_rows)
            if k + 1 < n_rows:
                state = plant.step(volts, n_sub)
        k = n_rows
    except PendcError as exc:
        stopped = f"t = {k * period:.6g} s: {exc}"
    except Exception as exc:   # noqa: BLE001 -- a user's controller may fail in any way; the run stops cleanly
        stopped = f"t = {k * period:.6g} s: the controller failed: {type(exc).__name__}: {exc}"
    if progress is not None:
        progress(1.0)
    rows = len(modes)
    return HilRun(t=t[:rows].copy(), u=u[:rows].copy(), x=x[:rows].copy(), theta=theta[:rows].copy(),
                  mode=tuple(modes), plant=plant_name, wall_s=time.perf_counter() - start,
                  seconds=float(seconds), stopped=stopped,
                  extra={"plant_build": plant.describe()} if hasattr(plant, "describe") else {})
