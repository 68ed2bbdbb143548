"""bench/bench_hil.py's socket part on a short run: its idle plant is a plant the server
accepts (it has the core's names, ``ports``), so ``make bench`` does not stop there."""

import importlib.util
from pathlib import Path

import pendc

BENCH = Path(__file__).resolve().parents[1] / "bench" / "bench_hil.py"


def test_socket_round_trips_against_the_idle_plant():
    spec = importlib.util.spec_from_file_location("bench_hil", BENCH)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    result = bench.bench_socket(bench.IdlePlant(pendc.load_model()), 0.05)
    assert result["completed"] and result["round_trips"] == 51, result
