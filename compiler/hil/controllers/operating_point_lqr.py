"""A discrete LQR about a named operating point of any plant file (``[operating_points]``).

Nothing here knows a plant. The operating point names some states' values (expressions of
the file's constants: ``top = { q1 = "pi", q2 = "0" }``); the states it does not name
are 0. The input that holds the plant there comes from the model's own equations: the
derivatives are affine in the input for the catalogue's drive laws, so two evaluations give
them as ``d0 + b u`` and the hold input is the least-squares ``u`` of ``d0 + b u = 0`` (a
one-line error if that leaves a derivative non-zero: nothing holds the plant there). Dry
friction jumps at zero rate and a sticking rule would make a coordinate look immovable, so,
as :mod:`pendc.hil.controllers.linearize` does for the pendulums, every evaluation is the mean of the
plant with all its rates slowly positive and slowly negative: the Coulomb jumps cancel, the
slopes stay. A and B are the model's Jacobian there (:class:`~pendc.hil.controllers.numeric_model.NumericModel`;
B the mean slope over ``u* +- span/40``, so a dead zone's edges count), sampled exactly at
the control period (zero-order hold), and the gain is the discrete LQR with

* Q from the states' units: a position 1/(0.01 m)^2 or 1/(0.02 rad)^2 (another unit:
  1/(0.01 unit)^2), a rate 1/(0.5 unit/s)^2, any other state 1e-6;
* R = 1/(span/10)^2 from the input's range (1/(2 V)^2 for +-10 V);
* either overridden by name (``excursions``, ``pendc hil --excursion q1=0.05,dq1=2,tau=0.5``):
  each the acceptable excursion of that position, rate or input in its unit (Bryson's rule).

The controller sees what a rig's controller sees: the measured positions (encoders' and
sampled converters', :attr:`~pendc.hil.plants.core_ports.CorePorts.measured`) and their filtered
differences (:class:`~pendc.hil.controllers.measurement.FilteredDifference`). So every state of the model
must be a measured position or the rate of one (a one-line error names the state it cannot
see), and the linearisation must be controllable (checked, one-line error otherwise).
Periodic positions are wrapped about the operating point's value.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import sympy as sp

from ...errors import PendcError
from ...model.interface import with_unit
from ...model.plant import PlantModel
from .measurement import FilteredDifference, Measurement
from ..plants.core_ports import CorePorts
from .numeric_model import NumericModel

EPS_RATE = 1e-6            # "moving slowly" (each rate's unit) for the one-sided evaluations
Q_POSITION = {"m": 0.01, "rad": 0.02}   # acceptable excursion of a position, by unit
Q_POSITION_OTHER = 0.01    # ... of a position in any other unit
Q_RATE = 0.5               # acceptable excursion of a rate (its unit)
Q_OTHER = 1e-6             # weight of any other state
R_FRACTION = 0.1           # acceptable input excursion, as a fraction of the input's span
HOLD_TOLERANCE = 1e-6      # relative residual of the hold input's least squares
CONTROLLABLE_TOLERANCE = 1e-9
VELOCITY_TAU = 0.02        # s: the rate filter (a coarse encoder's one count must not kick the input)


def operating_point_names(model: PlantModel) -> tuple:
    """The names of the plant file's operating points, in the file's order."""
    return tuple(model.definition.operating_points) if model.definition is not None else ()


def operating_state(model: PlantModel, point: str | None = None) -> tuple[str, dict]:
    """``(name, {state: value})`` of operating point ``point`` (None: the file's first) over every
    state of the model's equations (the ones it does not name at 0)."""
    names = operating_point_names(model)
    where = f"plant '{model.interface.name}'"
    if not names:
        raise PendcError(f"{where} declares no [operating_points]: no point to hold (try --controller hold)")
    name = names[0] if point is None else point
    if name not in names:
        raise PendcError(f"{where} has no operating point '{name}' (it has {', '.join(names)})")
    values = model.parameter_values()
    symbols = {k: sp.Symbol(k, real=True) for k in values}
    states = [s.name for s in model.equations.states]
    out = {s: 0.0 for s in states}
    for key, text in model.definition.operating_points[name]:
        expr = parse_value(text, symbols, f"operating_points.{name}.{key}").subs(
            {symbols[k]: v for k, v in values.items()})
        try:
            value = float(expr)
        except TypeError:
            raise PendcError(f"operating_points.{name}.{key}: '{text}' is not a number of the constants") from None
        if key not in out:
            raise PendcError(f"operating_points.{name}: '{key}' is not a state of the model "
                             f"({', '.join(states)})")
        out[key] = value
    return name, out


def parse_value(text, symbols, where):
    """An operating point's value, parsed without executing code (:func:`pendc.model.expressions.parse_expression`)."""
    from ...model.expressions import parse_expression
    return parse_expression(text, symbols, where)


@dataclass(frozen=True)
class MeasuredCoordinate:
    """A measured position and the state that is its rate: names, indices into the model's
    state vector, the position's unit, its period (None: not periodic) and the operating
    point's values of both."""

    position: str
    rate: str | None
    index: int
    rate_index: int | None
    unit: str
    period: float | None
    target: float
    rate_target: float


def measured_coordinates(model: PlantModel, state: dict, point: str) -> tuple:
    """The measured positions with their rates; a one-line error naming a state of the model
    that is neither a measured position nor the rate of one."""
    iface = model.interface
    ports = CorePorts.of_interface(iface)
    states = [s.name for s in model.equations.states]
    coords, seen = [], set()
    for p in ports.measured:
        spec = iface.state(p)
        sensor = iface.sensor_of(p)
        if sensor is not None and sensor.is_adc and not sensor.lo <= state[p] <= sensor.hi:
            # the converter clips: the LQR would read its end and miss the point by what lies beyond
            raise PendcError(f"operating point '{point}' of plant '{iface.name}': {p} = "
                             f"{with_unit(f'{state[p]:.4g}', spec.unit)} lies outside the range of its converter "
                             f"{sensor.name}, {with_unit(f'[{sensor.lo:g}, {sensor.hi:g}]', spec.unit)}: it reads "
                             f"clipped there; widen the converter's range or move the point")
        rate = next((s.name for s in iface.states if s.derivative_of == p), None)
        coords.append(MeasuredCoordinate(
            position=p, rate=rate, index=states.index(p), rate_index=states.index(rate) if rate else None,
            unit=spec.unit, period=spec.period if spec.periodic else None, target=state[p],
            rate_target=state[rate] if rate else 0.0))
        seen.update({p, rate})
    unseen = [s for s in states if s not in seen]
    if unseen:
        raise PendcError(f"the LQR at operating point '{point}' of plant '{iface.name}' cannot see state "
                         f"'{unseen[0]}': it is neither a measured position (encoder or converter) nor the rate "
                         f"of one")
    return tuple(coords)


def wrap(error: float, period: float | None) -> float:
    """``error`` into (-period/2, period/2] (unchanged when ``period`` is None)."""
    if period is None:
        return error
    half = 0.5 * period
    return half - (half - error) % period


def state_weights(model: PlantModel, coords: tuple, excursions: dict | None = None) -> np.ndarray:
    """Q's diagonal in the model's state order (see the module docstring); ``excursions`` (state
    -> acceptable excursion) override the units' choice."""
    states = [s.name for s in model.equations.states]
    q = np.full(len(states), Q_OTHER)
    for c in coords:
        q[c.index] = 1.0 / Q_POSITION.get(c.unit, Q_POSITION_OTHER) ** 2
        if c.rate_index is not None:
            q[c.rate_index] = 1.0 / Q_RATE ** 2
    for name, value in (excursions or {}).items():
        if name in states:
            q[states.index(name)] = 1.0 / float(value) ** 2
    return q


def check_excursions(model: PlantModel, excursions: dict | None) -> dict:
    """``excursions`` checked: each names a state of the model or its input, with a positive
    finite value; a one-line error otherwise."""
    names = [s.name for s in model.equations.states] + [model.interface.input.name]
    out = {}
    for name, value in (excursions or {}).items():
        if name not in names:
            raise PendcError(f"--excursion names '{name}', not a state or the input of plant "
                             f"'{model.interface.name}' (known: {', '.join(names)})")
        if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
            raise PendcError(f"--excursion {name} must be a positive number, got {value!r}")
        out[name] = float(value)
    return out


@dataclass(frozen=True)
class OperatingLinearModel:
    """ds/dt = A (s - s0) + B (u - u0) about operating point ``point`` (states in the model's order)."""

    point: str
    s0: np.ndarray
    u0: float
    A: np.ndarray
    B: np.ndarray


def linearise_at(model: PlantModel, point: str | None = None, numeric: NumericModel | None = None
                 ) -> OperatingLinearModel:
    """The hold input and the linearisation at operating point ``point`` (see the module docstring)."""
    numeric = numeric or NumericModel.of(model)
    name, values = operating_state(model, point)
    where = f"operating point '{name}' of plant '{model.interface.name}'"
    s0 = np.array([values[s] for s in numeric.names])
    iface = model.interface
    lo, hi = float(iface.input.lo), float(iface.input.hi)
    span = hi - lo
    rates = [i for i, s in enumerate(numeric.names) if iface.state(s).derivative_of is not None]

    def shifted(sign: float) -> np.ndarray:
        s = s0.copy()
        s[rates] += sign * EPS_RATE
        return s

    def derivatives(u: float) -> np.ndarray:
        return 0.5 * sum(numeric.derivatives(shifted(sg), u) for sg in (1.0, -1.0))

    u_a, u_b = lo + 0.25 * span, lo + 0.75 * span
    d_a, d_b = derivatives(u_a), derivatives(u_b)
    b = (d_b - d_a) / (u_b - u_a)
    if not (np.all(np.isfinite(d_a)) and np.all(np.isfinite(b))):
        raise PendcError(f"the model's derivatives are not finite at the {where}")
    if not np.any(b != 0.0):
        raise PendcError(f"the input does not act on the plant at the {where}")
    d0 = d_a - b * u_a
    u0 = float(-(b @ d0) / (b @ b))
    residual = derivatives(u0)
    # each derivative's own scale: what the input moves it by, its size about the point, and the
    # size of the terms the states contribute (|A| |s0|), so an exact equilibrium's rounding (a
    # buck's output voltage derivative at 1e-12 V/s) is held and a ball on a tilted beam is not
    n = len(s0)
    terms = np.abs(0.5 * sum(numeric.jacobian(shifted(sg), u0)[:, :n] for sg in (1.0, -1.0))) @ np.abs(s0)
    scale = np.abs(b) * span + np.abs(d_a) + np.abs(d_b) + np.nan_to_num(terms)
    worst = int(np.argmax(np.abs(residual) / np.maximum(scale, 1e-300)))
    if not (np.abs(residual[worst]) <= HOLD_TOLERANCE * max(scale[worst], 1e-12) + 1e-12):
        raise PendcError(f"no input holds the plant at the {where}: the rate of change of {numeric.names[worst]} stays "
                         f"{residual[worst]:.3g} at the best input ({with_unit(f'{u0:.4g}', iface.input.unit)})")
    if not lo - 1e-9 * span <= u0 <= hi + 1e-9 * span:
        raise PendcError(f"holding the plant at the {where} needs {iface.input.name} = "
                         f"{with_unit(f'{u0:.4g}', iface.input.unit)}, outside its range [{lo:g}, {hi:g}]")
    n = len(numeric.names)
    A = 0.5 * sum(numeric.jacobian(shifted(sg), u0)[:, :n] for sg in (1.0, -1.0))
    du = span / 40.0
    B = ((derivatives(u0 + du) - derivatives(u0 - du)) / (2 * du)).reshape(n, 1)
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
        raise PendcError(f"the model's linearisation at the {where} is not finite (a non-smooth term there?)")
    return OperatingLinearModel(point=name, s0=s0, u0=u0, A=A, B=B)


def check_controllable(lin: OperatingLinearModel, q: np.ndarray, input_scale: float, plant: str) -> None:
    """The Popov-Belevitch-Hautus test on the linearisation, states scaled by sqrt(Q) and the
    input by its acceptable excursion (so units do not decide); a one-line error if a mode
    of A cannot be moved by the input."""
    t = np.sqrt(q)
    A = (t[:, None] * lin.A) / t[None, :]
    B = t[:, None] * lin.B * input_scale
    n = A.shape[0]
    norm = max(1.0, float(np.linalg.norm(np.hstack([A, B]), 2)))
    for lam in np.linalg.eigvals(A):
        smallest = np.linalg.svd(np.hstack([A - lam * np.eye(n), B]), compute_uv=False)[-1]
        if smallest <= CONTROLLABLE_TOLERANCE * norm:
            raise PendcError(f"plant '{plant}' is not controllable at operating point '{lin.point}': the input "
                             f"cannot move its mode at s = {complex(lam).real:.4g}{complex(lam).imag:+.4g}j")


def discrete_lqr(A: np.ndarray, B: np.ndarray, period: float, q: np.ndarray, r: float, where: str):
    """``(K, Ad, Bd)``: the zero-order-hold sampled model and its discrete LQR gain."""
    n = A.shape[0]
    big = np.zeros((n + 1, n + 1))
    big[:n, :n], big[:n, n:] = A * period, B * period
    e = scipy.linalg.expm(big)
    Ad, Bd = e[:n, :n], e[:n, n:]
    R = np.array([[float(r)]])
    try:
        P = scipy.linalg.solve_discrete_are(Ad, Bd, np.diag(q), R)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise PendcError(f"no LQR gain at {where}: {exc}") from None
    K = np.linalg.solve(R + Bd.T @ P @ Bd, Bd.T @ P @ Ad)
    return K.ravel(), Ad, Bd


class OperatingPointLqr:
    """Discrete LQR about operating point ``point`` (None: the plant file's first) of ``model``,
    at control period ``period`` (see the module docstring): ``u = u0 - K (s - s0)`` with s
    the measured positions (periodic ones wrapped about the point) and their rates, first
    differences through a low-pass of ``velocity_tau`` (20 ms: with 4 ms, as the pendulum
    controllers use, one count of a 4096-count encoder kicks a double pendulum's input into
    saturation half the time).
    ``lin`` is the linearisation, ``K`` the gain (per state of the model, in its order),
    ``input_range`` the DAC's span (the input's range)."""

    mode = "lqr"

    def __init__(self, model: PlantModel, period: float = 1e-3, point: str | None = None,
                 velocity_tau: float = VELOCITY_TAU, numeric: NumericModel | None = None,
                 excursions: dict | None = None):
        excursions = check_excursions(model, excursions)
        numeric = numeric or NumericModel.of(model)
        self.lin = linearise_at(model, point, numeric)
        self.point = self.lin.point
        self.states = numeric.names
        self.coords = measured_coordinates(model, dict(zip(numeric.names, self.lin.s0)), self.point)
        iface = model.interface
        self.input_range = (float(iface.input.lo), float(iface.input.hi))
        span = self.input_range[1] - self.input_range[0]
        self.q = state_weights(model, self.coords, excursions)
        input_excursion = excursions.get(iface.input.name, R_FRACTION * span)
        self.r = 1.0 / input_excursion ** 2
        check_controllable(self.lin, self.q, input_excursion, iface.name)
        self.K, self.Ad, self.Bd = discrete_lqr(self.lin.A, self.lin.B, period, self.q, self.r,
                                                f"operating point '{self.point}' of plant '{iface.name}'")
        self.period = float(period)
        self.rates = {c.position: FilteredDifference(period, velocity_tau) for c in self.coords}

    def reset(self) -> None:
        """Forget the rate filters' history."""
        for f in self.rates.values():
            f.reset()

    def error(self, meas: Measurement) -> np.ndarray:
        """s - s0 from the measurement (every state: a measured position or its filtered rate)."""
        err = np.zeros(len(self.states))
        for c in self.coords:
            p = meas.position(c.position)
            rate = self.rates[c.position].update(p)
            err[c.index] = wrap(p - c.target, c.period)
            if c.rate_index is not None:
                err[c.rate_index] = rate - c.rate_target
        return err

    def step(self, meas: Measurement) -> float:
        """One control period: the input."""
        return self.lin.u0 - float(self.K @ self.error(meas))
