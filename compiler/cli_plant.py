"""``pendc plant new NAME`` and ``pendc plant check FILE``: start a plant file, and see what it derives.

``new`` writes a commented skeleton (a pendulum on a driven cart, every table of
``docs/plant_files.md`` present) that ``check`` accepts as it stands; ``check`` reads a plant
file, derives its equations and prints them (text, or LaTeX with ``--latex``) with the
states, inputs, sensors, effects and experiments the compiler will start from.
"""

from __future__ import annotations

import sys

from .atomic import write_atomic
from .errors import PendcError

SKELETON = '''# {name}: a plant file (docs/plant_files.md is the reference of every table).
# Check it with `pendc plant check {name}.toml`, build it with `pendc build --model {name}.toml`.
# The skeleton is a pendulum on a cart pushed by a force: replace the physics with your plant's.

[plant]
name = "{name}"
core = "{name}_core"
summary = "a pendulum on a cart pushed by a force (replace with your plant)"
source = "where the figures come from (a datasheet, a paper, a measurement)"
# values of the constants
g = 9.81
M = 1.0
m = 0.1
L = 0.25

[constants]
g = {{ unit = "m/s^2", meaning = "gravitational acceleration", bounds = [9.0, 10.5] }}
M = {{ unit = "kg", meaning = "cart mass", bounds = [0.01, 100.0] }}
m = {{ unit = "kg", meaning = "bob mass", bounds = [0.001, 10.0] }}
L = {{ unit = "m", meaning = "pivot to bob", bounds = [0.01, 5.0] }}

# Generalized coordinates (mechanical form; a plant given by state equations uses [states])
[coordinates.x]
unit = "m"
meaning = "cart position (m)"
body = "cart"
force = "F_x"
rate = {{ unit = "m/s", meaning = "cart velocity (m/s)", quantity = "velocity" }}

[coordinates.theta]
unit = "rad"
meaning = "pendulum angle from hanging down (rad)"
body = "pendulum"
quantity = "angle"
force = "tau_theta"
rate = {{ unit = "rad/s", meaning = "pendulum angular velocity (rad/s)", training_rate = 30.0 }}

[mechanics]
gravity = [0, "-g"]          # the last component points up

[bodies.cart]
position = ["x", 0]
mass = "M"

[bodies.bob]
position = ["x + L*sin(theta)", "-L*cos(theta)"]
mass = "m"

[inputs.F]
unit = "N"
meaning = "force on the cart (N)"
range = [-10.0, 10.0]

[sensors.enc_x]
state = "x"
band = 1e-4
lines = 1000
bands_per_rev = 2000

[sensors.enc_theta]
state = "theta"
band = 0.0031415926535897933
lines = 1000
bands_per_rev = 2000

[experiments.cart_held]
meaning = "the cart is clamped: only the pendulum swings"
held = ["x"]

[operating_points]
upright = {{ theta = "pi" }}

[drawing]
points = {{ cart = ["x", 0], bob = ["x + L*sin(theta)", "-L*cos(theta)"] }}
lines = [["cart", "bob"]]

# The effects a model of the plant may have (generic kinds: docs/plant_files.md)
[catalogue.push]
kind = "drive"
on = "x"
force = "F"
name = "F_push"
summary = "the input force pushes the cart"

[catalogue.cart_friction]
kind = "viscous"
on = "x"
coefficient = "b_x"
summary = "viscous friction of the cart, -b_x dx"
evidence = "the residual force on the cart is proportional to its speed"
params.b_x = {{ unit = "N*s/m", default = 0.5, bounds = [0.0, 100.0], meaning = "viscous coefficient of the cart" }}

[catalogue.pivot_damping]
kind = "viscous"
on = "theta"
coefficient = "b_theta"
summary = "viscous damping at the pivot, -b_theta dtheta"
evidence = "the residual torque at the pivot is proportional to the swing's rate"
params.b_theta = {{ unit = "N*m*s/rad", default = 1e-3, bounds = [0.0, 1.0], meaning = "pivot damping" }}

# The effects this model has, with their values
[effects.push]

[effects.cart_friction]
b_x = 0.5

[effects.pivot_damping]
b_theta = 1e-3
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


def cmd_plant_check(args) -> int:
    import sympy as sp

    from .model.modelfile import load_model

    model = load_model(args.file)
    d, eq, iface = model.definition, model.equations, model.interface
    show = sp.latex if args.latex else str
    out = [f"plant {d.name} ({d.summary}); core {d.core}; {d.form} form; model {model.source}"]
    out.append("states:")
    for s in iface.states:
        extra = [f"period {s.period:g}, {s.turns} turns" if s.period else "",
                 f"|value| <= {s.velocity_bound:g}" if s.velocity_bound else "",
                 f"budget {s.budget:g}" if s.budget else "", "" if s.output else "internal"]
        out.append(f"  {s.name} [{s.unit}] {s.meaning}" + "".join(f"; {e}" for e in extra if e))
    out.append("inputs:")
    out += [f"  {i.name} [{i.unit}] {i.meaning}; range {i.range.describe()}" for i in iface.inputs]
    out.append("sensors:")
    out += [f"  {s.name}: {s.state}, {s.lines} lines, {s.counts_per_unit:g} counts per unit" for s in iface.sensors] \
        or ["  (none)"]
    out.append("parameters: " + ", ".join(f"{k} = {v:g}" for k, v in model.parameter_values().items()))
    out.append("effects: " + (", ".join(model.effects) or "(none)") + "; catalogue: " + ", ".join(d.catalogue))
    out.append("experiments: " + ", ".join(d.experiments))
    out.append("equations:")
    for sym, expr in eq.assignments:
        out.append(f"  {show(sym)} = {show(expr)}")
    for state, derivative in zip(eq.states, eq.derivatives):
        out.append(f"  d/dt {show(state)} = {show(derivative)}")
    if eq.velocity_bound is not None:
        out.append(f"  after each step: |rate| <= {show(eq.velocity_bound)}")
    sys.stdout.write("\n".join(out) + "\n")
    return 0
