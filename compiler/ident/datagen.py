"""Measurement-like data from models that carry effects the tool's model lacks.

The identification workbench is tested the way it will be used: on data whose
physics is known to us but not to the model being identified. A data set is the
"true" model simulated (1 us Euler, the reference integrator) on a rich experiment,
then degraded like the real rig: the command goes through a 12-bit DAC and picks up
unmeasured noise before the drive sees it, and the positions are read by the plant's
x4 encoders (the SCT's: 2.5 um, 0.314 mrad). The file records the *commanded* input,
as a controller log would. The columns are the plant interface's: time, the input,
each position (``t, u, x, theta`` for the cart-pendulum).
"""

from __future__ import annotations

import numpy as np

from ..model.interface import InputRange
from ..model.plant import PlantModel
from ..sim.encoders import quantize
from ..sim.signals import PlantSignals, signals_of
from ..sim.simulator import Simulator
from ..sim.stimuli import Stimuli

FS = 1000.0


def identification_experiment(duration: float = 20.0, seed: int = 7, plant=None):
    """The standard 20 s experiment: small and large steps, a chirp, a resonant swing-up
    and a quiet end where the pendulum swings freely (damping shows there). The levels are
    :mod:`~pendc.sim.stimuli` reference levels on the input of ``plant`` (a model or interface;
    default: the default model's), about its neutral value and within its range."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(duration * FS)) + 1) / FS
    u = np.zeros_like(t)
    seg = duration / 20.0
    levels = [0.3, -0.3, 0.6, -0.6, 2.8, -2.8, 1.2, -1.2]
    for i, lv in enumerate(levels):                         # 0-4 s: steps
        u[(t >= i * 0.5 * seg) & (t < (i + 1) * 0.5 * seg)] = lv
    m = (t >= 4 * seg) & (t < 10 * seg)                      # 4-10 s: chirp 0.3 -> 3 Hz
    tau = t[m] - 4 * seg
    T = 6 * seg
    u[m] = 1.5 * np.sin(2 * np.pi * (0.3 * tau + (3.0 - 0.3) / (2 * T) * tau**2))
    m = (t >= 10 * seg) & (t < 14 * seg)                     # 10-14 s: resonant square wave
    u[m] = 2.0 * np.sign(np.sin(2 * np.pi * 0.9 * (t[m] - 10 * seg)))
    m = (t >= 14 * seg) & (t < 16 * seg)                     # 14-16 s: random levels
    holds = rng.uniform(-2.0, 2.0, 40)
    u[m] = holds[((t[m] - 14 * seg) / 0.05).astype(int) % 40]
    return t, Stimuli(signals_of(plant).interface.input).on_input(u)   # 16-20 s: idle, free swing


def dac_output(u, input_range: InputRange, dac_bits: int = 12) -> np.ndarray:
    """The command as a DAC of ``dac_bits`` over the actuator's whole range puts it out (the
    nearest code, counted from the range's low end)."""
    lsb = input_range.span / (2**dac_bits - 1)
    return input_range.lo + np.round((np.asarray(u, float) - input_range.lo) / lsb) * lsb


def degrade_input(u: np.ndarray, input_range: InputRange, dac_bits: int = 12, noise_v: float = 0.005,
                  seed: int = 11) -> np.ndarray:
    """What the actuator sees: the DAC's quantised command (:func:`dac_output` over the
    plant's ``input_range``) plus unmeasured noise."""
    rng = np.random.default_rng(seed)
    return dac_output(u, input_range, dac_bits) + rng.normal(0.0, noise_v, size=np.shape(u))


def encoder_readings(signals: PlantSignals, positions: dict) -> dict:
    """Each position as its encoder reads it (counted from the first sample); a position no
    sensor reads is passed on unchanged."""
    out = {}
    for name, values in positions.items():
        step = signals.resolution(name)
        out[name] = quantize(values, step) if step is not None else np.asarray(values, float)
    return out


