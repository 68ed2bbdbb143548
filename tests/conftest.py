"""Order of the test files, so that ``make test`` (pytest-xdist, ``--dist loadfile
--no-loadscope-reorder``) keeps both workers busy until the end.

xdist hands out whole files in collection order, a new one whenever a worker is nearly out
of work. Its default order (most tests first) put the files with a few long tests, the
simulator regressions and builds, at the very end, so one worker ran them alone while the
other had finished. Here the slowest files go first, longest first, and the rest follow with
the most tests first (xdist's own order), so the last files handed out are the short ones.

``SLOWEST_FIRST`` is measured (``pytest --durations=0``, per file, clean clone; see
docs/testing.md; the seconds beside each file are those of commit be84764, less what a later
change of that file saved). It only decides the order: a file missing from it still runs, after the
listed ones. The first two files compile different models (the default and the rig), so the
two workers do not compile the same model at the same moment on a cold cache (if they do, the
build cache's lock makes the second wait for the first's entry instead of compiling it again).
The Furuta's full build is first needed by test_emit.py, well before test_sim_second_plant.py.
"""

from __future__ import annotations

import os
from collections import Counter

# One BLAS thread per process, set before anything imports numpy (the workers and every
# subprocess inherit it): the suite runs two workers on two cores, and OpenBLAS's threads spin
# after each call on the fits' long residual vectors, a quarter of a `pendc fit`'s CPU time
# (61 against 47 s, the same wall time) taken from the other worker.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

SLOWEST_FIRST = (
    "test_sim.py",                  # 455 CPU s at c257d7e; since then Verilator on the thesis preset (its cold compile, ~200 s)
    "test_rtl_full_scale.py",       # 151 s: the rig model: golden minute and spin, Verilator and Icarus windows
    "test_hidden_new_plants.py",    # ~120 s (estimated from a loaded run): the new plants' hidden effects
    "test_diagnose_cases.py",       # 103 s: hidden-effect cases, first half
    "test_diagnose.py",             # 100 s: two effects in turn (14 s experiment), unexplained physics (12 s)
    "test_new_plant_end_to_end.py", # ~90 s (estimated): a plant file's cold build, cocotb on both simulators
    "test_hil_operating_point.py",  # ~90 s (estimated): the double pendulum's design, a golden ball-beam run
    "test_ident_experiments.py",    # 79 s: the independent generator's experiments
    "test_diagnose_more_cases.py",  # 79 s: hidden-effect cases, second half
    "test_emit.py",                 # 67 s: the Furuta's full build (cached for test_sim_second_plant and the HIL)
    "test_synth.py",                # 75 s: YoWASP's first run compiles yosys and nextpnr
    "test_sim_second_plant.py",     # 75 s: the Furuta's core on both simulators
    "test_closed_loop_ident.py",    # 64 s (measured under load): four hidden-effect HIL runs, diagnosed and fitted
    "test_prediction_band.py",      # ~50 s (estimated): a fit and three compares with 20-draw bands
    "test_robust_engine.py",        # ~130 s (under load): Dask scheduler and workers as processes, faults, resume
    "test_robust_cli.py",           # ~60 s (under load): a 20-sample sweep, its page in headless Chromium
    "test_robust_golden_retype.py", # ~35 s (under load): the retyped core against the baked kernel
    "test_explore.py",              # 45-90 s warm, ~200 s with a cold synthesis cache: a DC motor's build, xc7 syntheses, Dask
    "test_fuzz_engine.py",          # ~35 s: fuzz batches on 1 and 2 Dask workers
    "test_sim_shared_multipliers.py",   # 57 s: tb/run.py on a quick model, small preset, Icarus
    "test_make_sim.py",             # ~45 s (estimated): make sim on the QUBE (its vectors)
    "test_quick_deposits.py",       # 32 s (a5d7840, clean clone): a private-check plant's cold build, Icarus core tests
    "test_new_plants.py",           # ~40 s (estimated): the double pendulum's short build
    "test_narrow_products.py",      # the thesis build's held-out check; its compile is test_sim's, cached by then
    "test_cli_ident.py",            # 100 s at 4368da0 (cold cache, 2 workers; so are the new entries below)
    "test_kernel_parts.py",         # ~50 s: split kernels of the every-kind graph (the whole ones are test_compiled's)
    "test_backend_models.py",       # 47 s: six effects in one model, built and simulated on Icarus
    "test_error_budget.py",         # 45 s
    "test_ident_shipped.py",        # 41 s
    "test_compiled.py",             # 23 s (its hand-graph kernels often compiled by test_kernel_parts first)
    "test_hil_animate.py",          # 37 s: headless Chromium
    "test_hil_scenarios.py",        # 35 s
    "test_hil_rtl_cpp.py",          # 32 s
    "test_build_schedule.py",       # 29 s
    "test_ident_offsets.py",        # 29 s
    "test_simulator.py",            # 28 s
    "test_pipeline.py",             # 25 s
    "test_fit.py",                  # 24 s
    "test_start_rates.py",          # 16 s: a coarse encoder's compare and fit (independent data)
    "test_hardware_dt.py",          # ~45 s: a small plant with [hardware] dt, one cold build, golden HIL and robust
    "test_fast_plants.py",          # 13 s: an RLC ladder at 10 kHz: compare, diagnose, fit, plant check
    "test_sim_debug_status.py",     # 24 s
    "test_fuzz_backend.py",         # 20 s
    "test_furuta_build.py",         # a few s: the Furuta build test_emit.py compiled (the build cache)
    "test_interpret.py",            # 16 s
    "test_api.py",                  # 14 s
    "test_full_scale.py",           # 4 s: leaving a range (the rig's minute and spin are test_rtl_full_scale's)
    "test_golden.py",               # 14 s
    "test_ident_second_plant.py",   # 13 s
    "test_datagen.py",              # 13 s
    "test_fit_objective.py",        # 17 s
    "test_held_axes.py",            # 13 s
    "test_build_cache_lock.py",     # two processes compile one entry
)


def pytest_collection_modifyitems(session, config, items):
    """Slowest files first (``SLOWEST_FIRST``), then by number of tests; a file's own order kept."""
    rank = {name: i for i, name in enumerate(SLOWEST_FIRST)}
    count = Counter(item.path for item in items)
    items.sort(key=lambda item: (rank.get(item.path.name, len(rank)), -count[item.path], str(item.path)))
