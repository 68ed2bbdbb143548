"""The lockstep loop: measure, ask the controller, hold its volts for one period, repeat.

One row per control period: the time, the measured positions the controller saw
(one per state an encoder or a sampled converter of the plant interface reads, named by that
state: :attr:`~pendc.hil.plants.core_ports.CorePorts.measured`), the volts it
answered (after the 12-bit DAC) and its mode. A run ends early, with
the rows so far and the reason, when the plant or the controller fails; the caller
writes that partial record, it never silently continues.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import PendcError
from ..model.interface import unit_key
from .controllers.measurement import Measurement, wrap_upright

DAC_BITS = 12
UPRIGHT_TOLERANCE = 0.05   # rad: "upright" for the summary and the scenarios


def dac(volts: float, span: tuple, bits: int = DAC_BITS) -> float:
    """Clamp to ``span`` (the input's low and high) and quantise to the nearest code of a
    ``bits``-bit DAC over it."""
    if not math.isfinite(volts):
        raise PendcError(f"the controller answered {volts!r} volts")
    lo, hi = span
    levels = 2**bits - 1
    code = round((min(max(volts, lo), hi) - lo) / (hi - lo) * levels)
    return lo + code * (hi - lo) / levels


@dataclass(frozen=True)
class HilRun:
    """A closed-loop run: per-period columns and how it ended (``stopped`` is None if complete).

    ``u`` is the plant input the controller answered (the interface's input, named
    ``input_name``), ``positions`` the measured positions ``(state, column)`` in the interface's
    sensor order (encoders', then converters') (each also reads as ``run.<state>``), ``units`` their units and ``angle`` the
    measured periodic state whose upright the summary reports (None: no such state)."""

    t: np.ndarray
    u: np.ndarray
    positions: tuple
    mode: tuple
    plant: str
    wall_s: float
    seconds: float
    stopped: str | None = None
    extra: dict = field(default_factory=dict)
    input_name: str = ""
    units: tuple = ()
    angle: str | None = None

    def __getattr__(self, name: str):
        # only reached when ordinary lookup fails: a measured state's column
        for key, column in self.__dict__.get("positions", ()):
            if key == name:
                return column
        raise AttributeError(f"the run has no column '{name}'")

    def column(self, state: str) -> np.ndarray:
        """The measured position of ``state`` per period."""
        return dict(self.positions)[state]

    def summary(self) -> dict:
        """The figures of merit written to summary.json: the upright stretch of ``angle``,
        ``max_abs_<state>_<unit>`` of every measured state, controller switches, timing."""
        angle = self.column(self.angle) if self.angle else np.zeros(0)
        phi = np.array([wrap_upright(th) for th in angle])
        up_at, rms = upright_stretch(self.t, phi) if self.angle else (None, None)
        switches = sum(1 for a, b in zip(self.mode, self.mode[1:]) if a != b)
        units = dict(self.units)
        out = {
            "upright_at_s": up_at,
            "balance_rms_rad": rms,
        }
        for state, column in self.positions:
            key = unit_key(f"max_abs_{state}", units.get(state, ""))
            out[key] = float(np.max(np.abs(column))) if column.size else None
        out.update({
            "switches": switches,
            "plant": self.plant,
            "wall_s": round(self.wall_s, 3),
            "seconds": self.seconds,
            "rows": int(self.t.size),
            "completed": self.stopped is None,
        })
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
                    progress=None, answer=None, count_origin: dict | None = None) -> HilRun:
    """Run ``controller`` against ``plant`` for ``seconds`` (one row per period).

    ``answer(measurement) -> volts`` replaces ``controller.step`` (the socket server
    uses it); ``progress(fraction)`` is called now and then. The DAC spans the controller's
    ``input_range`` (low and high) if it declares one, else the range of the plant's input (its ports').
    ``count_origin`` ({encoder: count}, :func:`pendc.hil.plants.plant.start_counts`) is added to every
    count since reset, so a plant started elsewhere than at 0 is measured from the grid's zero
    (as a rig with homed encoders is). A :class:`PendcError` from
    the plant or the controller ends the run: the result keeps the rows so far and
    says why in ``stopped``.
    """
    if not (math.isfinite(seconds) and seconds > 0):
        raise PendcError(f"--seconds must be a positive number, got {seconds}")
    n_sub = steps_per_period(plant.dt, period)
    n_rows = int(round(seconds / period)) + 1
    step = answer if answer is not None else controller.step
    span = tuple(getattr(controller, "input_range", None) or plant.ports.input_range)
    ports = plant.ports
    t = np.empty(n_rows)
    u = np.empty(n_rows)
    measured = ports.measured
    pos = np.empty((len(measured), n_rows))
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
            meas = Measurement.of(k * period, state, ports, count_origin)
            volts = dac(float(step(meas)), span=span)
            t[k], u[k] = meas.t, volts
            for i, name in enumerate(measured):
                pos[i, k] = meas.position(name)
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
    return HilRun(t=t[:rows].copy(), u=u[:rows].copy(),
                  positions=tuple((name, pos[i, :rows].copy()) for i, name in enumerate(measured)),
                  mode=tuple(modes), plant=plant_name, wall_s=time.perf_counter() - start,
                  seconds=float(seconds), stopped=stopped,
                  extra={"plant_build": plant.describe()} if hasattr(plant, "describe") else {},
                  input_name=ports.input, units=tuple((name, sensor_unit(ports, name)) for name in measured)
                  + ((ports.input, ports.input_unit),),
                  angle=upright_angle(ports, getattr(plant, "model", None)))


def sensor_unit(ports, state: str) -> str:
    """The unit of measured ``state`` (its encoder's, else its converter's)."""
    sensor = ports.encoder_of(state) or ports.adc_of(state)
    return sensor.unit if sensor is not None else ""


def upright_angle(ports, model=None) -> str | None:
    """The measured angle whose upright a run's summary reports: of the encoder-read periodic
    states, the pendulum (:func:`~pendc.hil.controllers.pendulum_roles.pendulum_roles`: gravity
    restores it and the input does not drive it, whichever the file declares first), else the
    last one the input does not drive, else the last one (the pendulum after any arm), or None."""
    angles = [e.state for e in ports.encoders if e.periodic]
    if model is not None and len(angles) > 1:
        from .controllers.pendulum_roles import driven_positions, pendulum_roles
        try:
            pendulum = pendulum_roles(model).pendulum.position
        except PendcError:
            driven = driven_positions(model)
            pendulum = next((a for a in reversed(angles) if a not in driven), None)
        if pendulum in angles:
            return pendulum
    return angles[-1] if angles else None
