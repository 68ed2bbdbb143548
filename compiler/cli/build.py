"""``pendc build``: compile a model to Verilog, or (``--check``) check that a folder holds what
the compiler emits now."""

from __future__ import annotations

import json
import sys

from ..errors import PendcError
from .options import MODEL_HELP, build_model, note_offsets as _note_offsets


def _warn_unmet_budget(report) -> None:
    """One line on standard error when the error budget is not met (the build stands: an open-loop
    unstable plant's float and fixed runs part by design, docs/error_budget.md)."""
    if report is None or report.met:
        return
    worst = max(((state, err / report.budgets[state]) for run in report.errors.values()
                 for state, err in run.items() if report.budgets.get(state)), key=lambda kv: kv[1], default=None)
    detail = f" ({worst[0]} {worst[1]:.3g} times its budget)" if worst else ""
    print(f"pendc: warning: the error budget is not met{detail}; pendc report qformat shows where "
          f"(docs/error_budget.md)", file=sys.stderr)


def cmd_build(args) -> int:
    from ..backend.hdl import build_hdl, build_request, differences, write_hdl
    from ..model.modelfile import build_source, load_model, model_fingerprint

    if args.preset is not None and args.ii is not None:
        raise PendcError("--preset and --ii both choose the schedule: give one of them")
    for flag, value in (("--ii", args.ii), ("--dsp", args.dsp)):
        if value is not None and value < 1:
            raise PendcError(f"{flag} must be a positive integer, got {value}")
    if args.output == "-":
        raise PendcError("build: -o names the output folder; a build is a folder of files, not standard output")
    model = load_model(args.model)
    build = build_model(model, args)
    # named by content and compiler version, never by path: the same model builds the same files anywhere
    source = build_source(model)
    request = build_request(build.options.target, preset=args.preset, ii=args.ii, dsp=args.dsp)
    files = build_hdl(build.graph, build.resources.to_json(), source=source, bus=args.bus, request=request,
                      debug_status=args.debug_status)
    if args.check:
        diff = differences(args.output, files)
        if diff:
            raise PendcError(f"{args.output} differs from what the compiler emits now: {', '.join(diff[:8])}")
        print(f"pendc: {args.output} is up to date ({len(files)} files)", file=sys.stderr)
        return 0
    write_hdl(args.output, files)
    _warn_unmet_budget(build.error)
    _note_offsets(model, "the core")
    if args.json:
        sys.stdout.write(files["report.json"])
    else:
        report = json.loads(files["report.json"])
        sched = report["schedule"]
        print(f"pendc: wrote {len(files)} files to {args.output}/ (model {model.source}, {model_fingerprint(model)}; "
              f"top {report['wrapper']} around "
              f"{report['top']}, {report['ii']} clock cycles per model step, "
              f"{report['resources'].get('dsp_scheduled', report['resources'].get('dsp'))} DSP blocks "
              f"{report['resources'].get('dsp_shape', '')}"
              f"{', schedule ' + sched['preset'] if sched.get('preset') else ''})", file=sys.stderr)
    return 0


def add_parsers(sub) -> None:
    p = sub.add_parser("build", help="compile the model to Verilog (hdl_out/)",
                       description="Compile the model to Verilog. The files name the model by its fingerprint "
                                   "(sha256 of its constants, effects and [hardware]) and the pendc version, never by "
                                   "its path, and the build id hashes them: the same model builds byte-identical "
                                   "files wherever it lies and wherever it is built from.")
    p.add_argument("--model", help=MODEL_HELP)
    p.add_argument("-o", "--output", default="hdl_out", help="output folder (default hdl_out)")
    p.add_argument("--bus", choices=("raptor", "axi-lite"), default="raptor", help="bus wrapper (default raptor)")
    p.add_argument("--json", action="store_true", help="print report.json")
    p.add_argument("--check", action="store_true", help="write nothing: check that the output folder holds exactly "
                   "what this build writes (exit 2 naming the files that differ)")
    p.add_argument("--no-cache", action="store_true", help="recompile even if a cached build exists")
    p.add_argument("--target", choices=("ecp5-85k", "ice40-up5k", "xc7", "xcu"),
                   help="FPGA whose multiplier shape the formats fit (default ecp5-85k: 18x18)")
    p.add_argument("--preset", choices=("default", "fast", "fmax", "small", "comb", "thesis"),
                   help="schedule: default = shortest step within 24 DSP blocks, fast = shortest step at 100 MHz "
                        "(clock goals up to 9.5 ns, a multiplier per product, the short-chain arithmetic), fmax = a "
                        "10 ns clock goal (partial-product registers, the short-chain arithmetic), small = 4 shared "
                        "DSP blocks, comb = no pipelining, thesis = shortest step within 24 DSP blocks at clock goals "
                        "up to 25 ns (the short-chain arithmetic, products narrowed where the error budget allows, "
                        "only products off the critical chain sharing a multiplier)")
    p.add_argument("--ii", type=int, help="clock cycles per model step: the scheduler packs the step into "
                   "exactly N cycles with the shortest clock it can")
    p.add_argument("--dsp", type=int, help="DSP-block budget: if a multiplier per product exceeds it, products "
                   "share K // (blocks of the widest product) multipliers across cycles")
    p.add_argument("--debug-status", action="store_true", help="debug build: a sticky overflow bit per node, "
                   "readable on both buses as OVERFLOW_STATUS_k (report.json lists the node of every bit)")
    p.set_defaults(func=cmd_build)
