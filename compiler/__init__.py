"""pendc: compiler and identification workbench for hardware-in-the-loop plant models.

The main objects, importable from here::

    load_model, parse_model, save_model   model files (TOML)
    PlantModel, Equations                 plant definition + values, and its sympy equations
    KINDS                                 the generic effect kinds a plant file's catalogue uses
    Simulator, simulate                   compiled float simulation
    stimuli                               standard input signals
    PendcError                            the exception for bad input
    compare, diagnose, fit                identification from Python (see pendc.api)
"""

from .api import compare, diagnose, fit
from .errors import PendcError
from .model.effect_kinds import KINDS
from .model.modelfile import load_model, parse_model
from .model.model_writer import save_model
from .model.plant import Equations, PlantModel
from .sim import stimuli
from .sim.simulator import SimResult, Simulator, simulate

__all__ = [
    "PendcError", "KINDS", "load_model", "parse_model", "save_model", "Equations", "PlantModel",
    "stimuli", "SimResult", "Simulator", "simulate", "compare", "diagnose", "fit",
]
__version__ = "0.1.0"
