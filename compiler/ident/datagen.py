"""Measurement-like data from models that carry effects the tool's model lacks.

The identification workbench is tested the way it will be used: on data whose
physics is known to us but not to the model being identified. A data set is the
"true" model simulated (1 us Euler, the reference integrator) on a rich experiment,
then degraded like a real rig: the command goes through a 12-bit DAC and picks up
unmeasured noise before the drive sees it, and the positions are read by the plant's
x4 encoders (its ``[sensors]``). The file records the *commanded* input, as a controller
log would. The columns are the plant interface's: time, the input, each position.

Nothing here names a plant: which coordinate is driven, which experiment holds it and how
much force a unit of input makes come from the plant file (:mod:`.plant_roles`). The
scenarios of the shipped data files (which effects are hidden, with which values) are
``data/generate.py``'s.
"""

from __future__ import annotations

import numpy as np

from ..model.interface import InputRange
from ..model.plant import PlantModel
from ..sim.encoders import quantize
from ..sim.signals import PlantSignals, signals_of
from ..sim.simulator import Simulator
from ..sim.stimuli import Stimuli
from .plant_roles import drive_gain, driven_coordinate, holding_experiment
from .regimes import swing_angle

FS = 1000.0


def identification_experiment(duration: float = 20.0, seed: int = 7, plant=None):
    """The standard 20 s experiment: small and large steps, a chirp, a resonant square wave
    and a quiet end where the plant moves freely (damping shows there). The levels are
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
    """Each position as its sensor reads it (an encoder: counted from the first sample; a sampled
    converter: quantised to its LSB and clipped to its range, :func:`pendc.sim.encoders.convert`);
    a position no sensor reads is passed on unchanged."""
    out = {}
    for name, values in positions.items():
        step = signals.resolution(name)
        out[name] = quantize(values, step) if step is not None else np.asarray(values, float)
    return out


def make_dataset(true_model: PlantModel, t=None, u=None, dac_bits: int = 12, noise_v: float = 0.005,
                 seed: int = 11, dt: float = 1e-6, experiment: str = "free", x0=None) -> dict:
    """Columns time, input and each position (the plant interface's names) of one
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
    """A free swing with the driven coordinate held (the plant file's experiment that holds it
    alone): the swinging angle (:func:`.regimes.swing_angle`) released from ``angle0`` at rest; the actuator is idle
    (the log holds the input's neutral value)."""
    t = np.arange(int(round(duration * FS)) + 1) / FS
    sig = signals_of(true_model)
    u = np.full_like(t, sig.interface.input.neutral)
    x0 = np.zeros(len(sig.mechanical))
    x0[sig.index(swing_angle(true_model))] = angle0
    return make_dataset(true_model, t, u, seed=seed, experiment=held_experiment(true_model), x0=tuple(x0))


def held_experiment(model: PlantModel) -> str:
    """The plant file's experiment that holds the driven coordinate and nothing else."""
    driven = driven_coordinate(model)
    found = holding_experiment(model, driven) if driven else None
    if found is None:
        raise ValueError(f"{model.definition.name}: no experiment holds the driven coordinate '{driven}' alone")
    return found


def perturbed(base: PlantModel, factors: dict, effects: dict | None = None) -> PlantModel:
    """``base`` with constants scaled (``factors``: name -> factor) and effects set or added
    (``effects``: effect -> parameter values): another rig of the same plant."""
    p = base.plant
    model = base.with_params({k: p[k] * f for k, f in factors.items()})
    for effect, values in (effects or {}).items():
        model = model.with_params(values) if effect in model.effects else model.with_effect(effect, values)
    return model


def hidden_effect_cases(base: PlantModel, hidden: dict, removed=()) -> dict:
    """name -> (true model, model the tool starts from): one hidden catalogue effect each.

    ``hidden`` (effect -> parameter values) are added to the true model; each effect of
    ``removed`` the base model has is hidden by removing it from the tool's model."""
    cases = {name: (base.with_effect(name, params), base) for name, params in hidden.items()}
    for name in removed:
        if name in base.effects:
            cases[name] = (base, base.without_effect(name))
    return cases


def make_ripple_dataset(model: PlantModel, amplitude: float = 40.0, wavelength: float = 0.06,
                        dac_bits: int = 12, noise_v: float = 0.005, seed: int = 11) -> dict:
    """Data with physics outside the catalogue: a ripple force A sin(2 pi q / wavelength) along
    the driven coordinate q (a worn or uneven guide). It enters as an equivalent input offset
    (the force over the drive's gain, :func:`~pendc.ident.plant_roles.drive_gain`) updated
    every millisecond from the simulated position, since no catalogue effect can carry it."""
    t, u = identification_experiment(plant=model)
    applied = degrade_input(u, model.interface.input.range, dac_bits, noise_v, seed)
    gain = drive_gain(model)
    sim = Simulator(model, dt=1e-6)
    sig = sim.signals
    track = sig.index(driven_coordinate(model))      # the ripple is along the driven coordinate's guide
    state = np.zeros(len(sig.mechanical))
    log = {p: np.zeros_like(t) for p in sig.positions}
    for k in range(len(t) - 1):
        ripple = amplitude * np.sin(2 * np.pi * state[track] / wavelength) / gain
        seg = sim(t[k:k + 2], applied[k:k + 2] + ripple, x0=state)
        state = np.array([seg[s][-1] for s in sig.mechanical])
        for p in sig.positions:
            log[p][k + 1] = state[sig.index(p)]
    return {"t": t, sig.input: u, **encoder_readings(sig, log)}
