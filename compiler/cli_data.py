"""Reading measurement files for the identification commands (shared by compare, diagnose, fit).

One place that knows how a command line names its data: the positional files and the
options that map other labs' formats onto pendc's columns (a thin layer over
:class:`pendc.sim.readers.ReadOptions`). Every command calls :func:`load_datasets`;
what was done to a file (resampling, filling an absent axis) goes to stderr as one
``pendc: note:`` line each, problems as ``pendc: warning:`` lines.
"""

from __future__ import annotations

import argparse
import math
import sys

PENDC_COLUMNS = ("t", "u", "x", "theta", "dx", "dtheta")
MODEL_HELP = "model file (default: models/sct_thesis_final.toml; '-': standard input)"

FORMATS_HELP = """\
measurement files:
  CSV (pendc's own): '# key: value' comment lines, a header t,u,x,theta (s, V, m, rad;
  theta from hanging, unwrapped), one row per sample. Also read: other column names,
  ';' tab or whitespace separators (detected from the header), other units, any sample
  rate (resampled to a uniform grid, at most 1 kHz unless --rate; a note says how), '-'
  for standard input, and MATLAB .mat v5/v7 files (v7.3/HDF5: save with -v7): plain
  arrays (a matrix's columns are NAME:1, NAME:2, ...), Simulink To Workspace
  'Structure with time' / 'Structure' / 'Array' (one variable or one per block, e.g.
  theta, x, u, tout), timeseries-like structs with Time and Data. A file that cannot be
  mapped is refused with the names it holds.
  Resampling: a uniform file faster than 1 kHz is averaged down to 1 kHz (boxcar blocks);
  a non-uniform one is interpolated linearly onto a uniform grid at its median step,
  unless a gap is longer than max(20 ms, 5 median steps), which is refused.
  Plausibility checks, each a one-line error naming the column or line: t sampled slower
  than 10 Hz (milliseconds?), |x| beyond 1 m in many rows (the track is 0.75 m long:
  millimetres or centimetres?), |u| beyond 100 V (the drive takes 0-10 V: millivolts?),
  theta beyond 200 or turning faster than 60 rad/s (degrees?); the same beyond the
  limits in a few rows, or a theta sample 1 rad away from both neighbours, is an
  outlier; NaN, inf, time not strictly increasing, rows with missing fields.

reading other formats, examples:
  CSV with other names, semicolons, degrees and millimetres:
    %(prog)s run.csv --columns t=Time,theta=Theta1,x=CartPos,u=Vin --theta-unit deg --x-unit mm
  a spreadsheet export with ';' and decimal commas (both detected), angle from upright:
    %(prog)s run.csv --columns t=Zeit,theta=Winkel,x=Position,u=Spannung --theta-zero upright
  a text file without a header row (MATLAB writematrix), columns by number, angle and
  position in encoder counts (2*pi/20000 rad and 2.5 um per count):
    %(prog)s run.txt --columns t=1,theta=2,x=3,u=4 --theta-unit 3.14159265e-4 --x-unit 2.5e-6
  time in milliseconds, input in millivolts, tab-separated:
    %(prog)s run.tsv --separator tab --t-unit ms --u-unit mV
  Simulink 'Structure with time', one To Workspace block logging [theta x u] at 10 kHz,
  theta in degrees from upright (decimated to 1 kHz):
    %(prog)s swing.mat --columns theta=simout:1,x=simout:2,u=simout:3 --theta-unit deg --theta-zero upright
  one To Workspace variable per signal (theta, x, u, tout): the names map themselves:
    %(prog)s run.mat
  Simulink 'Array' or 'Structure' (no time in the file): give the sample time:
    %(prog)s run.mat --columns theta=data:1 --sample-time 1e-4 --experiment cart_held
  a clamped-cart free swing with no x and no u column (filled with 0, listed as missing):
    %(prog)s swing.csv --experiment cart_held
  several experiments at once (one name per file) and known encoder steps:
    %(prog)s held.csv cart.csv --experiment cart_held,pendulum_removed --resolution theta=3.1416e-4,x=2.5e-6
  from standard input:
    pendc simulate stim.csv | %(prog)s -
"""


def _mapping(text: str) -> dict:
    out = {}
    for part in (p.strip() for p in text.split(",")):
        if not part:
            continue
        name, eq, file_name = part.partition("=")
        name, file_name = name.strip(), file_name.strip()
        if not eq or not file_name:
            raise argparse.ArgumentTypeError(f"expected PENDC_NAME=FILE_NAME pairs, got {part!r}")
        if name not in PENDC_COLUMNS:
            raise argparse.ArgumentTypeError(f"{name!r} is not a pendc column ({', '.join(PENDC_COLUMNS)})")
        out[name] = file_name
    return out


