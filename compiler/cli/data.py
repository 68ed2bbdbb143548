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
import re
import sys

from .options import finite, positive

# The examples name the default model's signals ({plant:WORD}: filled from its interface when
# the help is printed, pendc.cli.help); the rules hold for any model's signals.
FORMATS_HELP = """\
measurement files:
  CSV (pendc's own): '# key: value' comment lines, a header naming the time and the
  model's signals ({plant:body}: {plant:columns}; SI units, periodic
  positions from the model's zero, unwrapped), one row per sample. Also read: other
  column names, ';' tab or whitespace separators (detected from the header), other units
  (--unit or --<SIGNAL>-unit), any sample rate (resampled to a uniform grid, at most 1 kHz
  unless --rate; a note says how), '-' for standard input, and MATLAB .mat v5/v7 files
  (v7.3/HDF5: save with -v7): plain arrays (a matrix's columns are NAME:1, NAME:2, ...),
  Simulink To Workspace 'Structure with time' / 'Structure' / 'Array' (one variable or
  one per block, e.g. {plant:angle}, {plant:position}, {plant:input}, tout), timeseries-like structs with Time and
  Data. A file that cannot be mapped is refused with the names it holds.
  Resampling: a uniform file faster than 1 kHz is averaged down to 1 kHz (boxcar blocks);
  a non-uniform one is interpolated linearly onto a uniform grid at its median step,
  unless a gap is longer than max(20 ms, 5 median steps), which is refused.
  Plausibility checks, each a one-line error naming the column or line: time sampled
  slower than 10 Hz and than ten samples a period of the plant's fastest mode
  (milliseconds? --t-unit s says seconds), a position in metres beyond 1 m in many rows (a
  rig's travel: millimetres or centimetres?), the input beyond 10 times its full scale
  (millivolts?), an angle beyond 200 or turning faster than 60 rad/s (degrees?); the
  same beyond the limits in a few rows, or an angle sample 1 rad away from both
  neighbours, is an outlier; NaN, inf, time not strictly increasing, rows with missing
  fields.

reading other formats, examples (the signals of the default model, {plant:body}):
  CSV with other names, semicolons, degrees and millimetres:
    %(prog)s run.csv --columns {plant:time}=Time,{plant:angle}=Theta1,{plant:position}=CartPos,{plant:input}=Vin --{plant:angle}-unit deg --{plant:position}-unit mm
  a spreadsheet export with ';' and decimal commas (both detected), angle from upright:
    %(prog)s run.csv --columns {plant:time}=Zeit,{plant:angle}=Winkel,{plant:position}=Position,{plant:input}=Spannung --{plant:angle}-zero upright
  a text file without a header row (MATLAB writematrix), columns by number, positions in
  encoder counts ({plant:angle_step} {plant:angle_unit} and {plant:position_step} {plant:position_unit} per count):
    %(prog)s run.txt --columns {plant:time}=1,{plant:angle}=2,{plant:position}=3,{plant:input}=4 --{plant:angle}-unit {plant:angle_step} --{plant:position}-unit {plant:position_step}
  time in milliseconds, input in millivolts, tab-separated:
    %(prog)s run.tsv --separator tab --{plant:time}-unit ms --{plant:input}-unit mV
  Simulink 'Structure with time', one To Workspace block logging [{plant:angle} {plant:position} {plant:input}] at 10 kHz,
  {plant:angle} in degrees from upright (decimated to 1 kHz):
    %(prog)s swing.mat --columns {plant:angle}=simout:1,{plant:position}=simout:2,{plant:input}=simout:3 --unit {plant:angle}=deg --zero {plant:angle}=upright
  one To Workspace variable per signal ({plant:angle}, {plant:position}, {plant:input}, tout): the names map themselves:
    %(prog)s run.mat
  Simulink 'Array' or 'Structure' (no time in the file): give the sample time:
    %(prog)s run.mat --columns {plant:angle}=data:1 --sample-time 1e-4 --experiment {experiment:held}
  a free swing with the driven coordinate clamped, no {plant:position} and no {plant:input} column (filled with 0, listed as missing):
    %(prog)s swing.csv --experiment {experiment:held}
  several experiments at once (one name per file) and known encoder steps:
    %(prog)s held.csv other.csv --experiment {experiment:held},{experiment:other} --resolution {plant:angle}={plant:angle_step},{plant:position}={plant:position_step}
  from standard input:
    pendc simulate stim.csv | %(prog)s -
"""


