"""Regenerate the shipped measurement-like data files of data/ (deterministic).

Usage: .venv/bin/python data/generate.py [folder]
Each file is the thesis' final model (the shipped cart-pendulum plant,
models/sct_thesis_final.toml) with hidden effects, simulated at 1 us on the standard
identification experiment, with a 12-bit DAC, unmeasured input noise and x4 encoder
quantisation (see pendc.ident.datagen, which names no plant).

The scenarios are this plant's, so they live here rather than in the package: which
catalogue effects are hidden and with which values (large enough to matter on the rig),
another lab's pendulum on the same cart, and an energy swing-up controller for a pendulum
on a cart. The tests read them from here (tests/demo_data.py).
"""

import sys
from pathlib import Path

import numpy as np

from pendc import load_model
from pendc.ident.datagen import (FS, dac_output, free_swing, hidden_effect_cases, identification_experiment,
                                 make_dataset, make_ripple_dataset, perturbed)
from pendc.model.plant import PlantModel
from pendc.sim.encoders import quantize
from pendc.sim.measurements import write_csv
from pendc.sim.simulator import Simulator

MODEL = Path(__file__).resolve().parents[1] / "models" / "sct_thesis_final.toml"   # the plant of these scenarios

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
# Effects of the shipped model that a case hides by removing them from the tool's model
REMOVED = ("viscous_pendulum", "velocity_limit")

# The other lab's pendulum: 5 % heavier, 5 % shorter to its centre of mass, 5 % more inertia,
# and a stiffer pivot (the catalogue's viscous pivot damping with this coefficient)
PIVOT_DAMPING = ("viscous_pendulum", 0.0025)
OTHER_PENDULUM = {"m": 1.05, "L": 0.95, "I": 1.05}


def hidden_cases(base: PlantModel) -> dict:
    """name -> (true model, model the tool starts from): one hidden catalogue effect each."""
    return hidden_effect_cases(base, HIDDEN_PARAMS, REMOVED)


def pivot_damping(base: PlantModel) -> tuple:
    """``(parameter, value)`` of the other lab's pivot damping: the coefficient of the
    catalogue's :data:`PIVOT_DAMPING` effect."""
    effect, value = PIVOT_DAMPING
    return base.catalogue[effect].params[0].name, value


def unknown_pendulum(base: PlantModel) -> PlantModel:
    """Another lab's pendulum on the SCT cart: 5 % heavier, 5 % shorter to its centre of mass,
    5 % more inertia, and a stiffer pivot than the model says."""
    return perturbed(base, OTHER_PENDULUM, {PIVOT_DAMPING[0]: dict([pivot_damping(base)])})


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


def demo_datasets(base: PlantModel) -> dict:
    """The shipped data files (name -> (columns, description[, extra metadata])) for the
    walkthroughs in docs/."""
    spring = base.with_effect("cart_spring", HIDDEN_PARAMS["cart_spring"])
    two = spring.with_effect("coulomb_pendulum", HIDDEN_PARAMS["coulomb_pendulum"])
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


def main() -> int:
    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent
    for name, (columns, description, *extra) in demo_datasets(load_model(MODEL)).items():
        meta = {"description": description, "generator": "data/generate.py", **(extra[0] if extra else {})}
        write_csv(folder / f"{name}.csv", columns, meta=meta)
        print(f"wrote {folder / name}.csv")
    return 0


if __name__ == "__main__":
    sys.exit(main())