def _steps(text: str) -> dict:
    out = {}
    for part in (p.strip() for p in text.split(",") if p.strip()):
        name, _, value = part.partition("=")
        try:
            step = float(value)
        except ValueError:
            step = -1.0
        if not (step > 0 and math.isfinite(step)) or name.strip() not in PENDC_COLUMNS:
            raise argparse.ArgumentTypeError(f"expected NAME=STEP with a pendc column and a positive step, got {part!r}")
        out[name.strip()] = step
    return out


def finite(text: str) -> float:
    """An argparse type: a finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


def positive(text: str) -> float:
    """An argparse type: a finite number above zero (a step, a rate, a time)."""
    value = finite(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return value


def _unit(axis: str):
    """An argparse type: a unit name of ``axis`` or a positive number."""
    def parse(text: str) -> str:
        from .errors import PendcError
        from .sim.readers import unit_factor

        try:
            unit_factor(axis, text)
        except PendcError as exc:
            raise argparse.ArgumentTypeError(f"{text!r}: {str(exc).split(': ', 1)[1]}") from None
        return text
    return parse


# --AXIS-unit options: axis, unit names, default, what a number means, an example number
UNIT_OPTIONS = (
    ("t", ("s", "ms", "us"), "s", "seconds", ""),
    ("x", ("m", "cm", "mm"), "m", "metres", "2.5e-6 for encoder counts"),
    ("u", ("V", "mV"), "V", "volts", ""),
    ("theta", ("rad", "deg"), "rad", "radians", "3.14159e-4 = 2*pi/20000 for encoder counts"),
)


def add_data_options(p, many: bool = True) -> None:
    """The positional data file(s) and every reading option, added to parser ``p`` (with examples)."""
    from .model.experiments import EXPERIMENTS

    p.add_argument("data", nargs="+" if many else 1,
                   help="measurement file(s): CSV-like text ('-' for standard input) or MATLAB .mat")
    g = p.add_argument_group("reading the data (other formats; see the examples below)")
    g.add_argument("--columns", type=_mapping, default={}, metavar="MAP",
                   help="map pendc's columns to the file's names: t=Time,theta=Theta1,x=Pos,u=Vin "
                        "(.mat: a variable, VAR:K for its K-th column, a Simulink signal label; "
                        "a text file without a header row: column numbers 1, 2, ...)")
    g.add_argument("--separator", default="auto", metavar="SEP",
                   help="field separator: auto (default: ',' ';' tab or whitespace, from the header), "
                        "comma, semicolon, tab, whitespace, or one character")
    g.add_argument("--decimal", choices=("auto", "point", "comma"), default="auto",
                   help="decimal mark: auto (default: comma when fields are not comma-separated and "
                        "the first row has commas but no point, as spreadsheets write in many locales)")
    g.add_argument("--encoding", default="utf-8", metavar="NAME",
                   help="text encoding of the header and comments (default utf-8; e.g. cp1252 for a "
                        "spreadsheet export with 'Winkel [°]')")
    for axis, names, default, per, example in UNIT_OPTIONS:
        g.add_argument(f"--{axis}-unit", type=_unit(axis), metavar="{" + ",".join(names) + ",NUMBER}",
                       help=f"unit of {axis} in the file (default {default}; a number: {per} per file unit"
                            + (f", e.g. {example})" if example else ")"))
    g.add_argument("--theta-zero", choices=("hanging", "upright"), default="hanging",
                   help="where the file's theta is 0 (default hanging); upright: theta = theta_file + pi")
    g.add_argument("--theta-sign", type=int, choices=(1, -1), default=1,
                   help="-1 when the file's theta grows counter-clockwise (pendc's grows clockwise, "
                        "with x positive to the left; spec section 1)")
    g.add_argument("--experiment", metavar="NAME[,NAME...]",
                   help=f"what was held or removed: {', '.join(EXPERIMENTS)} (default: the file's "
                        f"'# experiment:' line or free); one name for all files, or one per data file "
                        f"(--validate files then say theirs in a '# experiment:' line)")
    g.add_argument("--missing", default="", metavar="AXES",
                   help="axes the file may lack, filled with 0 (u with --u-value), e.g. --missing u "
                        "(cart_held allows x and u, pendulum_removed theta, without this option)")
    g.add_argument("--u-value", type=finite, default=0.0, metavar="V", help="value of an absent u (default 0 V)")
    g.add_argument("--resolution", type=_steps, default={}, metavar="STEPS",
                   help="measurement steps, e.g. theta=3.1416e-4,x=2.5e-6 (default: estimated from the data)")
    g.add_argument("--sample-time", type=positive, metavar="S",
                   help="sample time of a file without a time vector (Simulink 'Array'/'Structure')")
    g.add_argument("--rate", type=positive, metavar="HZ",
                   help="resample onto a uniform grid at this rate (default: keep a uniform file's rate "
                        "up to 1 kHz, average faster ones down to 1 kHz)")
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.epilog = (p.epilog + "\n\n" if p.epilog else "") + FORMATS_HELP


def reading_arguments(args) -> list:
    """The reading options ``args`` holds that differ from the defaults, as command-line words,
    so a suggested next command (``pendc fit ...``) reads the data the same way."""
    import shlex

    words = []
    columns = getattr(args, "columns", None) or {}
    if columns:
        words += ["--columns", ",".join(f"{k}={v}" for k, v in columns.items())]
    resolution = getattr(args, "resolution", None) or {}
    if resolution:
        words += ["--resolution", ",".join(f"{k}={v!r}" for k, v in resolution.items())]
    defaults = {"separator": "auto", "decimal": "auto", "encoding": "utf-8", "t_unit": None, "x_unit": None,
                "u_unit": None, "theta_unit": None, "theta_zero": "hanging", "theta_sign": 1, "experiment": None,
                "missing": "", "u_value": 0.0, "sample_time": None, "rate": None}
    for name, default in defaults.items():
        value = getattr(args, name, default)
        if value is not None and value != default:
            words += [f"--{name.replace('_', '-')}", str(value)]
    return [shlex.quote(w) for w in words]


def note(text: str) -> None:
    """One ``pendc: note:`` line on stderr."""
    print(f"pendc: note: {text}", file=sys.stderr)


def read_options(args, experiment: str | None = None):
    """The :class:`~pendc.sim.readers.ReadOptions` that ``args`` ask for (missing attributes: defaults)."""
    from .sim.csvread import separator_from_name
    from .sim.readers import ReadOptions

    missing = tuple(a.strip() for a in (getattr(args, "missing", "") or "").split(",") if a.strip())
    return ReadOptions(
        columns=dict(getattr(args, "columns", None) or {}),
        separator=separator_from_name(getattr(args, "separator", None)),
        decimal={"point": ".", "comma": ","}.get(getattr(args, "decimal", None) or "auto", ...),
        encoding=getattr(args, "encoding", None) or "utf-8",
        t_unit=getattr(args, "t_unit", None), x_unit=getattr(args, "x_unit", None),
        u_unit=getattr(args, "u_unit", None), theta_unit=getattr(args, "theta_unit", None),
        theta_zero=getattr(args, "theta_zero", None) or "hanging",
        theta_sign=float(getattr(args, "theta_sign", 1) or 1),
        experiment=experiment, resolution=dict(getattr(args, "resolution", None) or {}),
        allow_missing=missing, u_value=float(getattr(args, "u_value", 0.0) or 0.0),
        sample_time=getattr(args, "sample_time", None), rate=getattr(args, "rate", None), uniform=True,
        plausible=True)


def experiments_for(args, paths: list, positional: bool = True) -> list:
    """One experiment name (or None: the file decides) per path, from ``--experiment``.

    One name applies to every file; a list names the positional data files in order,
    and other files (``--validate``) then declare theirs (``# experiment:``).
    """
    from .errors import PendcError

    names = [n.strip() for n in (getattr(args, "experiment", None) or "").split(",") if n.strip()]
    if not names:
        return [None] * len(paths)
    if len(names) == 1:
        return names * len(paths)
    if not positional:
        return [None] * len(paths)
    if len(names) != len(paths):
        raise PendcError(f"--experiment names {len(names)} experiments for {len(paths)} data files: give one, "
                         f"or one per file")
    return names


def load_datasets(args, paths=None) -> list:
    """Read ``paths`` (default: ``args.data``) with the reading options in ``args``; print notes."""
    from .errors import PendcError
    from .sim.measurements import read_measurements

    positional = paths is None
    paths = list(args.data if paths is None else paths)
    if [str(p) for p in paths].count("-") > 1:
        raise PendcError("standard input ('-') can be read only once")
    datasets = []
    for path, experiment in zip(paths, experiments_for(args, paths, positional)):
        datasets.append(read_measurements(path, options=read_options(args, experiment)))
    for d in datasets:
        for w in d.warnings:
            print(f"pendc: warning: {w}", file=sys.stderr)
        for n in d.notes:
            note(n)
    return datasets


def load_model_and_data(args):
    """The model of ``--model`` (default: the thesis' final model) and the data sets."""
    from .model.modelfile import load_model

    return load_model(args.model), load_datasets(args)
