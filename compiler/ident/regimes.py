"""Operating regimes: where in the plant's state and input space the residual concentrates.

Each partition splits the run's samples into regimes that cover every sample exactly once,
classified on the *measured* motion (a wrong model must not decide which regime the real
rig was in). The partitions are read off the plant interface:

* **<body> motion** for the position the drive moves (else the first; e.g. a cart's or a rotary arm's): standing,
  moving + or - (its rate below or beyond ``STANDSTILL`` of its unit: static friction's realm);
* **<body> angle** for the last periodic position the drive does not move (e.g. a pendulum's): small or large swing
  from its zero (``SMALL_SWING``: sin(q) ~ q still holds within 1.5 %);
* **drive**: the input near or far from its centre (where the model's drive law pushes
  nothing at rest, e.g. a servo drive's offset voltage, else the middle of the input's
  range; ``LOW_DRIVE``: about the static break-away input of a laboratory cart, 0.40 V; an
  input whose range spans less than ``REFERENCE_SPAN`` units takes that share of it, so a 0-1
  duty cycle's is 0.05);
* **<position> position** for a translation (e.g. a cart on its track): centre or near an
  end (``TRACK_END`` of its unit: the outer third of each half of a 750 mm track);
* **input saturation**: the input within ``SATURATION_MARGIN`` of the span of the range its
  actuator takes (the plant file's ``[inputs]`` range) from either end, or not.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.interface import with_unit
from ..sim.signals import signals_of
from ..sim.stimuli import REFERENCE_SPAN
from .plant_roles import driven_coordinate

STANDSTILL = {"m/s": 0.005, "rad/s": 0.05}   # per rate unit: below this the body counts as standing
SMALL_SWING = 0.3            # rad from the angle's zero
LOW_DRIVE = 0.5              # input units from its centre (of a range spanning REFERENCE_SPAN or more)
TRACK_END = {"m": 0.25}      # per position unit: beyond this the body is near an end of its travel
SATURATION_MARGIN = 0.005    # fraction of the input range's span
CENTRE_NAME = "input_centre"  # what reports call the input's centre when no parameter holds it


def wrap_angle(angle, period: float = 2 * math.pi):
    """An angle folded into [-period/2, period/2): a whole turn is the same position again."""
    return (np.asarray(angle, dtype=np.float64) + period / 2) % period - period / 2


def input_centre(model) -> float:
    """The input the plant rests at: where the model's drive law pushes nothing at rest
    (:func:`~pendc.ident.plant_roles.drive_offset`: a drive's offset parameter, 0 for a law
    without one), else the input's ``neutral`` (the file's, else 0 or the middle of its range)."""
    return centre_and_name(model)[0]


def centre_and_name(model) -> tuple:
    """``(value, name)`` of :func:`input_centre`: the name of the parameter that holds it, else
    :data:`CENTRE_NAME`."""
    from .plant_roles import drive_offset

    found = drive_offset(model)
    if found is not None:
        return found[0], found[1] or CENTRE_NAME
    return model.interface.input.neutral, CENTRE_NAME


def saturation_limits(drive) -> tuple:
    """``(low, high)``: an input at or below ``low`` or at or above ``high`` is saturated,
    within ``SATURATION_MARGIN`` of the span of the range ``drive`` (an
    :class:`~pendc.model.interface.InputRange`) from either end."""
    margin = SATURATION_MARGIN * drive.span
    return drive.lo + margin, drive.hi - margin


def _number(value: float, unit: str) -> str:
    """``5 mm/s`` for small lengths, else the value in its own unit."""
    if unit.startswith("m") and not unit.startswith("mm") and abs(value) < 0.1:
        return f"{value * 1e3:g} m{unit}"
    return with_unit(f"{value:g}", unit)


def swing_angle(plant) -> str | None:
    """The periodic position whose swing the reports follow: the last one the drive does not move
    (a pendulum's angle, whatever the order of the file's coordinates: a reaction wheel declared
    after its pendulum is driven), else the last periodic one, else None."""
    sig = signals_of(plant)
    driven = driven_coordinate(plant) if hasattr(plant, "catalogue") else None
    free = [p for p in sig.periodic if p != driven]
    return free[-1] if free else (sig.periodic[-1] if sig.periodic else None)


def low_drive_of(drive) -> float:
    """The weak-drive bound of an input whose range is ``drive``: ``LOW_DRIVE``, or its share of a
    span narrower than ``REFERENCE_SPAN`` (every sample of a 0-1 duty cycle was 'weak' at 0.5)."""
    return LOW_DRIVE * min(1.0, drive.span / REFERENCE_SPAN)


def regime_partitions(plant, measured: dict, u, centre: float, skip=(), centre_name: str = CENTRE_NAME) -> list:
    """``[(partition, [(name, definition, mask), ...]), ...]``; each partition's masks cover
    every sample exactly once. ``measured`` holds the data's positions and rates by state name
    (absent ones are not partitioned); ``plant`` is a model or its interface; partitions named
    in ``skip`` are left out; ``centre`` is the input's centre (:func:`input_centre`), which
    the definitions call ``centre_name``."""
    sig = signals_of(plant)
    spec = sig.interface.input
    u = np.asarray(u, dtype=np.float64)
    out = []
    # the coordinate the drive moves leads (a reaction wheel declared after its pendulum too);
    # the swing is the last periodic position it does not move
    driven = driven_coordinate(plant) if hasattr(plant, "catalogue") else None
    lead = driven if driven in sig.positions else sig.positions[0]
    rate = sig.rate(lead)
    if rate is not None and rate in measured and sig.unit(rate) in STANDSTILL:
        v, still = np.asarray(measured[rate], dtype=np.float64), STANDSTILL[sig.unit(rate)]
        s = _number(still, sig.unit(rate))
        out.append((f"{sig.body_of(lead)} motion", [
            ("standstill", f"|{rate}| < {s}", np.abs(v) < still),
            (f"moving +{lead}", f"{rate} >= {s}", v >= still),
            (f"moving -{lead}", f"{rate} <= -{s}", v <= -still)]))
    swing = swing_angle(plant)
    if swing is not None and swing in measured:
        th = np.abs(wrap_angle(measured[swing], sig.period(swing)))
        zero = sig.spec(swing).meaning.split(" from ", 1)[1].split(" (")[0] if " from " in sig.spec(swing).meaning \
            else "its zero"
        small = with_unit(f"{SMALL_SWING:g}", sig.unit(swing))
        out.append((f"{sig.body_of(swing)} angle", [
            ("small swing", f"|{swing}| < {small} from {zero}", th < SMALL_SWING),
            ("large swing", f"|{swing}| >= {small}", th >= SMALL_SWING)]))
    e = np.abs(u - centre)
    name = spec.name
    about = f"|{name} - {centre_name}|" if centre else f"|{name}|"
    where = f", {centre_name} = {with_unit(f'{centre:.4g}', spec.unit)}" if centre else ""
    low_drive = low_drive_of(spec.range)
    weak = with_unit(f"{low_drive:g}", spec.unit)
    out.append(("drive", [
        ("weak drive", f"{about} < {weak}{where}", e < low_drive),
        ("strong drive", f"{about} >= {weak}", e >= low_drive)]))
    for p in [p for p in sig.positions if sig.period(p) is None and p in measured and sig.unit(p) in TRACK_END]:
        end = TRACK_END[sig.unit(p)]
        x = np.abs(np.asarray(measured[p], dtype=np.float64))
        out.append(("track position" if p == lead else f"{p} position", [
            ("centre", f"|{p}| <= {with_unit(f'{end:g}', sig.unit(p))}", x <= end),
            ("near an end", f"|{p}| > {with_unit(f'{end:g}', sig.unit(p))}", x > end)]))
    low, high = saturation_limits(spec.range)
    sat = (u <= low) | (u >= high)
    out.append(("input saturation", [
        ("saturated", with_unit(f"{name} <= {low:g} or >= {high:g}", spec.unit), sat),
        ("in range", with_unit(f"{low:g} < {name} < {high:g}", spec.unit), ~sat)]))
    return [(p, members) for p, members in out if p not in skip]


def regimes(residual: dict, partitions: list) -> list:
    """Share of each output's squared residual per regime, next to the share of time.

    Entries: ``partition, name, definition, output, share, rms, fraction_of_time,
    samples``; within one partition and output the shares add up to 1 (all 0 when
    the residual is exactly zero) and so do the time fractions. ``rms`` is None for
    a regime the run never entered. Samples count equally (uniform sampling assumed,
    as in fit%). ``partitions`` come from :func:`regime_partitions`.
    """
    out = []
    for partition, members in partitions:
        for output, r in residual.items():
            sq = np.asarray(r, dtype=np.float64) ** 2
            total, n = float(sq.sum()), sq.size
            for name, definition, mask in members:
                k = int(mask.sum())
                part = float(sq[mask].sum())
                out.append({"partition": partition, "name": name, "definition": definition, "output": output,
                            "share": part / total if total > 0 else 0.0,
                            "rms": math.sqrt(part / k) if k else None,
                            "fraction_of_time": k / n, "samples": k})
    return out
