"""``pendc hil`` (closed loop against a stepping plant) and ``pendc animate`` (virtual pendulum).

A thin layer over :mod:`pendc.hil`: build the plant and the controller, run the loop
(in-process or serving it to an external controller over TCP), write the run's files.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from .options import MODEL_HELP, note_offsets as _note_offsets, positive
from ..errors import PendcError


def _progress(enabled: bool):
    """A progress bar (tqdm) on stderr when it is a terminal, else None: ``show(fraction)``."""
    if not (enabled and sys.stderr.isatty()):
        return None
    from tqdm import tqdm

    bar = tqdm(total=100, unit="%", file=sys.stderr, dynamic_ncols=True, bar_format="{l_bar}{bar}| {elapsed}")

    def show(fraction: float):
        bar.update(round(100 * fraction) - bar.n)
        if fraction >= 1.0:
            bar.close()
    return show


def _address(text: str) -> tuple[str, int]:
    from ..hil.server import parse_loopback_address

    return parse_loopback_address(text)


def _check_out_folder(out: str) -> None:
    """Refuse an ``--out`` that cannot become the run's folder before the run, not after it."""
    from pathlib import Path

    if out == "-":
        raise PendcError("hil: --out names a folder for run.csv, summary.json and run.png, not standard output "
                         "(--json prints the summary)")
    folder = Path(out)
    if folder.exists() and not folder.is_dir():
        raise PendcError(f"{out}: is a file; --out names a folder for run.csv, summary.json and run.png")
    blocking = next((a for a in folder.parents if a.exists() and not a.is_dir()), None)
    if blocking is not None:
        raise PendcError(f"{out}: {blocking} is not a folder")


