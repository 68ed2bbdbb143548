"""``pendc plant new NAME`` and ``pendc plant check FILE``: start a plant file, and see what it derives.

``new`` writes a commented skeleton (a load hanging from a driven trolley, every table of
``docs/plant_files.md`` present) that ``check`` accepts as it stands; ``check`` reads a plant
file, derives its equations and prints them (text, or LaTeX with ``--latex``) with the
states, inputs, sensors, effects and experiments the compiler will start from.
"""

from __future__ import annotations

import sys

from ..atomic import write_atomic
from ..errors import PendcError

SKELETON = '''# {name}: a plant file (docs/plant_files.md is the reference of every table).
# Check it with `pendc plant check {name}.toml`, build it with `pendc build --model {name}.toml`.
# The skeleton is a load hanging from a trolley pushed by a force: replace the physics with your plant's.

[plant]
name = "{name}"
core = "{name}_core"
summary = "a load hanging from a trolley pushed by a force (replace with your plant)"
source = "where the figures come from (a datasheet, a paper, a measurement)"
# values of the constants
g = 9.81
M = 1.0
m = 0.1
L = 0.25

[constants]
g = {{ unit = "m/s^2", meaning = "gravitational acceleration", bounds = [9.0, 10.5] }}
M = {{ unit = "kg", meaning = "trolley mass", bounds = [0.01, 100.0] }}
m = {{ unit = "kg", meaning = "load mass", bounds = [0.001, 10.0] }}
L = {{ unit = "m", meaning = "hook to load", bounds = [0.01, 5.0] }}

# Generalized coordinates (mechanical form; a plant given by state equations uses [states])
[coordinates.s]
unit = "m"
meaning = "trolley position (m)"
body = "trolley"
force = "F_s"
rate = {{ unit = "m/s", meaning = "trolley velocity (m/s)", quantity = "velocity" }}

[coordinates.phi]
unit = "rad"
meaning = "load angle from hanging down (rad)"
body = "load"
quantity = "angle"
force = "tau_phi"
rate = {{ unit = "rad/s", meaning = "load angular velocity (rad/s)", training_rate = 30.0 }}

[mechanics]
gravity = [0, "-g"]          # the last component points up

[bodies.trolley]
position = ["s", 0]
mass = "M"

[bodies.load]
position = ["s + L*sin(phi)", "-L*cos(phi)"]
mass = "m"

[inputs.F]
unit = "N"
meaning = "force on the trolley (N)"
range = [-10.0, 10.0]

[sensors.enc_s]
state = "s"
band = 1e-4
lines = 1000
bands_per_rev = 2000

[sensors.enc_phi]
state = "phi"
band = 0.0031415926535897933
lines = 1000
bands_per_rev = 2000

[experiments.trolley_held]
meaning = "the trolley is clamped: only the load swings"
held = ["s"]

[operating_points]
upright = {{ phi = "pi" }}

[drawing]
points = {{ trolley = ["s", 0], load = ["s + L*sin(phi)", "-L*cos(phi)"] }}
lines = [["trolley", "load"]]

# The effects a model of the plant may have (generic kinds: docs/plant_files.md)
[catalogue.push]
kind = "drive"
on = "s"
force = "F"
name = "F_push"
summary = "the input force pushes the trolley"

[catalogue.rail_friction]
kind = "viscous"
on = "s"
coefficient = "b_s"
summary = "viscous friction of the trolley, -b_s ds"
evidence = "the residual force on the trolley is proportional to its speed"
params.b_s = {{ unit = "N*s/m", default = 0.5, bounds = [0.0, 100.0], meaning = "viscous coefficient of the trolley" }}

[catalogue.hook_damping]
kind = "viscous"
on = "phi"
coefficient = "b_phi"
summary = "viscous damping at the hook, -b_phi dphi"
evidence = "the residual torque at the hook is proportional to the swing's rate"
params.b_phi = {{ unit = "N*m*s/rad", default = 1e-3, bounds = [0.0, 1.0], meaning = "hook damping" }}

# The effects this model has, with their values
[effects.push]

[effects.rail_friction]
b_s = 0.5

[effects.hook_damping]
b_phi = 1e-3
'''


def add_parsers(sub) -> None:
    """Register ``plant new`` and ``plant check`` on the top-level subparsers."""
    p = sub.add_parser("plant", help="start a plant file (new) and see what it derives (check)")
    kinds = p.add_subparsers(dest="plant_command", metavar="new|check")
    n = kinds.add_parser("new", help="write a commented skeleton plant file NAME.toml")
    n.add_argument("name", help="the plant's name (letters, digits and _)")
    n.add_argument("-o", "--output", help="the file to write (default NAME.toml; refuses to overwrite)")
    n.set_defaults(func=cmd_plant_new)
    c = kinds.add_parser("check", help="validate a plant file and print the equations the compiler starts from")
    c.add_argument("file", help="the plant file ('-': standard input)")
    c.add_argument("--latex", action="store_true", help="print the equations as LaTeX")
    c.set_defaults(func=cmd_plant_check)


