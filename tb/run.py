"""Run the cocotb regression: ``python tb/run.py --sim icarus|verilator|both [--model M.toml]``.

Prepares the HDL of the default model (the repository's hdl_out/ if ``pendc build
--check`` says it is current, else a fresh build under the work folder) or of the
model file given by ``--model`` (always built under the work folder, never into
hdl_out/), with the default schedule or the one ``--preset`` / ``--ii`` / ``--dsp``
ask for, and the golden vectors once, then runs the suites on each simulator:

    core    tb/test_core.py on the model's core (with the testbench decoders)
    raptor  tb/test_bus.py on the RAPTOR local-bus wrapper
    axil    tb/test_bus.py on the AXI4-Lite wrapper

Every name of the plant (module, ports, registers) comes from the model's plant interface.

Exit status 0 if every test passed, 1 if some failed, 2 on a usage or setup error.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import pendtb  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="tb/run.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--sim", choices=("icarus", "verilator", "both"), default="both")
    ap.add_argument("--suite", action="append", choices=tuple(pendtb.SUITES),
                    help="suite(s) to run (default: all)")
    ap.add_argument("--profile", choices=("quick", "full"),
                    help="quick: short long-runs; full: seconds of model time (default: quick on Icarus, "
                         "full on Verilator)")
    ap.add_argument("--work", default=str(pendtb.REPO / "sim_build"),
                    help="work folder: HDL, vectors, simulator builds and logs (default: sim_build/, git-ignored "
                         "and removed by `make clean`)")
    ap.add_argument("--no-repo-hdl", action="store_true", help="always build the HDL, even if hdl_out/ is current")
    ap.add_argument("--serial", action="store_true", help="one suite at a time (default: two in parallel)")
    ap.add_argument("-k", "--testcase", help="only the cocotb test(s) with this name (comma-separated; the golden "
                                               "vectors then hold only what they read)")
    ap.add_argument("--waves", action="store_true", help="record waveforms")
    ap.add_argument("--json", help="write a summary JSON here")
    ap.add_argument("--model", help="model file whose HDL to test (default: the default model)")
    ap.add_argument("--preset", choices=("default", "fast", "fmax", "small", "comb", "thesis"),
                    help="schedule preset (as pendc build)")
    ap.add_argument("--ii", type=int, help="clock cycles per model step (as pendc build --ii)")
    ap.add_argument("--dsp", type=int, help="DSP-block budget (as pendc build --dsp)")
    args = ap.parse_args(argv)
    if args.model is not None and not Path(args.model).is_file():
        print(f"tb/run.py: error: no model file {args.model}", file=sys.stderr)
        return 2
    request = {k: v for k, v in (("preset", args.preset), ("ii", args.ii), ("dsp", args.dsp)) if v is not None}

    sims = pendtb.SIMS if args.sim == "both" else (args.sim,)
    suites = tuple(args.suite or pendtb.SUITES)
    for sim in sims:
        why = pendtb.simulator_missing(sim)
        if why:
            print(f"tb/run.py: error: {why}", file=sys.stderr)
            return 2
    work = Path(args.work).resolve()      # the simulators run in their own folders: a relative path would not reach them
    t_all = time.time()
    try:
        prep = pendtb.prepare(work, use_repo_hdl=not args.no_repo_hdl, model_path=args.model, request=request,
                              testcase=args.testcase)
    except Exception as exc:  # a bad model file or schedule: one line, like pendc
        from pendc.errors import PendcError
        if not isinstance(exc, (PendcError, OSError, ValueError)):
            raise
        print(f"tb/run.py: error: {exc}", file=sys.stderr)
        return 2
    t_prep = time.time() - t_all

    t0 = time.time()
    results = pendtb.run_suites(prep, sims, suites, work / "sim", profile=args.profile, jobs=1 if args.serial else 2,
                                testcase=args.testcase, waves=args.waves,
                                log=lambda text: print(text, flush=True))
    t_sims = time.time() - t0
    total = time.time() - t_all
    failed = sum(r.failed for r in results) + sum(1 for r in results if r.tests == 0 and not args.testcase)
    skipped = sum(len(r.skipped) for r in results)
    skips = f", {skipped} skipped (reasons above)" if skipped else ""
    per_sim = {sim: sum(r.build_s + r.test_s for r in results if r.sim == sim) for sim in sims}
    print(f"tb/run.py: preparation {t_prep:.1f} s; simulations {t_sims:.1f} s wall "
          f"({', '.join(f'{sim} {t:.1f} s' for sim, t in per_sim.items())} of build+test); total {total:.1f} s; "
          f"{'all passed' if not failed else f'{failed} failed'}{skips} (work folder {work})")
    if args.json:
        Path(args.json).write_text(json.dumps({
            "preparation_s": t_prep, "simulations_s": t_sims, "total_s": total, "per_sim_build_test_s": per_sim,
            "suites": [{"sim": r.sim, "suite": r.suite, "tests": r.tests, "failed": r.failed,
                        "failures": r.failures, "skipped": r.skipped, "build_s": r.build_s, "test_s": r.test_s}
                       for r in results],
        }, indent=2) + "\n")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
