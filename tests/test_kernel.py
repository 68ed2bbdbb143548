"""pendc.sim.kernel: the float simulator's generated source, and the cache that keeps it."""

import pytest

import pendc.sim.kernel as kernel
from pendc import load_model


def test_the_stored_source_is_the_printed_one_and_is_printed_once(monkeypatch, tmp_path):
    """A diagnosis of the double pendulum built 13 simulators of 3 models and printed each one's
    equations again (1.5 s each, 20 of its 60 s); the source is now kept by the equations' hash."""
    monkeypatch.setenv("PENDC_CACHE_DIR", str(tmp_path))
    eq = load_model().equations
    first = kernel.stored_kernel_source(eq)
    assert first == kernel.kernel_source(eq)
    assert len(list((tmp_path / "kernel_sources").glob("*.py"))) == 1

    def printed_again(*args):
        raise AssertionError("printed again")

    monkeypatch.setattr(kernel, "kernel_source", printed_again)
    assert kernel.stored_kernel_source(load_model().equations) == first      # another model object, same equations
    with pytest.raises(AssertionError, match="printed again"):              # another clamped state: its own entry
        kernel.stored_kernel_source(eq, clamped=eq.states[0].name)
    other = load_model().with_effect("cart_spring").equations
    with pytest.raises(AssertionError, match="printed again"):              # other equations: their own entry
        kernel.stored_kernel_source(other)