def cmd_plant_new(args) -> int:
    from pathlib import Path

    name = args.name
    if not name.isidentifier() or name.startswith("_"):
        raise PendcError(f"plant name '{name}' must be letters, digits and _, not starting with a digit or _")
    path = Path(args.output or f"{name}.toml")
    if path.exists():
        raise PendcError(f"{path}: exists already; choose another name or -o")
    write_atomic(path, SKELETON.format(name=name))
    print(f"pendc: wrote {path}; next: pendc plant check {path}")
    return 0


def _latex_printer(eq, iface):
    """sympy's LaTeX with a position's rate and acceleration written as dots over it
    (``dq`` -> \\dot{q}, ``ddq`` -> \\ddot{q})."""
    import sympy as sp

    symbols = set(eq.states) | {sym for sym, _ in eq.assignments}
    for expr in (*eq.derivatives, *(e for _, e in eq.assignments)):
        symbols |= expr.free_symbols
    by_name = {s.name: s for s in symbols if isinstance(s, sp.Symbol)}
    names = {}
    for st in iface.states:
        if st.derivative_of:
            base = sp.latex(sp.Symbol(st.derivative_of))
            for name, dots in ((st.name, r"\dot"), ("d" + st.name, r"\ddot")):
                if name in by_name:
                    names[by_name[name]] = f"{dots}{{{base}}}"
    return lambda expr: sp.latex(expr, symbol_names=names)


def cmd_plant_check(args) -> int:
    import sympy as sp

    from ..model.interface import unit_name
    from ..model.modelfile import load_model
    from ..model.modes import euler_note
    from ..passes.pipeline import check_hardware_names, options_from_model

    model = load_model(args.file)
    d, eq, iface = model.definition, model.equations, model.interface
    show = _latex_printer(eq, iface) if args.latex else str
    out = [f"plant {d.name} ({d.summary}); core {d.core}; {d.form} form; model {model.source}"]
    out.append("states:")
    for s in iface.states:
        extra = [f"period {s.period:g}, {s.turns} turns" if s.period else "",
                 f"|value| <= {s.velocity_bound:g}" if s.velocity_bound else "",
                 f"budget {s.budget:g}" if s.budget else "", f"starts at {s.initial:g}" if s.initial else "",
                 f"works in [{s.working_range[0]:g}, {s.working_range[1]:g}]" if s.working_range else "",
                 "" if s.output else "internal"]
        out.append(f"  {s.name} [{unit_name(s.unit)}] {s.meaning}" + "".join(f"; {e}" for e in extra if e))
    out.append("inputs:")
    out += [f"  {i.name} [{unit_name(i.unit)}] {i.meaning}; range {i.range.describe()}" for i in iface.inputs]
    out.append("sensors:")
    out += [f"  {s.describe()}" for s in iface.sensors] \
        or ["  (none)"]
    out.append("parameters: " + ", ".join(f"{k} = {v:g}" for k, v in model.parameter_values().items()))
    out.append("effects: " + (", ".join(model.effects) or "(none)") + "; catalogue: " + ", ".join(d.catalogue))
    out.append("experiments: " + ", ".join(d.experiments))
    out.append("equations:")
    for sym, expr in eq.assignments:
        out.append(f"  {show(sym)} = {show(expr)}")
    ddt = r"\frac{d}{dt} " if args.latex else "d/dt "
    for state, derivative in zip(eq.states, eq.derivatives):
        out.append(f"  {ddt}{show(state)} = {show(derivative)}")
    if eq.velocity_bound is not None:
        out.append(f"  after each step: |rate| <= {show(eq.velocity_bound)}")
    options = options_from_model(model)
    if options.budget or options.ranges or options.qformats:    # the names a build would refuse
        check_hardware_names(model, options)
    out.append(euler_note(model, options.dt))
    out += _unreadable_states(model)
    sys.stdout.write("\n".join(out) + "\n")
    return 0


def _unreadable_states(model) -> list:
    """Notes on the start state and each operating point where a state lies outside its
    converter's range (the converter reads its end there: an LQR misses the point) or outside its
    declared range (the core's formats are sized for that range)."""
    from ..hil.controllers.operating_point_lqr import operating_point_names, operating_state
    from ..model.interface import with_unit

    iface = model.interface
    start = "it reads clipped there until the state comes back within it"
    places = [("the start state", {s.name: s.initial for s in iface.states}, start)]
    places += [(f"operating point '{name}'", operating_state(model, name)[1],
                "it reads clipped there, so pendc hil's LQR refuses the point") for name in operating_point_names(model)]
    notes = []
    for where, values, clipped in places:
        for spec in iface.states:
            value, sensor = values.get(spec.name), iface.sensor_of(spec.name)
            if value is None:
                continue
            shown = with_unit(f"{value:.4g}", spec.unit)
            if sensor is not None and sensor.is_adc and not sensor.lo <= value <= sensor.hi:
                notes.append(f"note: {where}: {spec.name} = {shown} lies outside the range of its converter "
                             f"{sensor.name}, {with_unit(f'[{sensor.lo:g}, {sensor.hi:g}]', spec.unit)}: {clipped}")
            low_high = spec.working_range
            if low_high and not low_high[0] <= value <= low_high[1]:
                notes.append(f"note: {where}: {spec.name} = {shown} lies outside its range "
                             f"{with_unit(f'[{low_high[0]:g}, {low_high[1]:g}]', spec.unit)}, which the core's "
                             f"formats are sized for: widen states.{spec.name}.range")
    return notes
