"""One batch of the long differential fuzz run (bench/fuzz.py): the task a Dask worker runs.

A batch is a function of (seed, size, options) alone: ``draw_cases`` gives the same graphs from
the same seed whatever ran before in the process, and the checks and the shrinking are
deterministic, so the run's findings do not depend on how many workers share the batches. The
result is plain JSON (counts keyed by text), kept as one file per batch by the sweep engine.

bench/fuzz.py uploads this module and the test helpers it imports (tests/graphgen.py,
fuzzcases.py, fuzzharness.py, fuzzshrink.py) to every worker, so a worker on another machine
needs pendc and the simulators installed, not this repository.
"""

from __future__ import annotations

import tempfile
import time
from collections import Counter
from pathlib import Path

from fuzzcases import case_source, draw_cases
from fuzzharness import check_batch
from fuzzshrink import shrink

# the test helpers a worker must import (beside this module), uploaded by bench/fuzz.py
HELPERS = ("graphgen.py", "fuzzcases.py", "fuzzharness.py", "fuzzshrink.py")


def run_batch(b: int, count: int, seed: int, sim: str, golden: int, shrink_count: int) -> dict:
    """Check batch ``b`` (``count`` graphs drawn from ``seed``) in one simulator build: its counts,
    timings and mismatches (the first ``shrink_count`` mismatched graphs shrunk under Icarus)."""
    import warnings

    warnings.simplefilter("ignore")     # hypothesis' own notes about non-test use
    timings: Counter = Counter()
    t0 = time.perf_counter()
    cases = draw_cases(count, seed)
    timings["generate"] += time.perf_counter() - t0
    mismatches, kinds = [], Counter()
    with tempfile.TemporaryDirectory(prefix="pendc-fuzz-") as tmp:
        result = check_batch(cases, Path(tmp) / f"b{b}", sim, golden=golden)
        timings.update(result.timings)
        for c in cases:
            kinds.update(n.kind.value for n in c.graph.nodes)
        shrunk = {}
        for m in result.mismatches:
            if m.case not in shrunk and len(shrunk) < shrink_count:
                small = shrink(cases[m.case], Path(tmp) / "shrink", "icarus")
                shrunk[m.case] = case_source(small)
            mismatches.append({"batch": b, "seed": seed, "case": m.case, "engine": m.engine,
                               "step": m.step, "port": m.port, "expected": m.expected, "actual": m.actual,
                               "detail": m.detail, "graph": cases[m.case].graph.text(),
                               "shrunk": shrunk.get(m.case)})
    return {"graphs": count, "golden_checked": result.golden_checked, "mismatches": mismatches,
            "node_kinds": dict(kinds), "ii": {str(k): v for k, v in Counter(result.ii).items()},
            "lint_warnings": dict(Counter(w.split(":")[0] for w in result.warnings)),
            "timings_s": dict(timings)}
