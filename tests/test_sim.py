"""Simulation regression of the generated HDL: the cocotb suites in tb/ on Icarus and
Verilator, and the chirp accuracy of the core through a standalone Verilator harness.

The HDL of the default model is the repository's hdl_out/ when ``pendc build --check``
says it is current, else a fresh build under pytest's tmp folder; the golden vectors
are computed once per session (tb/pendtb.py). Icarus runs the core and RAPTOR wrapper suites,
Verilator the core and AXI4-Lite ones (see SUITES); a cocotb
failure fails the test with the failing cocotb tests and their messages. ``make sim`` runs
every suite on both simulators through tb/run.py, there with the full profile on Verilator
(seconds of model time; see CI_PROFILE).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tb"))

import pendtb  # noqa: E402


# Which build each simulator regresses: Icarus the default build (hdl_out/: ii > 2; the small
# preset's shared multipliers are tests/test_sim_shared_multipliers.py), Verilator the thesis
# preset (the short-chain arithmetic with narrowed products and three shared multipliers, ii 3:
# another graph, another golden model; its cold compile is shared with test_narrow_products.py and
# test_read_ahead_start.py), also through `verilator --binary` in test_chirp_accuracy_verilator_binary.
# The fast preset (the same short chain, its products unshared and two blocks wide) runs outside CI:
# `make sim TB_ARGS="--preset fast"` (every suite on both simulators) and make bench's synthesis.
SCHEDULES = {"icarus": None, "verilator": {"preset": "thesis"}}

# Which suites each simulator runs here: the core on both, each bus wrapper's whole suite on one
# (the RAPTOR one on Icarus, the AXI4-Lite one on Verilator). The wrappers do not depend on the
# schedule beyond ``ready``, the two suites are the same tests through another bus, and each
# Verilator suite is a build of the whole core (Verilator also reads the RAPTOR wrapper in
# tests/test_sim_debug_status.py, its debug build, and runs its reset values for a new plant in
# tests/test_new_plant_end_to_end.py); `make sim` runs every suite on both simulators.
SUITES = {"icarus": ("core", "raptor"), "verilator": ("core", "axil")}


# The CI profile of the cocotb suites on both simulators: every every-step window, the bus
# tests, the overflow scenario and 10 ms long runs (the chirp's from its golden state half-way).
# The full profile's seconds from reset (2 s of the chirp, 1 s of full-scale random levels for
# the encoders) run the same RTL on more of the same kind of input: the 2 s chirp from reset is
# test_chirp_accuracy_verilator_binary below (the thesis preset's build, bit-exact at every 1000th
# step), and long runs at full scale with the encoder counts compared after every ms are
# tests/test_rtl_full_scale.py (the minute and the spin). `make sim` runs the full profile.
CI_PROFILE = "ci"


@pytest.fixture(scope="module")
def hdl(tmp_path_factory):
    return pendtb.prepare_hdl(tmp_path_factory.mktemp("sim_hdl"))


@pytest.fixture(scope="module")
def preset_hdl(tmp_path_factory):
    return pendtb.prepare_hdl(tmp_path_factory.mktemp("sim_hdl_preset"), request=SCHEDULES["verilator"])


@pytest.fixture(scope="module")
def prepared(hdl):
    return pendtb.add_vectors(hdl)


@pytest.fixture(scope="module")
def preset_prepared(preset_hdl):
    return pendtb.add_vectors(preset_hdl)


@pytest.mark.parametrize("sim", pendtb.SIMS)
def test_cocotb_regression(sim, request, tmp_path):
    why = pendtb.simulator_missing(sim)
    if why:
        pytest.skip(why)
    prepared = request.getfixturevalue("preset_prepared" if SCHEDULES[sim] else "prepared")
    assert prepared.report["raptor"]["ii"] > 2
    # the default build regressed is the committed hdl_out/ itself (test_emit.py proves it current)
    assert prepared.repo_hdl == (SCHEDULES[sim] is None), "hdl_out/ was not recognised as current"
    assert prepared.report["raptor"]["schedule"].get("preset") == (SCHEDULES[sim] or {}).get("preset", "default")
    # the preset's own arithmetic reaches the RTL (the short chain: no acceleration node, dt folded into the tables)
    assert ("ddx" in prepared.report["raptor"]["qformats"]) == (SCHEDULES[sim] is None)
    lines = []
    results = pendtb.run_suites(prepared, [sim], list(SUITES[sim]), tmp_path, profile=CI_PROFILE, log=lines.append)
    print("\n".join(lines))
    problems = []
    for r in results:
        if r.tests == 0:
            problems.append(f"{sim}/{r.suite}: no cocotb test ran (log {r.log})")
        problems += [f"{sim}/{r.suite}: {f}" for f in r.failures]
        problems += [f"{sim}/{r.suite}: {t} skipped (the default model must reach every check)" for t in r.skipped]
    assert [r.suite for r in results] == list(SUITES[sim]), f"not every suite ran on {sim}"
    assert not problems, "cocotb failures:\n" + "\n".join(problems)


def test_chirp_accuracy_verilator_binary(preset_hdl, tmp_path):
    """The issue's chirp, 2 s from reset, through `verilator --binary` (the thesis preset's build,
    whose cocotb suites run windows of it): within 0.5 mm and 5 mrad of the float simulator, and
    bit-exact with the golden model of that build at every 1000th step."""
    why = pendtb.simulator_missing("verilator")
    if why:
        pytest.skip(why)
    import vbinary
    r = vbinary.chirp_run(preset_hdl.hdl["raptor"], preset_hdl.report["raptor"], tmp_path, seconds=2.0,
                          build_=preset_hdl.build)
    print(f"chirp 2 s: max |x - float| {r['max_abs_x_error_m']:.3g} m, max |theta - float| "
          f"{r['max_abs_theta_error_rad']:.3g} rad, {r['steps_per_s']:.3g} steps/s")
    assert r["bit_exact_vs_golden_every_1000"], f"harness differs from the golden model: {r['first_golden_difference']}"
    assert not r["overflow"], "the core overflowed on the chirp"
    assert r["max_abs_x_error_m"] <= 0.5e-3, f"max |x - float| = {r['max_abs_x_error_m']:.3g} m > 0.5 mm"
    assert r["max_abs_theta_error_rad"] <= 5e-3, f"max |theta - float| = {r['max_abs_theta_error_rad']:.3g} rad > 5 mrad"
