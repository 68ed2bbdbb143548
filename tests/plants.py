"""The shipped plants as tests use them: the default model's plant definition, its catalogue
and encoder counts, and a model of it from values alone (the plants are files in models/,
so these are read from there, never typed in)."""

from __future__ import annotations

from pendc.model.modelfile import load_model
from pendc.model.plant import PlantModel
from pendc.sim.stimuli import Stimuli

DEFAULT = load_model()                                   # models/sct_thesis_final.toml
CATALOGUE = DEFAULT.catalogue                             # the SCT plant's effects
X_COUNT = DEFAULT.interface.sensor_of("x").resolution     # 2.5 um
THETA_COUNT = DEFAULT.interface.sensor_of("theta").resolution   # 0.314 mrad


def sct_model(plant: dict, effects: dict, **kwargs) -> PlantModel:
    """A model of the default model's plant with these values and effects."""
    return PlantModel(plant=plant, effects=effects, definition=DEFAULT.definition, **kwargs)


def plant_named(name: str) -> PlantModel:
    """The shipped model file that declares plant ``name``."""
    from pendc.model.modelfile import shipped_plants

    return shipped_plants()[name]


def _rigid(model, names):
    """The mechanism of ``model`` with the constants by name (as the derivations were once kept)."""
    from types import SimpleNamespace

    from pendc.model.assemble import mechanism_of

    mech = mechanism_of(model)
    symbols = {s.name: s for s in mech.kinetic.free_symbols | mech.potential.free_symbols | mech.det.free_symbols}
    return SimpleNamespace(mech=mech, constants={n: symbols[n] for n in names}, state=mech.state,
                           forces=mech.forces, lagrangian=mech.lagrangian, kinetic=mech.kinetic,
                           potential=mech.potential, euler_lagrange=mech.euler_lagrange,
                           accelerations=mech.accelerations, mass_matrix=mech.mass_matrix, det=mech.det,
                           numerators=mech.numerators, points=mech.points, periods=mech.periods,
                           k=mech.det, num_x=mech.numerators[0], num_theta=mech.numerators[-1])


def derive_rigid_body():
    """The SCT cart-pendulum's derived mechanism (from models/sct_thesis_final.toml)."""
    return _rigid(DEFAULT, ("g", "M", "m", "L", "I"))


def derive_furuta():
    """The QUBE's Furuta pendulum's derived mechanism (from models/furuta_qube.toml)."""
    return _rigid(plant_named("furuta"), ("g", "J_r", "L_r", "m_p", "L_p"))


# The standard stimuli on the default model's input (its 0-10 V drive about the idle voltage)
STIMULI = Stimuli(DEFAULT.interface.input)
chirp, steps, swing_up, multisine, random_levels = (STIMULI.chirp, STIMULI.steps, STIMULI.swing_up,
                                                    STIMULI.multisine, STIMULI.random_levels)


# A one-state plant in state-equation form (a tank: inflow in, Torricelli outflow), for the tests
# of lowering and effects on plants that are not mechanisms
TANK_FILE = """
[plant]
name = "tank"
k = 0.5
L = 1.0
[constants]
k = { unit = "1/s", meaning = "outflow rate", bounds = [0.1, 1.0] }
L = { unit = "m", meaning = "length", bounds = [0.1, 2.0] }
[states.h]
unit = "m"
meaning = "level"
derivative = "u - k*sqrt(2*h*L)"
initial = 0.2
[inputs.u]
unit = "m/s"
meaning = "inflow"
range = [0.0, 1.0]
[sensors.level]
kind = "adc"
state = "h"
bits = 10
range = [0.0, 1.0]
"""
