"""A run of a short-chain build (the thesis preset's, which test_sim regresses) started away
from reset: the angle's tables are registers read a step ahead (``lower_model(lookahead=True)``),
which reset to the table at phase 0, so a start at another angle must fill them
(``pendc.golden.register_integers``) or the first steps push with the wrong forces. The golden
model and the RTL plants start through that one function, so both get it."""

import numpy as np
import pytest

import pendc
from pendc.caching.build_cache import compile_cached
from pendc.golden import GoldenModel, register_integers
from pendc.passes.lower import READ_AHEAD_KEY
from pendc.passes.pipeline import options_from_model, preset_options


@pytest.fixture(scope="module")
def short_chain():
    """The thesis preset's build: the short chain, tables read ahead (shared with test_sim)."""
    model = pendc.load_model()
    return model, compile_cached(model, options_from_model(model, **preset_options("thesis")))


def _start(model, build):
    """Hanging 2 rad away from its rest, cart still: the tables' values differ from phase 0's."""
    names = model.interface.outputs
    angle = next(s for s in model.interface.periodic)
    return names, tuple(2.0 if s == angle.name else 0.0 for s in names), angle


def test_read_ahead_registers_take_the_tables_value_at_the_start(short_chain):
    model, build = short_chain
    # the lowering's tables read ahead that survived its dead-node sweep
    ahead = [a for a in dict(build.graph.info)[READ_AHEAD_KEY] if a[0] in build.graph.by_name]
    assert ahead, "the short-chain build reads no table ahead: nothing to check"
    names, start, angle = _start(model, build)
    ints = register_integers(build.graph, dict(zip(names, start)))
    for register, state, period in ahead:
        table = build.graph[build.graph[register].inputs[0]]
        want = float(np.asarray(pendc.ir.lut.evaluate(table.params.expr, [2.0 / period % 1.0]))[0])
        got = ints[register] * build.graph[register].qformat.lsb
        reset = build.graph[register].params.reset
        # the tables hold dt-folded terms (1e-8 and less): tolerances relative to the table's largest value
        tol = 1e-3 * max(abs(v) for v in table.params.table) * table.qformat.lsb
        assert abs(got - want) <= tol, f"{register}: {got} for the table's {want}"
        assert abs(want - reset) <= tol or abs(got - reset) > tol, f"{register} kept its reset value"


def test_a_run_started_at_an_angle_follows_the_default_arithmetic(short_chain):
    """From the same start the short-chain build and the default build (whose tables are read in
    the step) integrate the same trajectory within the error budget; with the read-ahead registers
    left at their reset (phase 0) the angle's first steps are pushed by the wrong forces."""
    model, build = short_chain
    names, start, angle = _start(model, build)
    default = compile_cached(model)
    t = np.arange(0.0, 2.0 + 1e-9, 1e-3)
    u = np.full_like(t, model.interface.input.range.centre)
    runs = [GoldenModel(b.graph, b.options.dt)(t, u, initial=start).result for b in (build, default)]
    assert np.ptp(runs[1].states[angle.name]) > 0.1, "the pendulum did not swing: not a useful start"
    for state, budget in build.options.budgets_for(model.interface).items():
        err = float(np.max(np.abs(runs[0].states[state] - runs[1].states[state])))
        assert err <= budget, f"{state}: the short-chain build is {err:.3g} from the default build " \
                              f"(budget {budget:.3g})"
    # over the first 10 ms, before the narrowed products' rounding adds up: measured 1.4e-8 rad
    # apart; with the tables left at phase 0, 4.0e-7 (over the 2 s both are about 7e-5)
    early = int(round(0.010 / (t[1] - t[0]))) + 1
    err = float(np.max(np.abs(runs[0].states[angle.name][:early] - runs[1].states[angle.name][:early])))
    assert err <= 1e-7, f"{angle.name}: {err:.3g} apart in the first 10 ms: the first steps' tables look wrong"
