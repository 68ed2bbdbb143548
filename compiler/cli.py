"""``pendc`` command line: a thin layer over the Python API.

Every command turns bad input into one ``pendc: error: ...`` line on stderr and
exit status 2; nothing is half-written (outputs go through a temporary file).
"""

from __future__ import annotations

import argparse
import json
import re
import sys

from .cli_common import build_model, write_output
from .cli_data import MODEL_HELP, positive as _positive
from .cli_simulate import cmd_simulate, initial_state
from .errors import PendcError


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage mistake is one line, like every other error."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # argparse takes "-1e-6" for an option ("expected one argument"); a number in any
        # notation is a value, so `--dt -1e-6` is refused for being negative, not misread
        self._negative_number_matcher = re.compile(r"^-(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?$|^-(?:inf|nan)$")

    def _get_formatter(self):
        # help texts cite the plant through {plant:WORD}, filled from the interface when printed
        from .cli_help import formatter_with_plant_words

        return formatter_with_plant_words(self.formatter_class)(prog=self.prog)

    def format_help(self) -> str:
        """argparse's help; fit and diagnose also list every body's effect catalogue (names for --add)."""
        text = super().format_help()
        if self.prog.split()[-1] in ("fit", "diagnose"):
            from .cli_help import effects_by_body

            text += "\n" + effects_by_body()
        return text

    def parse_known_args(self, args=None, namespace=None):
        """argparse's, but a sub-command refuses what it does not take itself, naming itself and
        what it does take (the top level would only say "unrecognized arguments"); a command
        reading data also takes ``--<SIGNAL>-unit/-zero/-sign VALUE`` for ``--unit/--zero/--sign
        SIGNAL=VALUE``."""
        if args is not None and "--unit" in self._option_string_actions:
            from .cli_data import expand_signal_options

            try:
                args = expand_signal_options(list(args), self._option_string_actions)
            except PendcError as exc:
                self.error(str(exc))
        parsed, extras = super().parse_known_args(args, namespace)
        if extras and self.prog != "pendc":
            takes = [a.option_strings[-1] for a in self._actions
                     if a.option_strings and not isinstance(a, argparse._HelpAction)]
            self.error(f"unrecognized arguments: {' '.join(extras)}"
                       + (f" ({self.prog.removeprefix('pendc ')} takes {', '.join(takes)})" if takes else ""))
        return parsed, extras

    def error(self, message):
        # the top-level parser's prog is "pendc", which main() already prints once
        prefix = self.prog.removeprefix("pendc").strip()
        raise PendcError(f"{prefix}: {message}" if prefix else message)


def _emit_json(obj) -> None:
    json.dump(obj, sys.stdout, indent=2, sort_keys=False)
    sys.stdout.write("\n")


def cmd_stimulus(args) -> int:
    from .sim.measurements import format_csv
    from .sim.signals import TIME
    from .model.modelfile import load_model
    from .sim.stimuli import Stimuli

    inp = load_model(getattr(args, "model", None)).interface.input
    stimuli = Stimuli(inp).named()
    if args.name not in stimuli:
        raise PendcError(f"unknown stimulus '{args.name}' (known: {', '.join(stimuli)})")
    t, u = stimuli[args.name]
    name = inp.name
    write_output(args.output, format_csv({TIME: t, name: u}, {"generator": "pendc stimulus", "stimulus": args.name}))
    return 0


def cmd_build(args) -> int:
    from .backend.hdl import build_hdl, differences, write_hdl
    from .model.modelfile import build_source, load_model, model_fingerprint

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
    request = {"target": build.options.target, "preset": args.preset, "ii": args.ii, "dsp": args.dsp}
    files = build_hdl(build.graph, build.resources.to_json(), source=source, bus=args.bus,
                      request={k: v for k, v in request.items() if v is not None},
                      debug_status=args.debug_status)
    if args.check:
        diff = differences(args.output, files)
        if diff:
            raise PendcError(f"{args.output} differs from what the compiler emits now: {', '.join(diff[:8])}")
        print(f"pendc: {args.output} is up to date ({len(files)} files)", file=sys.stderr)
        return 0
    write_hdl(args.output, files)
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


