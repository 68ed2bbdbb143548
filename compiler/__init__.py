"""pendc: compiler and identification workbench for hardware-in-the-loop plant models.

The main objects, importable from here::

    load_model, parse_model, save_model   model files (TOML)
    PlantModel, Equations                 plant definition + values, and its sympy equations
    KINDS                                 the generic effect kinds a plant file's catalogue uses
    Simulator, simulate                   compiled float simulation
    stimuli                               standard input signals
    PendcError                            the exception for bad input
    compare, diagnose, fit                identification from Python (see pendc.api)

Each is imported on first use (PEP 562), so a process that needs one corner of pendc (the
HDL backend in a cocotb simulator) does not pay for the rest: the model modules import sympy
and its units, about a second of every process start.
"""

from importlib import import_module

# name -> (module, attribute): the attribute None is the module itself
_EXPORTS = {
    "compare": (".api", "compare"), "diagnose": (".api", "diagnose"), "fit": (".api", "fit"),
    "PendcError": (".errors", "PendcError"),
    "KINDS": (".model.effect_kinds", "KINDS"),
    "load_model": (".model.modelfile", "load_model"), "parse_model": (".model.modelfile", "parse_model"),
    "save_model": (".model.model_writer", "save_model"),
    "Equations": (".model.plant", "Equations"), "PlantModel": (".model.plant", "PlantModel"),
    "stimuli": (".sim.stimuli", None),
    "SimResult": (".sim.simulator", "SimResult"), "Simulator": (".sim.simulator", "Simulator"),
    "simulate": (".sim.simulator", "simulate"),
}

__all__ = list(_EXPORTS)
__version__ = "0.1.0"


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'pendc' has no attribute {name!r}")
    module, attribute = _EXPORTS[name]
    value = import_module(module, __name__)
    if attribute is not None:
        value = getattr(value, attribute)
    globals()[name] = value          # found once; later reads do not come here
    return value


def __dir__() -> list:
    return sorted({*globals(), *_EXPORTS})