NAME = re.compile(r"[A-Za-z_]\w*$")   # a signal's name as the plant interface spells it


def _mapping(text: str) -> dict:
    """``PENDC_NAME=FILE_NAME`` pairs (the names are checked against the model's signals when read)."""
    out = {}
    for part in (p.strip() for p in text.split(",")):
        if not part:
            continue
        name, eq, file_name = part.partition("=")
        name, file_name = name.strip(), file_name.strip()
        if not eq or not file_name:
            raise argparse.ArgumentTypeError(f"expected PENDC_NAME=FILE_NAME pairs, got {part!r}")
        if not NAME.match(name):
            raise argparse.ArgumentTypeError(f"{name!r} is not a signal name (letters, digits and _)")
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
        if not (step > 0 and math.isfinite(step)) or not NAME.match(name.strip()):
            raise argparse.ArgumentTypeError(f"expected NAME=STEP with a signal name and a positive step, got {part!r}")
        out[name.strip()] = step
    return out


def _settings(kind: str, check):
    """An argparse type: ``NAME=VALUE`` pairs, each value checked by ``check`` (returns it parsed)."""
    def parse(text: str) -> dict:
        out = {}
        for part in (p.strip() for p in text.split(",") if p.strip()):
            name, eq, value = (w.strip() for w in part.partition("="))
            if not eq or not NAME.match(name) or not value:
                raise argparse.ArgumentTypeError(f"expected NAME={kind.upper()} pairs, got {part!r}")
            out[name] = check(value)
        return out
    return parse


def _zero(text: str) -> str:
    from ..sim.signals import ZERO_NAMES

    if text not in ZERO_NAMES:
        raise argparse.ArgumentTypeError(f"{text!r}: use {' or '.join(ZERO_NAMES)}")
    return text


def _sign(text: str) -> float:
    if text not in ("1", "-1", "+1"):
        raise argparse.ArgumentTypeError(f"{text!r}: use 1 or -1")
    return float(text)


def _unit_text(text: str) -> str:
    """A unit name or a positive number (checked against the signal's unit when read)."""
    from ..sim.signals import UNIT_SCALES

    names = {n for scales in UNIT_SCALES.values() for n in scales}
    if text not in names:
        try:
            value = float(text)
        except ValueError:
            value = -1.0
        if not (value > 0 and math.isfinite(value)):
            raise argparse.ArgumentTypeError(f"{text!r}: a unit name ({', '.join(sorted(names))}) or the size of "
                                             "one file unit (a positive number)")
    return text


def _input_value(text: str) -> tuple:
    """``V`` or ``INPUT=V``: (the input's name or None, a finite number)."""
    name, eq, value = text.rpartition("=")
    if eq and not NAME.match(name.strip()):
        raise argparse.ArgumentTypeError(f"expected V or INPUT=V with the model's input and a number, got {text!r}")
    return (name.strip() if eq else None), finite(value)


def _checked_input_value(args, plant) -> float:
    """The value of an absent input from ``--input-value``; a name given must be ``plant``'s input."""
    from ..errors import PendcError
    from ..sim.signals import signals_of

    name, value = getattr(args, "input_value", None) or (None, 0.0)
    if name is not None and name != signals_of(plant).input:
        raise PendcError(f"--{name.replace('_', '-')}-value: '{name}' is not the model's input "
                         f"(its input is '{signals_of(plant).input}')")
    return float(value)


# --<SIGNAL>-unit/-zero/-sign VALUE: --unit/--zero/--sign SIGNAL=VALUE, for any signal of any plant;
# --<INPUT>-value V: --input-value INPUT=V (the name checked against the model's input when read)
SIGNAL_OPTION = re.compile(r"--([A-Za-z_][\w-]*?)-(unit|zero|sign|value)(?:=(.*))?$", re.S)
SETTING_OPTION = {"unit": "--unit", "zero": "--zero", "sign": "--sign", "value": "--input-value"}


