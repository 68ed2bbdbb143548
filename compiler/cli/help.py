"""Help texts that take their examples from the plant interface, not from the source.

A help text writes ``{plant:WORD}`` where an example needs a name of the plant (a state, the
input, a column list); :class:`PlantWordsFormatter` fills the words in from the interface of
the shipped default model when, and only when, a help page is printed (building an interface
derives the equations: seconds, which no other command line should pay). The effect list of
``pendc fit --help`` / ``pendc diagnose --help`` comes from the catalogue of every shipped
plant file (:func:`pendc.model.modelfile.shipped_plants`).
"""

from __future__ import annotations

import argparse
import re

PLACEHOLDER = re.compile(r"\{plant:(\w+)\}")


def plant_words(signals=None) -> dict:
    """The words help texts cite, from ``signals`` (:class:`~pendc.sim.signals.PlantSignals`;
    default: the default model's): ``time``, ``input`` (name and ``input_unit``), ``angle``
    (the first periodic position), ``position`` (the first other position, else the second
    position), ``positions``/``states``/``columns`` (comma-separated), each position's unit and
    encoder step, ``body`` (the interface's name) and ``constants`` (every shipped plant's constants)."""
    from ..model.modelfile import shipped_plants
    from ..sim.signals import TIME, signals_of

    sig = signals_of(signals)
    iface = sig.interface
    positions = sig.positions
    periodic = [p for p in positions if sig.period(p) is not None]
    others = [p for p in positions if p not in periodic[:1]]
    angle = periodic[0] if periodic else positions[0]
    position = others[0] if others else positions[-1]

    def step(name):
        sensor = iface.sensor_of(name)
        return f"{sensor.resolution:.5g}" if sensor is not None else "1e-3"

    return {
        "time": TIME, "input": sig.input, "input_unit": iface.input.unit,
        "angle": angle, "angle_unit": sig.unit(angle), "angle_step": step(angle),
        "angle_meaning": iface.state(angle).meaning,
        "position": position, "position_unit": sig.unit(position), "position_step": step(position),
        "positions": ",".join(positions), "states": ",".join(sig.mechanical),
        "columns": ",".join((TIME, sig.input, *positions)), "body": iface.name,
        "constants": "; ".join(f"{name}: {' '.join(model.plant)}" for name, model in shipped_plants().items()),
    }


def fill(text: str, words: dict) -> str:
    """``text`` with every ``{plant:WORD}`` replaced by ``words[WORD]``."""
    return PLACEHOLDER.sub(lambda m: words[m.group(1)], text)


class PlantWordsFormatter(argparse.HelpFormatter):
    """A help formatter (mixed in before argparse's own) that fills ``{plant:WORD}`` in help
    texts, descriptions and epilogs before they are wrapped."""

    _words = None

    def _plant(self, text):
        if text and PLACEHOLDER.search(text):
            if self._words is None:
                self._words = plant_words()
            return fill(text, self._words)
        return text

    def _expand_help(self, action):
        return self._plant(super()._expand_help(action))

    def _format_text(self, text):
        return super()._format_text(self._plant(text))


def formatter_with_plant_words(formatter_class):
    """``formatter_class`` with :class:`PlantWordsFormatter` mixed in before it."""
    if issubclass(formatter_class, PlantWordsFormatter):
        return formatter_class
    return type(f"PlantWords{formatter_class.__name__}", (PlantWordsFormatter, formatter_class), {})


def effects_by_body() -> str:
    """The effect catalogue of every shipped plant, grouped by plant (the names ``--add`` and
    ``--effects`` take; parameters in brackets, free them with ``--free``). A plant file of
    one's own lists its own in ``[catalogue]``."""
    from ..model.modelfile import default_model_path, shipped_plants

    default = next((name for name, model in shipped_plants().items()
                    if model.source == str(default_model_path())), None)
    lines = ["effects (names for --add; parameters in brackets, free them with --free), by the model's plant",
             "(the [catalogue] of its plant file; the shipped plants'):"]
    for name, model in shipped_plants().items():
        mark = ", the default" if name == default else ""
        lines.append(f"  {name} ({model.definition.summary}{mark}):")
        width = max(len(effect) for effect in model.catalogue)
        lines += [f"    {effect:<{width}}  {e.summary} [{', '.join(p.name for p in e.params)}]"
                  for effect, e in model.catalogue.items()]
    return "\n".join(lines) + "\n"
