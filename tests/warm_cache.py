"""Compile the models that many test files share, in parallel, before the suite starts.

`make test` runs this first: under pytest-xdist every worker that needs the default or the
rig model would otherwise compile it cold at the same moment (a minute or two each, the same
work twice); afterwards each one is a cache hit. The suite does not depend on it: without it
the tests compile what they need themselves.

    .venv/bin/python tests/warm_cache.py [MODEL.toml ...]
"""

from __future__ import annotations

import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = ("models/sct_thesis_final.toml", "models/sct_rig.toml")


def compile_one(path: str) -> str:
    """Compile ``path`` into the on-disk build cache (a hit if it is there already)."""
    from pendc.build_cache import compile_cached
    from pendc.model.modelfile import load_model
    compile_cached(load_model(path))
    return path


def main(argv: list[str]) -> int:
    paths = [str(REPO / p) for p in (argv or SHARED)]
    with ProcessPoolExecutor(max_workers=min(2, len(paths))) as pool:
        for done in pool.map(compile_one, paths):
            print(f"warm_cache: {Path(done).name} compiled", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
