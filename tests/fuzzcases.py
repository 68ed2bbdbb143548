"""Running the graph strategies outside a property test: the cases of a seed, and a case as Python.

:func:`draw_cases` is how the quick profile and the long run get their graphs (a seed fully
determines them); :func:`case_source` prints a (shrunk) case as code for a regression test.
"""

from __future__ import annotations

import math
from contextlib import contextmanager

from graphgen import FuzzCase, fuzz_cases


def case_source(case: FuzzCase, name: str = "case") -> str:
    """Python source that rebuilds ``case`` (for shrunk counterexamples in regression tests)."""
    lines = [f"{name} = FuzzCase(", "    graph=Graph.build(\"fuzz\", ["]
    for n in case.graph.nodes:
        params = ", ".join(f"{k}={v!r}" for k, v in n.params)
        q = n.qformat
        lines.append(f"        make({n.name!r}, Kind.{n.kind.name}, {n.inputs!r}, qformat=QFormat({q.signed}, {q.width}, {q.frac}), "
                     f"rounding=Rounding.{n.rounding.name}, overflow=Overflow.{n.overflow.name}"
                     + (f", {params}" if params else "") + "),")
    lines.append(f"    ], {case.graph.outputs!r}),")
    lines.append(f"    u={case.u!r},")
    sched = None if case.schedule is None else tuple("math.inf" if x == math.inf else repr(x) for x in case.schedule)
    lines.append(f"    schedule={'None' if sched is None else '(' + ', '.join(sched) + ')'})")
    return "\n".join(lines) + "\n"


@contextmanager
def _no_local_constants():
    """Hypothesis mixes in numbers it finds in the source of every loaded local module (the
    golden kernels compiled so far among them), which would make a seed's cases depend on what
    ran before: draw without them. Private API, hence the guard."""
    try:
        from hypothesis.internal.conjecture import providers
        empty = providers.Constants()
        original = providers._get_local_constants
    except (ImportError, AttributeError):
        yield
        return
    providers.CONSTANTS_CACHE.cache.clear()
    providers._get_local_constants = lambda: empty
    try:
        yield
    finally:
        providers._get_local_constants = original
        providers.CONSTANTS_CACHE.cache.clear()


def draw_cases(count: int, seed: int, **options) -> list:
    """``count`` cases drawn by hypothesis from ``seed`` (deterministic: same seed, same cases,
    whatever ran before in the process); ``options`` go to :func:`fuzz_cases`."""
    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import seed as hypothesis_seed

    cases: list = []

    @hypothesis_seed(seed)
    @settings(max_examples=count, database=None, deadline=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @given(fuzz_cases(**options))
    def collect(case):
        cases.append(case)

    with _no_local_constants():
        collect()
    return cases[:count]