def expand_signal_options(words: list, known) -> list:
    """``words`` with each ``--<SIGNAL>-unit VALUE`` (``-zero``, ``-sign``; also ``--OPT=VALUE``)
    that is no option of the parser (``known``) rewritten as ``--unit SIGNAL=VALUE``
    (``--zero``, ``--sign``; ``--<INPUT>-value V`` as ``--input-value INPUT=V``): the
    per-signal spelling, checked against the model's signals when the data are read. A
    hyphen in SIGNAL stands for an underscore."""
    out, i = [], 0
    while i < len(words):
        word = words[i]
        if word == "--":
            out += words[i:]
            break
        match = SIGNAL_OPTION.fullmatch(word) if word.startswith("--") and word.split("=")[0] not in known else None
        if match is None:
            out.append(word)
            i += 1
            continue
        name, setting, value = match.group(1).replace("-", "_"), match.group(2), match.group(3)
        if value is None:
            if i + 1 == len(words):
                from ..errors import PendcError

                raise PendcError(f"argument {word}: expected one argument")
            value, i = words[i + 1], i + 1
        out += [SETTING_OPTION[setting], f"{name}={value}"]
        i += 1
    return out


class _MergeSettings(argparse.Action):
    """``--unit``/``--zero``/``--sign``: repeated, the NAME=VALUE pairs add up (a later one wins)."""

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, {**(getattr(namespace, self.dest, None) or {}), **values})


def add_data_options(p, many: bool = True) -> None:
    """The positional data file(s) and every reading option, added to parser ``p`` (with examples)."""
    from ..model.modelfile import shipped_plants

    experiments = "; ".join(f"{', '.join(model.experiments)} ({name})" for name, model in shipped_plants().items())

    p.add_argument("data", nargs="+" if many else 1,
                   help="measurement file(s): CSV-like text ('-' for standard input) or MATLAB .mat")
    g = p.add_argument_group("reading the data (other formats; see the examples below)")
    g.add_argument("--columns", type=_mapping, default={}, metavar="MAP",
                   help="map pendc's columns to the file's names: "
                        "{plant:time}=Time,{plant:angle}=Theta1,{plant:position}=Pos,{plant:input}=Vin "
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
    per_signal = ("--<SIGNAL>-unit UNIT is the same as --unit SIGNAL=UNIT (for the default model: "
                  "--{plant:time}-unit, --{plant:input}-unit, --{plant:position}-unit, --{plant:angle}-unit)")
    g.add_argument("--unit", type=_settings("unit", _unit_text), default={}, action=_MergeSettings,
                   metavar="NAME=UNIT",
                   help="units of any of the model's signals (or the time) in the file, e.g. "
                        "{plant:angle}=deg,{plant:position}=mm,{plant:time}=ms (a unit name or the size of one file "
                        "unit in the signal's SI unit, e.g. {plant:angle}={plant:angle_step} for encoder counts); "
                        + per_signal)
    g.add_argument("--zero", type=_settings("zero", _zero), default={}, action=_MergeSettings,
                   metavar="NAME=hanging|upright",
                   help="where the file's zero of a periodic position is (default hanging: the model's zero), e.g. "
                        "{plant:angle}=upright (upright: half a period from the model's zero); "
                        "--<SIGNAL>-zero, e.g. --{plant:angle}-zero upright, is the same")
    g.add_argument("--sign", type=_settings("sign", _sign), default={}, action=_MergeSettings, metavar="NAME=-1",
                   help="-1 for a periodic position the file counts the other way round from the model "
                        "(spec section 1); --<SIGNAL>-sign, e.g. --{plant:angle}-sign -1, is the same")
    g.add_argument("--experiment", metavar="NAME[,NAME...]",
                   help=f"what was held or removed, by the model's body: {experiments} (default: the file's "
                        f"'# experiment:' line or free); one name for all files, or one per data file "
                        f"(--validate files then say theirs in a '# experiment:' line)")
    g.add_argument("--missing", default="", metavar="AXES",
                   help="axes the file may lack, filled with 0 (the input with --input-value), e.g. --missing "
                        "{plant:input} (an experiment allows the axes it holds still or removes without this option)")
    g.add_argument("--input-value", type=_input_value, default=(None, 0.0), metavar="[INPUT=]V",
                   help="value of an absent input, in its unit (default 0); --<INPUT>-value V, e.g. "
                        "--{plant:input}-value 5, is the same")
    g.add_argument("--resolution", type=_steps, default={}, metavar="STEPS",
                   help="measurement steps, e.g. {plant:angle}={plant:angle_step},{plant:position}={plant:position_step} "
                        "(default: estimated from the data)")
    g.add_argument("--sample-time", type=positive, metavar="S",
                   help="sample time of a file without a time vector (Simulink 'Array'/'Structure')")
    g.add_argument("--rate", type=positive, metavar="HZ",
                   help="resample onto a uniform grid at this rate (default: keep a uniform file's rate "
                        "up to 1 kHz, average faster ones down to 1 kHz)")
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    words = example_experiments()
    p.epilog = (p.epilog + "\n\n" if p.epilog else "") + \
        FORMATS_HELP.replace("{experiment:held}", words["held"]).replace("{experiment:other}", words["other"])


def example_experiments() -> dict:
    """The default model's experiments the examples cite, from its plant file: ``held`` holds
    the driven coordinate alone, ``other`` is the next experiment besides free (NAME when the
    file declares none)."""
    from ..ident.plant_roles import driven_coordinate, holding_experiment
    from ..model.equations import DEFAULT_EXPERIMENT
    from ..model.modelfile import default_model_path, shipped_plants

    model = next((m for m in shipped_plants().values() if m.source == str(default_model_path())), None)
    if model is None:
        return {"held": "NAME", "other": "NAME"}
    driven = driven_coordinate(model)
    held = (holding_experiment(model, driven) if driven else None) or "NAME"
    other = next((e for e in model.definition.experiments if e not in (held, DEFAULT_EXPERIMENT)), "NAME")
    return {"held": held, "other": other}


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
    for flag in ("--unit", "--zero", "--sign"):
        values = getattr(args, flag[2:], None) or {}
        if values:
            words += [flag, ",".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in values.items())]
    defaults = {"separator": "auto", "decimal": "auto", "encoding": "utf-8", "experiment": None, "missing": "",
                "sample_time": None, "rate": None}
    given_input = getattr(args, "input_value", None) or (None, 0.0)
    if given_input[1] != 0.0:
        words += ["--input-value", f"{given_input[1]!r}"]
    for name, default in defaults.items():
        value = getattr(args, name, default)
        if value is not None and value != default:
            words += [f"--{name.replace('_', '-')}", str(value)]
    return [shlex.quote(w) for w in words]