def cmd_hil(args) -> int:
    from ..hil.controllers.controller_spec import make_controller
    from ..hil.loop import run_closed_loop
    from ..hil.controllers.operating_point_lqr import OperatingPointLqr
    from ..hil.controllers.start_point import hold_keys, hold_summary, point_hold, start_state
    from ..hil.plants.plant import make_plant, start_counts
    from ..hil.records import write_run
    from ..model.interface import with_unit
    from ..model.modelfile import load_model

    if args.serve and args.controller is not None:
        raise PendcError("hil: --serve and --controller exclude each other (the socket client is the controller)")
    args.controller = args.controller or "builtin"
    if args.out is not None:
        _check_out_folder(args.out)
    model = load_model(args.model)
    # the absolute path: pendc animate reads the run from any folder
    meta = {"model": str(Path(model.source).resolve()) if Path(model.source).is_file() else model.source,
            "controller": "socket client" if args.serve else args.controller,
            "period_s": f"{args.period:g}"}
    address = _address(args.serve) if args.serve else None   # bad address: fail before any work
    initial = start_state(model, args.start) if args.start else None
    if initial is not None:
        meta["start"] = args.start
    plant = make_plant(args.plant, model,
                       **({"initial": initial} if initial is not None else {}))
    _note_offsets(model, f"the {args.plant} plant")
    origin = start_counts(plant.ports, initial)
    progress = _progress(not args.json)
    if address is not None:
        from ..hil.server import serve_loop

        controller = None
        run = serve_loop(plant, address, args.seconds, period=args.period, plant_name=args.plant,
                         timeout=args.timeout, progress=progress, count_origin=origin,
                         announce=lambda text: print(text, file=sys.stderr, flush=True))
    else:
        controller = make_controller(args.controller, model, args.period, excursions=_excursions(args.excursion))
        run = run_closed_loop(plant, controller, args.seconds, period=args.period, plant_name=args.plant,
                              progress=progress, count_origin=origin)
    # a run from a point is judged on holding it, whoever controls it (a crane's load kept hanging)
    holder = controller if isinstance(controller, OperatingPointLqr) else (
        point_hold(model, args.start) if args.start else None)
    if holder is not None:
        run.extra.update(hold_summary(run, holder))
    summary = write_run(args.out, run, meta) if args.out else run.summary()
    if args.json:
        json.dump(summary, sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        up = summary["upright_at_s"]
        print(f"plant {summary['plant']}, {summary['rows']} periods in {summary['wall_s']:.2f} s wall")
        held = summary.get("operating_point")
        if run.angle is not None and held is None and run.stopped is None:
            print(f"upright from t = {up:.3f} s (rms {summary['balance_rms_rad']:.4f} rad)" if up is not None
                  else "not upright at the end of the run")
        units = dict(run.units)
        spans = [f"max |{state}| = {with_unit(f'{float(abs(column).max()):.4f}', units.get(state, ''))}"
                 for state, column in run.positions if (state != run.angle or held is not None) and column.size]
        print(", ".join(spans + [f"{summary['switches']} controller switches"]))
        if held is not None and run.stopped is not None:
            print(f"no verdict on holding operating point {held}: the run stopped")
        elif held is not None:
            window = "the last 1 s" if summary["seconds"] >= 1.0 else f"the whole {summary['seconds']:g} s"
            print(f"over {window}, from operating point {held}: " + ", ".join(
                f"max |{c.position} - {c.target:.4g}| = {with_unit(f'{summary[k]:.4g}', c.unit)}"
                for c, k in zip(holder.coords, hold_keys(holder)) if summary.get(k) is not None))
        if args.out:
            print(f"wrote {args.out}/run.csv, summary.json, run.png")
    if run.stopped is not None:
        where = f" (partial record in {args.out}/run.csv)" if args.out else ""
        raise PendcError(f"the run stopped at {run.stopped}{where}")
    return 0


def _excursions(text: str | None) -> dict:
    """``NAME=VALUE,...`` -> {name: float}; a one-line error on a malformed item."""
    out = {}
    for item in (text or "").split(","):
        if not item.strip():
            continue
        name, sep, value = item.partition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep or not name.strip():
            raise PendcError(f"--excursion takes NAME=VALUE,... (e.g. q1=0.05,tau=0.5), got '{item.strip()}'")
    return out


def cmd_animate(args) -> int:
    from ..hil.animate import animate_run, model_of_run, playback, read_run_input

    model = None
    if args.model is not None:
        from ..hil.plants.core_ports import CorePorts
        from ..model.modelfile import load_model
        model = load_model(args.model)
        record = read_run_input(args.run, CorePorts.of_interface(model.interface))
    else:
        record = read_run_input(args.run)
    slow_motion, why = playback(record, args.slow_motion)
    animate_run(record, args.output, fps=args.fps, model=model if model is not None else model_of_run(record),
                slow_motion=slow_motion)
    if why:
        print(f"pendc: note: {why}", file=sys.stderr)
    print(f"wrote {args.output}")
    return 0


def add_parsers(sub) -> None:
    """Register ``hil`` and ``animate`` on the top-level subparsers."""
    p = sub.add_parser("hil", help="closed loop: a controller against a stepping plant (float, golden, RTL)")
    p.add_argument("--controller",
                   help="builtin (default: swing-up + LQR balance on a single pendulum, else lqr), swing-up, "
                        "balance (any plant that is one pendulum on one driven coordinate), lqr (LQR about the plant "
                        "file's first operating point; lqr:NAME about another), hold (PD on the first measured "
                        "position, of a plant whose position has a rate), or package.module:Class")
    p.add_argument("--excursion", metavar="NAME=VALUE,...",
                   help="the LQR's acceptable excursions by name (Bryson's rule), overriding the units' choice: "
                        "positions, rates and the input, each in its unit, e.g. q1=0.05,dq1=2,tau=0.5")
    p.add_argument("--model", help=MODEL_HELP)
    p.add_argument("--plant", default="float", choices=("float", "golden", "verilator", "icarus"),
                   help="the plant to run against (default float)")
    p.add_argument("--start", metavar="POINT",
                   help="start the plant at the plant file's operating point POINT, its last measured position "
                        "0.05 rad (1 cm) off (default: at rest at 0)")
    p.add_argument("--seconds", type=positive, default=12.0, help="simulated time (default 12)")
    p.add_argument("--period", type=positive, default=1e-3, help="control period in s (default 0.001)")
    p.add_argument("--out", help="folder for run.csv, summary.json and run.png")
    p.add_argument("--json", action="store_true", help="print summary.json")
    p.add_argument("--serve", metavar="127.0.0.1:PORT",
                   help="serve the loop to one external controller over TCP (loopback only; docs/hil.md)")
    p.add_argument("--timeout", type=positive, default=10.0,
                   help="--serve: seconds to wait for the client to connect and for each answer (default 10)")
    p.set_defaults(func=cmd_hil)

    p = sub.add_parser("animate", help="any plant's run drawn as its plant file's [drawing]: self-contained "
                                       "HTML, GIF or MP4")
    p.add_argument("run", help="run.csv of pendc hil (or any CSV with the time, the input and the model's measured "
                               "positions: {plant:columns}; '-': standard input)")
    p.add_argument("--model", help="the model whose [drawing] draws the run (default: the one the run's header "
                                   "names, else the default model)")
    p.add_argument("-o", "--output", required=True, help="pendulum.html, .gif or .mp4")
    p.add_argument("--fps", type=int, default=25, help="GIF/MP4 frames per second (default 25)")
    p.add_argument("--slow-motion", type=positive, metavar="FACTOR",
                   help="play FACTOR times slower than real time, every format (below 1: faster); default 1, "
                        "and a run shorter than 1 s is slowed by 1, 2 or 5 times a power of ten to last at least "
                        "5 s (a note says by how much)")
    p.set_defaults(func=cmd_animate)
