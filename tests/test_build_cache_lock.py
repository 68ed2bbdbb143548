"""The build cache's lock: two processes that miss the same entry at once compile it once; the
second waits for the first and reads the entry it wrote (pytest-xdist's two workers, or two
terminals, asking for one model on a cold cache)."""

import os
import subprocess
import sys
import textwrap

# Each process loads the model, says it is ready, waits until both are, then asks the cache for
# the default model's build with the compilation replaced by a slow stand-in that logs its pid.
SCRIPT = textwrap.dedent("""
    import os, sys, time
    from dataclasses import dataclass
    from pathlib import Path
    import pendc.caching.build_cache as bc
    from pendc import load_model

    @dataclass(frozen=True)
    class Built:
        model: object
        pid: int

    def slow_compile(model, options):
        with open(sys.argv[1], "a") as fh:
            fh.write(f"{os.getpid()}\\n")
        time.sleep(1.5)
        return Built(model, os.getpid())

    bc.compile_model = slow_compile
    model = load_model()
    ready = Path(sys.argv[2])
    (ready / str(os.getpid())).touch()
    while len(list(ready.iterdir())) < 2:
        time.sleep(0.01)
    print(bc.compile_cached(model).pid)
""")


def test_two_processes_missing_the_same_entry_compile_it_once(tmp_path):
    log, ready = tmp_path / "compiled.log", tmp_path / "ready"
    ready.mkdir()
    env = dict(os.environ, PENDC_CACHE_DIR=str(tmp_path / "cache"))
    procs = [subprocess.Popen([sys.executable, "-c", SCRIPT, str(log), str(ready)], env=env, text=True,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE) for _ in range(2)]
    outs = [p.communicate(timeout=120) for p in procs]
    assert all(p.returncode == 0 for p in procs), [err[-2000:] for _, err in outs]
    compiled = log.read_text().split()
    assert len(compiled) == 1, f"compiled by {len(compiled)} processes: {compiled}"
    # both got the one compilation's result: the first its own, the second the entry it waited for
    assert [out.strip() for out, _ in outs] == compiled * 2
    assert len(list((tmp_path / "cache" / "builds").glob("build_*.pickle"))) == 1
