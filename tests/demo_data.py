"""The shipped data files' scenarios (data/generate.py) as a module: the hidden effects and
their values, the other lab's pendulum, the swing-up controller. They are the shipped
cart-pendulum's, so they live in data/, not in the package (pendc.ident.datagen names no plant)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

GENERATOR = Path(__file__).resolve().parents[1] / "data" / "generate.py"


def _load():
    spec = importlib.util.spec_from_file_location("pendc_data_generate", GENERATOR)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


generate = _load()
HIDDEN_PARAMS = generate.HIDDEN_PARAMS
hidden_cases = generate.hidden_cases
demo_datasets = generate.demo_datasets
closed_loop_swing_up = generate.closed_loop_swing_up
unknown_pendulum = generate.unknown_pendulum
