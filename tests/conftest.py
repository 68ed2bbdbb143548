"""Order of the test files, so that ``make test`` (pytest-xdist, ``--dist loadfile
--no-loadscope-reorder``) keeps both workers busy until the end.

xdist hands out whole files in collection order, a new one whenever a worker is nearly out
of work. Its default order (most tests first) put the files with a few long tests, the
simulator regressions and builds, at the very end, so one worker ran them alone while the
other had finished. Here the slowest files go first, longest first, and the rest follow with
the most tests first (xdist's own order), so the last files handed out are the short ones.

``SLOWEST_FIRST`` is measured (``pytest --durations=0``, per file, clean clone; see
docs/testing.md). It only decides the order: a file missing from it still runs, after the
listed ones. The first two files compile different models (the default and the rig), so the
two workers do not compile the same model at the same moment on a cold cache (if they do, the
build cache's lock makes the second wait for the first's entry instead of compiling it again).
The Furuta's full build is first needed by test_emit.py, well before test_sim_second_plant.py.
"""

from __future__ import annotations

from collections import Counter

SLOWEST_FIRST = (
    "test_sim.py",                  # cocotb regression: Icarus (ii 6) and Verilator (comb); the default model
    "test_rtl_full_scale.py",       # the rig model: golden minute and spin, Verilator and Icarus windows
    "test_backend_models.py",       # six effect variants built and simulated on Icarus
    "test_diagnose_cases.py",       # hidden-effect cases, first half
    "test_diagnose.py",             # two effects in turn, unexplained physics
    "test_diagnose_more_cases.py",  # hidden-effect cases, second half
    "test_sim_shared_multipliers.py",   # tb/run.py on a quick model, small preset, Icarus
    "test_emit.py",                 # the Furuta's full build (cached for test_sim_second_plant and the HIL)
    "test_sim_debug_status.py",
    "test_hostile_commands.py",
    "test_help.py",
    "test_hil_rtl_cpp.py",
    "test_ident_experiments.py",
    "test_sim_second_plant.py",
    "test_error_budget.py",
    "test_compiled.py",
    "test_ident_offsets.py",
    "test_cli_ident.py",
    "test_ident_shipped.py",
    "test_hil_scenarios.py",
    "test_build_schedule.py",
    "test_build_cache_lock.py",
)


def pytest_collection_modifyitems(session, config, items):
    """Slowest files first (``SLOWEST_FIRST``), then by number of tests; a file's own order kept."""
    rank = {name: i for i, name in enumerate(SLOWEST_FIRST)}
    count = Counter(item.path for item in items)
    items.sort(key=lambda item: (rank.get(item.path.name, len(rank)), -count[item.path], str(item.path)))