def cmd_report(args) -> int:
    from .model.modelfile import load_model
    from . import reports

    if args.what == "synth":
        from .synth import format_synth_report, synthesize
        result = synthesize(args.build_dir, args.target, freq_mhz=args.freq, use_cache=not args.no_cache,
                            log=lambda text: print(f"pendc: {text}", file=sys.stderr))
        if args.json:
            _emit_json(result.to_json())
        else:
            sys.stdout.write(format_synth_report(result))
        return 0
    model = load_model(args.model)
    build = build_model(model, args)
    if args.what == "qformat":
        report = reports.qformat_report(build)
        if args.drift:
            from .sim.stimuli import Stimuli
            on = Stimuli(model.interface.input)
            report["drift"] = reports.drift_report(build, {"chirp": on.chirp(), "swing_up": on.swing_up()})
        text = reports.format_qformat_report(report)
    else:
        report = reports.resources_report(build)
        text = reports.format_resources_report(report)
    if args.json:
        _emit_json(report)
    else:
        sys.stdout.write(text)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="pendc", description="Compiler and identification workbench for HIL plant models.")
    from . import __version__
    parser.add_argument("--version", action="version", version=f"pendc {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    p = sub.add_parser("simulate", help="float simulation of a model on an input file")
    p.add_argument("--model", help=MODEL_HELP)
    p.add_argument("--input", required=True, help="measurement file with the time and the model's input as columns "
                   "(the default model: {plant:time} in s and {plant:input} in {plant:input_unit}): pendc's CSV "
                   "(',' ';' tab or whitespace separated, '# key: value' comments) or MATLAB .mat; '-': standard "
                   "input; other columns are ignored")
    p.add_argument("-o", "--output", help="output CSV: the time, the input and the model's states (the default "
                                          "model: {plant:columns} then the rates); default (or '-'): standard "
                                          "output")
    p.add_argument("--dt", type=_positive, default=1e-6, help="integration step in s (default 1e-6)")
    p.add_argument("--method", choices=("euler", "rk4"), default="euler", help="integrator (default euler)")
    p.add_argument("--x0", type=initial_state, help="initial state, one number per state in the model's order (the "
                                             "default model: {plant:states}; default: at rest, all 0); "
                                             "with --fixed the state registers start there")
    p.add_argument("--quantize", action="store_true", help="quantise the states the model's encoders read (the "
                                                           "default model: {plant:positions}) to x4 encoder counts")
    p.add_argument("--fixed", action="store_true", help="bit-accurate run of the compiled hardware model")
    p.add_argument("--on-overflow", choices=("error", "mark"), default="error",
                   help="--fixed: a value leaving its Q-format range stops the run with an error naming the node "
                        "and the time (default), or 'mark' continues and flags every affected row in a column "
                        "'overflow'")
    p.add_argument("--no-cache", action="store_true", help="recompile even if a cached build exists")
    p.set_defaults(func=cmd_simulate)

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
    p.add_argument("--preset", choices=("default", "fast", "fmax", "small", "comb"),
                   help="schedule: default = shortest step within 24 DSP blocks, fast = shortest step at 100 MHz "
                        "(clock goals up to 9.5 ns, a multiplier per product, the short-chain arithmetic), fmax = a "
                        "10 ns clock goal (partial-product registers, the short-chain arithmetic), small = 4 shared "
                        "DSP blocks, comb = no pipelining")
    p.add_argument("--ii", type=int, help="clock cycles per model step: the scheduler packs the step into "
                   "exactly N cycles with the shortest clock it can")
    p.add_argument("--dsp", type=int, help="DSP-block budget: if a multiplier per product exceeds it, products "
                   "share K // (blocks of the widest product) multipliers across cycles")
    p.add_argument("--debug-status", action="store_true", help="debug build: a sticky overflow bit per node, "
                   "readable on both buses as OVERFLOW_STATUS_k (report.json lists the node of every bit)")
    p.set_defaults(func=cmd_build)

    from .cli_ident import add_parsers as add_identification_parsers
    from .cli_hil import add_parsers as add_hil_parsers
    from .cli_plant import add_parsers as add_plant_parsers
    from .cli_explore import add_parser as add_explore_parser
    from .cli_robust import add_parser as add_robust_parser
    add_hil_parsers(sub)
    add_robust_parser(sub)
    add_explore_parser(sub)
    add_plant_parsers(sub)
    add_identification_parsers(sub)

    _add_report_parsers(sub)

    p = sub.add_parser("stimulus", help="write one of the standard input signals as a CSV (t and the model's input)")
    p.add_argument("name", help="chirp_low, chirp_high, steps, swing_up or random")
    p.add_argument("--model", help="model whose input the signal drives: its name, range and neutral value (default: the default model)")
    p.add_argument("-o", "--output", help="output CSV; default (or '-'): standard output")
    p.set_defaults(func=cmd_stimulus)
    return parser


def _add_report_parsers(sub) -> None:
    """``report qformat|resources|synth``: a sub-parser per kind, so each takes (and its --help
    lists) only the options that mean something for it."""
    p = sub.add_parser("report", help="reports on the compiled model: qformat, resources, or synth "
                       "(Yosys + nextpnr on a build folder)",
                       description="Reports on the compiled model. Each kind takes its own options: "
                                   "pendc report KIND --help.")
    kinds = p.add_subparsers(dest="what", metavar="KIND", required=True, parser_class=_Parser)
    q = kinds.add_parser("qformat", help="per signal its range, chosen Q-format and error against float")
    r = kinds.add_parser("resources", help="the resource estimate and DSP blocks per product")
    s = kinds.add_parser("synth", help="Yosys + nextpnr on a `pendc build` output folder (--build-dir)")
    for k in (q, r):
        k.add_argument("--model", help=MODEL_HELP)
        k.add_argument("--target", choices=("ecp5-85k", "ice40-up5k", "xc7"),
                       help="FPGA whose multiplier shape the formats fit (default ecp5-85k: 18x18)")
        k.add_argument("--json", action="store_true", help="machine-readable output")
        k.add_argument("--no-cache", action="store_true", help="recompile even if a cached build exists")
    q.add_argument("--drift", action="store_true", help="also measure fixed-vs-float drift on the full 20 s chirp "
                   "and 5 s swing-up")
    s.add_argument("--build-dir", default="hdl_out", help="the `pendc build` output folder (default hdl_out)")
    from .synth_targets import TARGETS
    s.add_argument("--target", choices=tuple(TARGETS), default="ecp5-85k",
                   help="FPGA target (default ecp5-85k: LFE5U-85F speed 6; xc7: Yosys counts only; "
                        "docs/hardware.md lists them)")
    s.add_argument("--freq", type=_positive, default=100.0, help="clock goal for nextpnr in MHz (default 100)")
    s.add_argument("--json", action="store_true", help="machine-readable output: target, top, ii, fmax_mhz, "
                   "step_ns, lut, ff, carry, dsp, bram, logic_depth, critical_path, cells, estimate, thesis")
    s.add_argument("--no-cache", action="store_true", help="run Yosys and nextpnr even if a cached result exists")
    p.set_defaults(func=cmd_report)


# the arguments that name a file to read (where '-' means standard input), by attribute
_INPUTS = {"model": "--model", "input": "--input", "data": "data file", "validate": "--validate", "run": "run"}


def _stdin_read_once(args) -> None:
    """Standard input holds one file: refuse a command line that gives '-' to two inputs."""
    given = []
    for attr, name in _INPUTS.items():
        value = getattr(args, attr, None)
        values = value if isinstance(value, list) else [value]
        given += [name for v in values if v is not None and str(v) == "-"]
    if len(given) > 1:
        raise PendcError(f"standard input ('-') can be read only once; it is given to {' and '.join(given)}")


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if not getattr(args, "func", None):
            parser.print_help(sys.stderr)
            return 2
        _stdin_read_once(args)
        return args.func(args)
    except PendcError as exc:
        print(f"pendc: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. `pendc ... | head`
        return 0
    except OSError as exc:  # unwritable output folder, disk full, ...
        print(f"pendc: error: {exc.filename or ''}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pendc: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
