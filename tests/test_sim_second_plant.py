"""The cocotb regression on a second plant: the rotary (Furuta) pendulum's core against its golden
vectors, bit-exact on Icarus and Verilator.

The same tb/ code as the cart-pendulum's (tests/test_sim.py) runs unchanged: every name of the
plant (the core's module, its input, states and encoders, the bus registers) comes from the
plant interface the build's graph carries. Short by design: every-step windows of a few hundred
steps on one training stimulus (from reset and from three states deep inside it, deposited into
the core), reset in the middle of a step, the step handshake, and over the RAPTOR bus the reset
values of every register (the map named by the interface). Most of its time is the
simulators' start-up and Verilator's build (about a minute alone, three under load).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tb"))

import pendtb  # noqa: E402

SECOND_PLANT = REPO / "models" / "furuta_qube.toml"
WINDOW = 200                       # steps per every-step window
STIMULI = ("chirp_low", "random", "multisine_seed7_1MHz")
CORE_TESTS = ("reset_state", "every_step/stim=chirp_low", "reset_mid_run", "step_handshake")
BUS_TESTS = ("reset_values",)


@pytest.fixture(scope="module")
def prepared(tmp_path_factory):
    if not SECOND_PLANT.is_file():
        pytest.skip(f"no second plant model ({SECOND_PLANT.name})")
    prep = pendtb.prepare_hdl(tmp_path_factory.mktemp("second_plant"), model_path=str(SECOND_PLANT))
    return pendtb.add_vectors(prep, stimuli_names=STIMULI, window=WINDOW, long_chunks={})


def test_the_testbench_reads_the_second_plants_names(prepared):
    """The vectors, the testbench top and the report name the second plant's core and ports, and
    none of the cart-pendulum's."""
    import pickle

    from pendc import load_model
    iface = load_model(str(SECOND_PLANT)).interface
    vec = pickle.loads(prepared.vectors.read_bytes())
    ports = vec["core_ports"]
    assert ports.module == iface.core == prepared.report["raptor"]["top"]
    assert (ports.input, ports.states) == (iface.input.name, iface.outputs)
    assert [e.name for e in ports.encoders] == [s.name for s in iface.sensors]
    top = prepared.tb_top.read_text()
    assert f"{iface.core} core (" in top and all(f"cnt_{s.name}" in top for s in iface.sensors)
    cart = load_model().interface
    assert not {s.name for s in cart.states} & {s.name for s in iface.states}
    assert not any(f".{s.name}(" in top for s in cart.states)
    assert all(len(w["rows"]) == WINDOW + 1 for w in vec["windows"])


@pytest.mark.parametrize("sim", pendtb.SIMS)
def test_second_plant_core_is_bit_exact(prepared, sim, tmp_path):
    why = pendtb.simulator_missing(sim)
    if why:
        pytest.skip(why)
    suites = [("core", CORE_TESTS)] + ([("raptor", BUS_TESTS)] if sim == "icarus" else [])
    problems = []
    for suite, tests in suites:
        r = pendtb.run_suite(prepared, sim, suite, tmp_path, profile="quick", testcase=",".join(tests))
        print(f"{sim}/{suite}: {r.tests - r.failed}/{r.tests} passed (build {r.build_s:.1f} s, tests {r.test_s:.1f} s)")
        if r.tests != len(tests):
            problems.append(f"{sim}/{suite}: {r.tests} cocotb tests ran, {len(tests)} selected (log {r.log})")
        problems += [f"{sim}/{suite}: {f}" for f in r.failures]
        problems += [f"{sim}/{suite}: {t} skipped (a shipped plant must reach every check)" for t in r.skipped]
    assert not problems, "cocotb failures:\n" + "\n".join(problems)
