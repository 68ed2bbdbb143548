"""``pendc simulate``: a model's float or bit-accurate run on an input file, and its argument checks."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace

from ..errors import PendcError
from .options import MODEL_HELP, positive


def initial_state(text: str) -> tuple:
    """``--x0``: comma-separated numbers (their count is checked against the model's states later)."""
    parts = text.split(",")
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if not values:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, one per state, got {text!r}")
    return values


def _check_x0(x0, iface) -> None:
    """``--x0`` has one value per reported state of the model (its plant interface's order)."""
    if x0 is not None and len(x0) != len(iface.outputs):
        raise PendcError(f"argument --x0: expected {len(iface.outputs)} numbers {','.join(iface.outputs)}, "
                         f"got {len(x0)}")


def cmd_simulate(args) -> int:
    """Run the model (float, or bit-accurate with ``--fixed``) on the input file; CSV out."""
    from ..model.modelfile import load_model
    from ..sim.measurements import format_csv, read_measurements
    from ..atomic import check_file_output
    from ..sim.signals import TIME
    from ..sim.simulator import Simulator, sensor_offsets
    from ..model.modes import euler_shortfall
    from ..passes.pipeline import core_step
    from .data import note
    from .options import build_model, write_output

    if args.output not in (None, "-"):
        check_file_output(args.output)   # before the run, which may compile the model first
    model = load_model(args.model)
    _check_x0(args.x0, model.interface)
    from ..sim.read_options import ReadOptions
    data = read_measurements(args.input, required=(TIME, model.interface.input.name),
                             options=ReadOptions(plant=model))
    _check_input_range(data, model.interface.input)
    for w in data.warnings:
        print(f"pendc: warning: {w}", file=sys.stderr)
    core_dt = core_step(model)
    if args.fixed:
        from ..golden import GoldenModel

        if args.method != "euler":
            raise PendcError("--fixed runs the hardware model with its own 1-step Euler integrator (no --method)")
        if args.dt is not None and abs(args.dt - core_dt) > 1e-9 * core_dt:
            raise PendcError(f"--fixed steps as the core was built, every {core_dt:g} s (the plant file's [hardware] "
                             f"dt or the build's default); drop --dt {args.dt:g}, or set [hardware] dt in the file")
        build = build_model(model, args)
        run = GoldenModel(build.graph, build.options.dt)(data.t, data.u, on_overflow=args.on_overflow,
                                                          initial=args.x0)
        # the core computes the motion; what the sensors read adds the model's sensor offsets,
        # as the float run's columns do
        off = sensor_offsets(model)
        outputs = {name: column + off.get(name, 0.0) for name, column in run.result.states.items()}
        if args.quantize:
            _quantize_measured(run.result.states, model.interface)
            _quantize_measured(outputs, model.interface)
        result = replace(run.result, outputs=outputs)
        columns = result.columns()
        if args.on_overflow == "mark":
            # every row computed after the sticky flag rose is marked, not just the first
            columns["overflow"] = run.marked_rows()
            if run.overflows:
                node, step = min(run.overflows.items(), key=lambda kv: (kv[1], kv[0]))
                print(f"pendc: warning: node '{node}' left its Q-format range at t = {step * build.options.dt:.6g} s; "
                      f"{int(columns['overflow'].sum())} row(s) marked in column 'overflow'", file=sys.stderr)
        method, dt = "fixed-point (bit-accurate)", build.options.dt
    else:
        if args.on_overflow != "error":
            raise PendcError("--on-overflow applies to --fixed runs (the float model has no formats)")
        dt = core_dt if args.dt is None else args.dt
        sim = Simulator(model, dt=dt, method=args.method)
        shortfall = euler_shortfall(model, dt, core_dt) if args.method == "euler" else None
        if shortfall:
            note(shortfall)
        result = sim(data.t, data.u, x0=args.x0, quantize=args.quantize)
        columns = result.columns()
        method = args.method
    meta = {"generator": "pendc simulate", "model": model.source, "method": method,
            "dt": repr(dt), "quantized": str(bool(args.quantize)).lower()}
    write_output(args.output, format_csv(columns, meta))
    return 0


def _quantize_measured(states: dict, iface) -> None:
    """Replace every sensed state by what its sensor reports (an encoder: counts from the first
    sample times its resolution; a converter: its code's step), as ``--quantize`` asks."""
    from ..sim.encoders import sensor_reading

    for sensor in iface.sensors:
        states[sensor.state] = sensor_reading(sensor, states[sensor.state])


def _check_input_range(data, inp) -> None:
    """The input (``inp``, an InputSpec) far beyond what its actuator takes (INPUT_MARGIN times its
    full scale): a unit mistake such as millivolts (many rows) or an outlier (a few), named by
    line, before a simulation of nonsense. Only the input: the other columns of a file (a
    simulation's own output, say) are not read."""
    from ..model.interface import is_dimensionless
    from ..sim import plausibility
    from ..sim.table import Table

    table = Table(columns={}, meta={}, source=data.source, first_line=data.first_line)
    if is_dimensionless(inp.unit):   # no unit to name: a percentage is the likely slip
        fix = ("a percentage or another scale", f"give {inp.name} as a plain number on the scale of its range, "
               "not in percent")
    else:
        fix = ("millivolts" if inp.unit == "V" else f"another unit than {inp.unit}", f"give {inp.name} in {inp.unit}")
    plausibility.check_bounded(table, inp.name, data.u, plausibility.INPUT_MARGIN * inp.full_scale, inp.unit,
                               f"the input takes {inp.range.describe()}", fix)


def add_parsers(sub) -> None:
    p = sub.add_parser("simulate", help="float simulation of a model on an input file")
    p.add_argument("--model", help=MODEL_HELP)
    p.add_argument("--input", required=True, help="measurement file with the time and the model's input as columns "
                   "(the default model: {plant:time} in s and {plant:input} in {plant:input_unit}): pendc's CSV "
                   "(',' ';' tab or whitespace separated, '# key: value' comments) or MATLAB .mat; '-': standard "
                   "input; other columns are ignored")
    p.add_argument("-o", "--output", help="output CSV: the time, the input and the model's states (the default "
                                          "model: {plant:columns} then the rates); default (or '-'): standard "
                                          "output")
    p.add_argument("--dt", type=positive, help="integration step in s (default: the core's, the plant file's "
                                               "[hardware] dt, else 1e-6; --fixed takes no other)")
    p.add_argument("--method", choices=("euler", "rk4"), default="euler", help="integrator (default euler)")
    p.add_argument("--x0", type=initial_state, help="initial state, one number per state in the order pendc plant check "
                                             "lists them (the default model: {plant:states}; the output's columns "
                                             "put the positions first); default: the file's initial values (at "
                                             "rest, all 0, for a mechanism); with --fixed the state registers start "
                                             "there; a negative first number needs --x0=-1,...")
    p.add_argument("--quantize", action="store_true", help="quantise the states the model's encoders read (the "
                                                           "default model: {plant:positions}) to x4 encoder counts")
    p.add_argument("--fixed", action="store_true", help="bit-accurate run of the compiled hardware model")
    p.add_argument("--on-overflow", choices=("error", "mark"), default="error",
                   help="--fixed: a value leaving its Q-format range stops the run with an error naming the node "
                        "and the time (default), or 'mark' continues and flags every affected row in a column "
                        "'overflow'")
    p.add_argument("--no-cache", action="store_true", help="recompile even if a cached build exists")
    p.set_defaults(func=cmd_simulate)