def make_dataset(true_model: PlantModel, t=None, u=None, dac_bits: int = 12, noise_v: float = 0.005,
                 seed: int = 11, dt: float = 1e-6, experiment: str = "free", x0=None) -> dict:
    """Columns time, input, positions (``t, u, x, theta`` for the cart-pendulum) of one
    simulated ``experiment`` on ``true_model`` from the true state ``x0`` (default: at rest
    at zero); positions as the sensors read them. The DAC spans the input's range."""
    if t is None:
        t, u = identification_experiment(plant=true_model)
    sig = signals_of(true_model)
    applied = degrade_input(np.asarray(u, float), sig.interface.input.range, dac_bits, noise_v, seed)
    res = Simulator(true_model.for_experiment(experiment), dt=dt)(t, applied, x0=x0)
    return {"t": np.asarray(t, float), sig.input: np.asarray(u, float),
            **encoder_readings(sig, {p: res.measured(p) for p in sig.positions})}


def free_swing(true_model: PlantModel, duration: float = 30.0, angle0: float = 0.8, seed: int = 17) -> dict:
    """The thesis' pivot experiment: the cart clamped, the pendulum (the last periodic
    position) released from ``angle0`` at rest; the actuator is idle (the log holds the input's
    neutral value)."""
    t = np.arange(int(round(duration * FS)) + 1) / FS
    sig = signals_of(true_model)
    u = np.full_like(t, sig.interface.input.neutral)
    x0 = np.zeros(len(sig.mechanical))
    x0[sig.index(sig.periodic[-1])] = angle0
    return make_dataset(true_model, t, u, seed=seed, experiment="cart_held", x0=tuple(x0))


# The other lab's pivot: the catalogue's viscous pivot damping with this coefficient
PIVOT_DAMPING = ("viscous_pendulum", 0.0025)


def pivot_damping(base: PlantModel) -> tuple:
    """``(parameter, value)`` of the other lab's pivot damping: the coefficient of the
    catalogue's :data:`PIVOT_DAMPING` effect."""
    effect, value = PIVOT_DAMPING
    return base.catalogue[effect].params[0].name, value


def unknown_pendulum(base: PlantModel) -> PlantModel:
    """Another lab's pendulum on the SCT cart: 5 % heavier, 5 % shorter to its centre of mass,
    5 % more inertia, and a stiffer pivot than the model says."""
    p = base.plant
    model = base.with_params({"m": p["m"] * 1.05, "L": p["L"] * 0.95, "I": p["I"] * 1.05})
    effect, damping = PIVOT_DAMPING[0], dict([pivot_damping(base)])
    return model.with_params(damping) if effect in model.effects else model.with_effect(effect, damping)


# Hidden effects added to the true model, with parameters large enough to matter on the rig.
HIDDEN_PARAMS = {
    "cart_spring": {"k_c": 300.0, "x_0": 0.05},
    "coulomb_pendulum": {"tau_c": 0.004},
    "asymmetric_cart": {"d_mu": 0.25},
    "drive_deadzone": {"u_dz": 0.2},
    "force_limit": {"F_max": 450.0},
    "motor_lag": {"tau_m": 0.02},
    "input_delay": {"tau_d": 0.01},
}


def hidden_effect_cases(base: PlantModel) -> dict:
    """name -> (true model, model the tool starts from): one hidden catalogue effect each.

    Effects the base model has are hidden by removing them from the tool's model;
    the others are added to the true model with clearly visible parameters."""
    cases = {name: (base.with_effect(name, params), base) for name, params in HIDDEN_PARAMS.items()}
    for name in ("viscous_pendulum", "velocity_limit"):
        if name in base.effects:
            cases[name] = (base, base.without_effect(name))
    return cases


def make_ripple_dataset(model: PlantModel, amplitude: float = 40.0, wavelength: float = 0.06,
                        dac_bits: int = 12, noise_v: float = 0.005, seed: int = 11) -> dict:
    """Data with physics outside the catalogue: a rail ripple force A sin(2 pi x / wavelength)
    on the cart (a worn or uneven guide). It enters as an equivalent input offset updated
    every millisecond from the simulated position, since no catalogue effect can carry it."""
    t, u = identification_experiment(plant=model)
    applied = degrade_input(u, model.interface.input.range, dac_bits, noise_v, seed)
    alpha = model.effects["drive"]["alpha"]
    sim = Simulator(model, dt=1e-6)
    sig = sim.signals
    track = sig.index(sig.positions[0])          # the cart's position: the ripple is along the rail
    state = np.zeros(len(sig.mechanical))
    log = {p: np.zeros_like(t) for p in sig.positions}
    for k in range(len(t) - 1):
        ripple = amplitude * np.sin(2 * np.pi * state[track] / wavelength) / alpha
        seg = sim(t[k:k + 2], applied[k:k + 2] + ripple, x0=state)
        state = np.array([seg[s][-1] for s in sig.mechanical])
        for p in sig.positions:
            log[p][k + 1] = state[sig.index(p)]
    return {"t": t, sig.input: u, **encoder_readings(sig, log)}