def note(text: str) -> None:
    """One ``pendc: note:`` line on stderr."""
    print(f"pendc: note: {text}", file=sys.stderr)


def read_options(args, experiment: str | None = None, plant=None):
    """The :class:`~pendc.sim.readers.ReadOptions` that ``args`` ask for (missing attributes:
    defaults), for the signals of ``plant`` (a model; default the default model)."""
    from ..sim.csvread import separator_from_name
    from ..sim.readers import ReadOptions

    missing = tuple(a.strip() for a in (getattr(args, "missing", "") or "").split(",") if a.strip())
    units, zero, sign = (dict(getattr(args, k, None) or {}) for k in ("unit", "zero", "sign"))
    return ReadOptions(
        columns=dict(getattr(args, "columns", None) or {}),
        separator=separator_from_name(getattr(args, "separator", None)),
        decimal={"point": ".", "comma": ","}.get(getattr(args, "decimal", None) or "auto", ...),
        encoding=getattr(args, "encoding", None) or "utf-8",
        units=units, zero=zero, sign=sign, plant=plant,
        experiment=experiment, resolution=dict(getattr(args, "resolution", None) or {}),
        allow_missing=missing, u_value=_checked_input_value(args, plant),
        sample_time=getattr(args, "sample_time", None), rate=getattr(args, "rate", None), uniform=True,
        plausible=True)


def experiments_for(args, paths: list, positional: bool = True) -> list:
    """One experiment name (or None: the file decides) per path, from ``--experiment``.

    One name applies to every file; a list names the positional data files in order,
    and other files (``--validate``) then declare theirs (``# experiment:``).
    """
    from ..errors import PendcError

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


def load_datasets(args, paths=None, plant=None) -> list:
    """Read ``paths`` (default: ``args.data``) with the reading options in ``args``, as
    measurements of ``plant`` (a model: its interface names the columns; default the
    default model); print notes."""
    from ..errors import PendcError
    from ..sim.measurements import read_measurements

    positional = paths is None
    paths = list(args.data if paths is None else paths)
    if [str(p) for p in paths].count("-") > 1:
        raise PendcError("standard input ('-') can be read only once")
    datasets = []
    for path, experiment in zip(paths, experiments_for(args, paths, positional)):
        datasets.append(read_measurements(path, options=read_options(args, experiment, plant)))
    for d in datasets:
        for w in d.warnings:
            print(f"pendc: warning: {w}", file=sys.stderr)
        for n in d.notes:
            note(n)
    return datasets


def load_model_and_data(args):
    """The model of ``--model`` (default: the shipped default model) and the data sets."""
    from ..model.modelfile import load_model

    model = load_model(args.model)
    return model, load_datasets(args, plant=model)
