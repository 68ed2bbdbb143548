"""What identification says about each plant's effects (the plant files' evidence, separated_by and [identification]): every
text belongs to an effect or constant of that body, and diagnose and its tie rule read them."""

from pathlib import Path

import pytest

import pendc
from pendc.ident.ties import find_tie
from pendc.model.modelfile import shipped_plants

BODIES = {name: model.definition for name, model in shipped_plants().items()}

QUBE = Path(__file__).resolve().parents[1] / "models" / "furuta_qube.toml"


@pytest.mark.parametrize("name", sorted(BODIES))
def test_every_note_names_an_effect_or_constant_of_its_body(name):
    body = BODIES[name]
    notes, catalogue = body.notes, body.catalogue
    assert set(notes.evidence) == set(catalogue)               # every effect is explained in words
    assert set(notes.separated_by) <= set(catalogue)
    assert all(len(pair) == 2 and pair <= set(catalogue) for pair in notes.pair_separated_by)
    params = set(body.constants) | {p.name for cls in catalogue.values() for p in cls.params}
    for hint_body, kind, names, reason, _also in notes.parameter_hints:
        assert kind in ("angle", "rate", "input") and reason
        assert set(names.split(",")) <= params, names


def test_the_bodies_say_different_things():
    cart, furuta = BODIES["cart_pendulum"].notes, BODIES["furuta"].notes
    assert not set(cart.evidence) & set(furuta.evidence)
    hint_bodies = {b for b, *_ in furuta.parameter_hints}
    qube = pendc.load_model(QUBE)
    assert hint_bodies <= {s.body for s in qube.interface.states}


class _Candidate:
    def __init__(self, effect, score):
        self.effect, self.score = effect, score
        self.heldout_before, self.heldout_after = [1.0, 1.0], [(1 - score) / 2] * 2


def test_a_tie_is_separated_by_the_models_own_body():
    tied = [_Candidate("viscous_pivot", 0.6), _Candidate("coulomb_pivot", 0.6)]
    tie = find_tie(tied, notes=BODIES["furuta"].notes)
    assert tie["separate_by"] == BODIES["furuta"].notes.pair_separated_by[frozenset({"viscous_pivot",
                                                                                     "coulomb_pivot"})]
    assert "arm held" in tie["message"]
    # without notes: the default model's body, which knows nothing of the Furuta's effects; the
    # round F check read "an experiment that excites pivot_viscous alone" as no advice at all
    advice = find_tie(tied)["separate_by"]
    assert "names no experiment for them" in advice and "longer --horizon" in advice