def demo_datasets(base: PlantModel) -> dict:
    """The shipped data files (name -> (columns, description[, extra metadata])) for the
    walkthroughs in docs/."""
    spring = base.with_effect("cart_spring", {"k_c": 300.0, "x_0": 0.05})
    two = spring.with_effect("coulomb_pendulum", {"tau_c": 0.004})
    t2, u2 = identification_experiment(seed=21, plant=base)
    damping, value = pivot_damping(base)
    return {
        "hidden_spring": (make_dataset(spring), "Table 14 model plus a cable pulling the cart (cart_spring k_c=300 N/m, x_0=0.05 m)"),
        "hidden_spring_validation": (make_dataset(spring, t2, u2, seed=23), "the same plant, another experiment (for validation)"),
        "hidden_two_effects": (make_dataset(two), "cable on the cart and dry friction in the pivot (coulomb_pendulum tau_c=0.004 N*m)"),
        "hidden_unexplained": (make_ripple_dataset(base), "a rail ripple force 40 sin(2 pi x / 0.06) N: not in the catalogue"),
        "hidden_spring_swing_up": (closed_loop_swing_up(spring), "the spring plant under a closed-loop energy swing-up controller"),
        "unknown_pendulum_swing": (free_swing(unknown_pendulum(base)),
                                   f"another pendulum (m +5 %, L -5 %, I +5 %, {damping} {value:g}) swinging "
                                   "freely from 0.8 rad with the cart clamped", {"experiment": "cart_held"}),
    }


def closed_loop_swing_up(model: PlantModel, duration: float = 10.0, gain_energy: float = 5e4,
                         gain_x: float = 3e3, gain_v: float = 800.0, swing: float = 4.5, dac_bits: int = 12,
                         noise_v: float = 0.005, seed: int = 13) -> dict:
    """An energy-pumping swing-up controller closing the loop at 1 kHz on the encoder readings,
    as the thesis' HiLDE tests ran controllers against the plant. The controller sees only
    quantised positions (velocities from a filtered difference), commands u, and the log
    records that command; the plant gets it through the DAC with noise."""
    rng = np.random.default_rng(seed)
    p = model.parameter_values()
    m, L, I, g = p["m"], p["L"], p["I"], p["g"]
    alpha, v_off = p["alpha"], p["V_off"]
    h = 1.0 / FS
    n = int(round(duration * FS))
    sim = Simulator(model, dt=1e-6)
    sig = sim.signals
    cart, pendulum = sig.positions[0], sig.periodic[-1]     # the controller's two sensors
    i_cart, i_pend = sig.index(cart), sig.index(pendulum)
    drive = sig.interface.input.range
    state = np.zeros(len(sig.mechanical))
    state[i_pend] = 0.05
    t = np.arange(n + 1) * h
    u_log, x_log, th_log = np.empty(n + 1), np.empty(n + 1), np.empty(n + 1)
    prev_x = prev_th = 0.0
    vx = vth = 0.0
    for k in range(n + 1):
        xq = float(quantize(np.array([0.0, state[i_cart]]), sig.resolution(cart))[1])
        thq = float(quantize(np.array([0.0, state[i_pend]]), sig.resolution(pendulum))[1])
        vx = 0.8 * vx + 0.2 * (xq - prev_x) / h
        vth = 0.8 * vth + 0.2 * (thq - prev_th) / h
        prev_x, prev_th = xq, thq
        energy = 0.5 * (m * L * L + I) * vth**2 - m * g * L * np.cos(thq)
        force = gain_energy * (m * g * L - energy) * np.sign(vth * np.cos(thq)) - gain_x * xq - gain_v * vx
        u = float(np.clip(v_off + force / alpha, v_off - swing, v_off + swing))
        u_log[k], x_log[k], th_log[k] = u, xq, thq
        if k == n:
            break
        applied = float(dac_output(u, drive, dac_bits)) + rng.normal(0.0, noise_v)
        seg = sim(np.array([t[k], t[k + 1]]), np.array([applied, applied]), x0=state)
        state = np.array([seg[s][-1] for s in sig.mechanical])
    return {"t": t, sig.input: u_log, cart: x_log, pendulum: th_log}
