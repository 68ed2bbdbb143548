"""Plant files (pendc.model.plantfile, docs/plant_files.md): the reference's own example reads and
derives what the physics says, and malformed files get one line naming the file and the key."""

import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import pendc
from buck_plant import buck_toml
from pendc.errors import PendcError
from pendc.model.modelfile import model_fingerprint, parse_model
from pendc.model.model_writer import dumps_model

DOCS = Path(__file__).resolve().parents[1] / "docs" / "plant_files.md"


def example() -> str:
    """The complete example of docs/plant_files.md, as a user would copy it."""
    return re.search(r"```toml\n(.*?)```", DOCS.read_text(encoding="utf-8"), re.S).group(1)


def test_the_reference_example_derives_a_cart_pendulum():
    model = parse_model(example(), "my_cart.toml")
    eq = model.equations
    x, dx, th, dth, F = sp.symbols("x dx theta dtheta F", real=True)
    g, M, m, L = sp.symbols("g M m L", positive=True)
    b = sp.Symbol("b", real=True)
    ddx, ddth = eq.inline(eq.derivatives[1]), eq.inline(eq.derivatives[3])
    # a point-mass pendulum on a cart, written out by hand
    A = sp.Matrix([[M + m, m * L * sp.cos(th)], [m * L * sp.cos(th), m * L ** 2]])
    rhs = sp.Matrix([F + m * L * dth ** 2 * sp.sin(th), -m * g * L * sp.sin(th) - b * dth])
    want = A.LUsolve(rhs)
    values = {g: 9.81, M: 2.0, m: 0.2, L: 0.3, b: 2e-3, F: 1.5, dx: 0.1, dth: -0.7}
    for angle in (0.0, 0.4, 2.5, -1.2):
        values[th] = angle
        assert float(ddx.subs(values)) == pytest.approx(float(want[0].subs(values)), rel=1e-12)
        assert float(ddth.subs(values)) == pytest.approx(float(want[1].subs(values)), rel=1e-12)
    iface = model.interface
    assert iface.state("theta").period == pytest.approx(2 * np.pi) and iface.state("x").period is None
    assert iface.input.name == "F" and (iface.input.lo, iface.input.hi) == (-20.0, 20.0)
    assert iface.state("theta").budget == pytest.approx(0.0031415926535897933 / 4)


def test_a_written_plant_reads_back_as_itself():
    model = parse_model(example(), "my_cart.toml")
    again = parse_model(dumps_model(model), "again.toml")
    assert again == model and model_fingerprint(again) == model_fingerprint(model)


def test_the_fingerprint_covers_the_physics():
    text = example()
    other = parse_model(text.replace('"-L*cos(theta)"', '"-L*cos(theta) + 0"').replace(
        'position = ["x + L*sin(theta)"', 'position = ["x + 1*L*sin(theta)"'), "b.toml")
    assert model_fingerprint(other) != model_fingerprint(parse_model(text, "a.toml"))


def test_shipped_plants_declare_their_physics():
    for path in sorted(Path(__file__).resolve().parents[1].glob("models/*.toml")):
        model = pendc.load_model(path)
        assert model.definition.catalogue and model.interface.sensors, path.name


def _without(text: str, line: str) -> str:
    assert line in text, line
    return text.replace(line, "", 1)


# a sampled converter added to the example (it reads the cart's rate: any state may be read)
_ADC = '\n[sensors.adc_v]\nkind = "adc"\nstate = "dx"\nbits = 12\nrange = [-5.0, 5.0]\n'


def _hostile():
    t = example()
    m = (Path(__file__).parent / "plant_dc_motor.toml").read_text(encoding="utf-8")   # the state-equation form
    return [
        ("not TOML", "[plant\n", "not valid TOML"),
        ("unknown top-level table", t + "\n[physics]\nx = 1\n", "unknown top-level key"),
        ("no name", t.replace('name = "my_cart"', ""), r"plant\.name: is missing"),
        ("bad name", t.replace('name = "my_cart"', 'name = "my cart"'), "not a valid plant name"),
        ("constant without unit", t.replace('g = { unit = "m/s^2", ', "g = { "), r"constants\.g\.unit: is missing"),
        ("constant without value", _without(t, "L = 0.3\n"), r"\[plant\] lacks L"),
        ("constant out of bounds", t.replace("M = 2.0", "M = 500.0"), r"plant\.M = 500.0 is outside its bounds"),
        ("bounds reversed", t.replace("bounds = [0.1, 100.0]", "bounds = [100.0, 0.1]"), "low < high"),
        ("both forms", t + '\n[states.q]\nunit = "m"\nmeaning = "q"\nderivative = "0"\n', "exactly one of the two"),
        ("no dynamics", t.split("[coordinates.x]")[0] + "[inputs.F]\nunit = \"N\"\nmeaning = \"f\"\nrange = [0, 1]\n",
         "exactly one of the two"),
        ("unknown symbol", t.replace('"-L*cos(theta)"', '"-R*cos(theta)"'), r"bodies\.bob\.position\[1\]: unknown symbol 'R'"),
        ("code in an expression", t.replace('"-L*cos(theta)"', "\"__import__('os').system('touch /tmp/pendc_pwned')\""),
         r"bodies\.bob\.position\[1\]"),
        ("attribute access", t.replace('"-L*cos(theta)"', '"L.real"'), r"bodies\.bob\.position\[1\]"),
        ("unknown function", t.replace('"-L*cos(theta)"', '"-L*cosh2(theta)"'), r"bodies\.bob\.position\[1\]"),
        ("syntax error", t.replace('"-L*cos(theta)"', '"-L*cos(theta"'), r"bodies\.bob\.position\[1\]"),
        ("vector of mixed size", t.replace('position = ["x", 0]', 'position = ["x", 0, 0]'), "all 2-D or all 3-D"),
        ("mass without position", t.replace('position = ["x", 0]\n', ""), r"bodies\.cart\.position: a mass needs"),
        ("body without mass or inertia", t.replace("[bodies.bob]\n", '[bodies.hub]\nrotation = "theta"\n\n[bodies.bob]\n'),
         r"bodies\.hub: has neither a mass nor an inertia"),
        ("constant of 0 a state equation divides by", m.replace("L_a = 1.8e-4", "L_a = 0.0").replace(
            'meaning = "armature inductance" }', 'meaning = "armature inductance", bounds = [0.0, 1.0] }'),
         r"plant\.L_a = 0\.0: d/dt i divides by L_a, which is then 0"),
        ("masses of 0 that empty the determinant", t.replace("M = 2.0", "M = 0.0").replace(
            "bounds = [0.1, 100.0]", "bounds = [0.0, 100.0]"),
         r"plant\.M = 0\.0: ddx divides by det, which is then 0 at the start state"),
        ("inertia without rotation", t.replace('mass = "M"', 'mass = "M"\ninertia = "m"'), "rotation"),
        ("unknown body kind", t.replace("[bodies.bob]\n", '[bodies.bob]\nkind = "blob"\n'), "unknown body kind 'blob'"),
        ("gravity beside the energies", t.split("[bodies.cart]")[0].replace(
            '[mechanics]', '[mechanics]\nkinetic = "M*dx**2/2"\npotential = "0"') + "[inputs.F]" + t.split("[inputs.F]")[1],
         r"mechanics\.gravity: acts on \[bodies\]; with the energies given"),
        ("no gravity", _without(t, 'gravity = [0, "-g"]                # the last component points up\n'),
         r"mechanics\.gravity: is missing"),
        ("singular mass matrix", t.replace('mass = "m"\n', 'mass = "0*m"\n'), "mass matrix is singular"),
        ("no input", t.replace("[inputs.F]", "[unused]").replace('unit = "N"\nmeaning = "force on the cart (N)"\n'
                                                                 "range = [-20.0, 20.0]\n", ""), "inputs"),
        ("input without range", _without(t, "range = [-20.0, 20.0]\n"), r"inputs\.F\.range: is missing"),
        ("algebraic loop", t.replace("[sensors.enc_x]", '[intermediates]\nF_a = "F_b + F"\nF_b = "2*F_a"\n\n'
                                     "[sensors.enc_x]").replace('force = "F"\n', 'force = "F_a"\n'),
         r"intermediates\.F_a: algebraic loop F_a -> F_b -> F_a"),
        ("intermediate out of order", t.replace("[sensors.enc_x]", '[intermediates]\nF_a = "F_b + F"\nF_b = "2*F"\n\n'
                                                "[sensors.enc_x]").replace('force = "F"\n', 'force = "F_a"\n'),
         r"intermediates\.F_a: uses 'F_b' before it is defined"),
        ("state without a derivative", m.replace('derivative = "omega"\n', ""), r"states\.phi\.derivative: is missing"),
        ("derivative of an unknown symbol", m.replace('derivative = "omega"', 'derivative = "omega2"'),
         r"states\.phi\.derivative: unknown symbol 'omega2'"),
        ("rate of an unknown state", m.replace('rate_of = "phi"', 'rate_of = "psi"'),
         r"states\.omega\.rate_of: rate_of names unknown state 'psi'"),
        ("initial not a constant", m.replace('rate_of = "phi"', 'rate_of = "phi"\ninitial = "2*i"'),
         r"states\.omega\.initial: unknown name 'i'"),
        ("state range reversed", m.replace('derivative = "(v - R*i - k*omega)/L_a"',
                                           'derivative = "(v - R*i - k*omega)/L_a"\nrange = [2.0, -2.0]'),
         r"states\.i\.range: must be \[low, high\] with low < high"),
        ("range of a periodic state", m.replace("period = 6.283185307179586", "period = 6.283185307179586\nrange = [0.0, 1.0]"),
         r"phi\.range: a periodic position \(period 6\.28319\) takes no range"),
        ("training rate of a position", m.replace('derivative = "(v - R*i - k*omega)/L_a"',
                                                  'derivative = "(v - R*i - k*omega)/L_a"\ntraining_rate = 3.0'),
         r"states\.i\.training_rate: is for a rate state"),
        ("state equation of the wrong unit", m.replace('derivative = "omega"', 'derivative = "omega*J"'),
         r"states\.phi\.derivative: d/dt phi has units of kg\*m\^2/s \(J\*s\), expected 1/s"),
        ("neutral outside the range", t.replace("range = [-20.0, 20.0]", "range = [-20.0, 20.0]\nneutral = 30.0"),
         r"inputs\.F\.neutral: neutral 30 lies outside the range"),
        ("drawing of an unknown symbol", t.replace('points = { cart = ["x", 0]', 'points = { cart = ["xx", 0]'),
         r"drawing\.points\.cart\[0\]: unknown symbol 'xx'"),
        ("two inputs", t.replace("[inputs.F]", '[inputs.G]\nunit = "N"\nmeaning = "a second force"\nrange = [-1.0, 1.0]\n\n'
                                 "[inputs.F]"), r"inputs: declares 2 inputs \(G, F\); a plant has one input"),
        ("sensor of an unknown state", t.replace('state = "x"', 'state = "y"'), r"sensors\.enc_x\.state: names unknown position 'y'"),
        ("two sensors on one state", t.replace("[sensors.enc_theta]", '[sensors.enc_x2]\nstate = "x"\nband = 1e-4\n'
                                               'lines = 1000\nbands_per_rev = 2000\n\n[sensors.enc_theta]'),
         r"sensors: enc_x and enc_x2 both read 'x'"),
        ("sensor band zero", t.replace("band = 1e-4", "band = 0.0"), r"sensors\.enc_x\.band: must be positive"),
        ("sensor of an unknown kind", t + _ADC.replace('"adc"', '"sar"'), r"sensors\.adc_v\.kind: unknown sensor kind 'sar'"),
        ("converter without bits", t + _ADC.replace("bits = 12\n", ""), r"sensors\.adc_v\.bits: is missing"),
        ("converter of too many bits", t + _ADC.replace("bits = 12", "bits = 40"), r"sensors\.adc_v\.bits: must be at most 24"),
        ("converter of zero bits", t + _ADC.replace("bits = 12", "bits = 0"), r"sensors\.adc_v\.bits: must be a positive whole"),
        ("converter range reversed", t + _ADC.replace("[-5.0, 5.0]", "[5.0, -5.0]"),
         r"sensors\.adc_v\.range: must be \[low, high\] with low < high"),
        ("converter with an encoder's key", t + _ADC + "band = 1e-4\n", r"sensors\.adc_v: unknown key 'band'"),
        ("converter of an unknown state", t + _ADC.replace('"dx"', '"q"'), r"sensors\.adc_v\.state: names unknown state 'q'"),
        ("unknown effect kind", t.replace('kind = "viscous"', 'kind = "magic"'), "unknown effect kind 'magic'"),
        ("effect role missing", _without(t, 'coefficient = "b"\n'), r"catalogue\.damping\.coefficient: an effect of kind 'viscous' needs"),
        ("effect on nothing", t.replace('on = "theta"', 'on = "phi"'), r"catalogue\.damping\.on: 'phi' is not a coordinate"),
        ("unknown role", t.replace('coefficient = "b"', 'coefficient = "b"\nstiffness = "b"'), "unknown key 'stiffness'"),
        ("effect parameter without meaning", t.replace(', meaning = "pivot damping"', ""), r"params\.b\.meaning: is missing"),
        ("active effect not in the catalogue", t + "\n[effects.spring]\nk = 1.0\n", "unknown effect 'spring'"),
        ("effect parameter named like a force", t.replace('coefficient = "b"', 'coefficient = "tau_theta"').replace(
            "params.b = {", "params.tau_theta = {").replace("b = 2e-3", "tau_theta = 2e-3"),
         r"catalogue\.damping\.params\.tau_theta: the name tau_theta is already coordinates\.theta\.force"),
        ("effect parameter named like a constant", t.replace('coefficient = "b"', 'coefficient = "L"').replace(
            "params.b = {", "params.L = {").replace("b = 2e-3", "L = 2e-3"),
         r"catalogue\.damping\.params\.L: the name L is already constants\.L"),
        ("effect value out of range", t.replace("b = 2e-3", "b = 5.0"), r"damping\.b = 5\.0 is outside its physical range"),
        ("experiment holds an unknown coordinate", t + '\n[experiments.held]\nmeaning = "m"\nheld = ["y"]\n',
         "names unknown coordinate 'y'"),
        ("experiment removes an unknown body", t + '\n[experiments.off]\nmeaning = "m"\nremoved = ["wheel"]\n',
         "names unknown body 'wheel'"),
        ("operating point of an unknown state", t.replace('upright = { theta = "pi" }', 'up = { phi = "pi" }'),
         "names unknown state 'phi'"),
        ("extends a missing file", '# values\nextends = "nowhere.toml"\n[plant]\ng = 9.8\n', "nowhere.toml"),
        ("extends and physics", 'extends = "x.toml"\n' + t, "declares no physics"),
        ("shipped plant unknown", '[plant]\nbody = "zeppelin"\ng = 9.8\n', "'zeppelin' is not a shipped plant"),
        ("inconsistent units", t.replace('force = "F"', 'force = "F + b"'),
         r"F_x \(the generalized force on x, the sum of the forces acting on it\): inconsistent units: "
         r"'F' is kg\*m/s\^2"),
        ("a force of the wrong unit", t.replace('coefficient = "b"', 'coefficient = "b*M"'),
         "the generalized force on theta has units of"),
        ("unknown unit", t.replace('unit = "N*m*s/rad"', 'unit = "Nm*s/rad"'), "unknown unit 'Nm'"),
    ]


HOSTILE = _hostile()


@pytest.mark.parametrize("label, text, message", HOSTILE, ids=[h[0] for h in HOSTILE])
def test_a_malformed_plant_file_gets_one_line(label, text, message, tmp_path):
    path = tmp_path / "plant.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(PendcError) as info:
        model = pendc.load_model(path)
        model.equations, model.interface
    line = str(info.value)
    assert "\n" not in line and re.search(message, line), line
    assert line.startswith(str(path)) or "nowhere.toml" in line or "x.toml" in line, line
    assert not Path("/tmp/pendc_pwned").exists()


def test_the_hostile_table_is_large():
    assert len(HOSTILE) >= 25


def test_plant_check_exits_2_with_one_line(tmp_path, capsys):
    from pendc.cli import main

    path = tmp_path / "plant.toml"
    path.write_text(HOSTILE[10][1], encoding="utf-8")
    assert main(["plant", "check", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "unknown symbol 'R'" in err


def test_plant_new_writes_a_file_that_checks(tmp_path, capsys):
    from pendc.cli import main

    target = tmp_path / "rig.toml"
    assert main(["plant", "new", "rig", "-o", str(target)]) == 0
    assert main(["plant", "check", str(target)]) == 0
    out = capsys.readouterr().out
    assert "d/dt dphi = ddphi" in out and "enc_phi" in out
    assert main(["plant", "new", "rig", "-o", str(target)]) == 2          # never overwrites
    assert main(["plant", "check", str(target), "--latex"]) == 0
    latex = capsys.readouterr().out
    assert "\\cos" in latex and "\\frac{d}{dt} \\dot{\\phi} = \\ddot{\\phi}" in latex and " dphi" not in latex.split("equations:")[1]


def test_the_hostile_table_is_documented():
    text = (DOCS.parent / "hostile_inputs.md").read_text(encoding="utf-8")
    for label, _, message in HOSTILE:
        assert f"| {label} | `{message}` |" in text, label


def test_a_state_equation_plant_simulates_to_its_steady_state():
    """A DC motor given by its state equations (input v, not u): the speed settles where the
    back-EMF and the bearing friction balance the voltage, k v / (k^2 + R b)."""
    from pendc.sim.simulator import Simulator

    model = pendc.load_model(Path(__file__).parent / "plant_dc_motor.toml")
    iface = model.interface
    assert [s.name for s in iface.states] == ["i", "phi", "omega"] and iface.input.name == "v"
    assert iface.state("phi").period == pytest.approx(2 * np.pi) and iface.state("omega").derivative_of == "phi"
    t = np.arange(0, 0.2, 1e-6)
    res = Simulator(model)(t, np.where(t > 0.01, 5.0, 0.0))
    v = model.parameter_values()
    steady = v["k"] * 5.0 / (v["k"] ** 2 + v["R"] * v["b"])
    assert res["omega"][-1] == pytest.approx(steady, rel=1e-4)


def test_a_state_equation_plant_starts_where_its_initial_says():
    """``initial`` (a number or an expression of the constants) is the register's reset, where a
    float run starts and where the training runs of the range analysis start."""
    from pendc.passes.lower import lower_model
    from pendc.sim.simulator import Simulator

    text = (Path(__file__).parent / "plant_dc_motor.toml").read_text(encoding="utf-8")
    model = parse_model(text.replace('rate_of = "phi"', 'rate_of = "phi"\ninitial = "k*400"')
                        .replace('derivative = "omega"', 'derivative = "omega"\ninitial = 4.0'), "motor.toml")
    omega0 = 400 * model.parameter_values()["k"]
    assert model.interface.state("omega").initial == pytest.approx(omega0)
    assert model.interface.state("phi").initial == 4.0 and model.interface.state("i").initial == 0.0
    graph = lower_model(model, dt=1e-6)
    assert graph["omega"].params.reset == pytest.approx(omega0) and graph["phi"].params.reset == 4.0
    sim = Simulator(model)
    res = sim(np.array([0.0, 1e-3]), np.zeros(2))
    assert res["omega"][0] == pytest.approx(omega0) and res["phi"][0] == 4.0
    # x0 names the reported states (phi, omega); the current, not reported, starts at its initial
    # (the kernel read the two numbers as i and phi, and omega past the array's end)
    res = sim(np.array([0.0, 1e-3]), np.zeros(2), x0=(1.0, 2.0))
    assert (res["i"][0], res["phi"][0], res["omega"][0]) == (0.0, 1.0, 2.0)


def test_a_converter_on_a_rate_state_gives_it_half_an_lsb_of_budget():
    text = (Path(__file__).parent / "plant_dc_motor.toml").read_text(encoding="utf-8")
    model = parse_model(text + '\n[sensors.tacho]\nkind = "adc"\nstate = "omega"\nbits = 12\nrange = [-512.0, 512.0]\n',
                        "motor.toml")
    assert model.interface.state("omega").budget == pytest.approx(0.5 * 1024 / 4096)


def test_an_energy_of_the_wrong_unit_is_named_at_its_key():
    """Round G: a unit slip in [mechanics] potential was reported against the derived acceleration
    ddq1; the energies are checked as written."""
    text = (Path(__file__).parent / "data" / "pendubot.toml").read_text()
    bad = text.replace('potential = "-g*(th4*cos(q1) + th5*cos(q1 + q2))"', 'potential = "-(th4*cos(q1) + th5*cos(q1 + q2))"')
    assert bad != text
    with pytest.raises(PendcError, match=r"mechanics\.potential: the potential energy has units of kg\*m, expected"):
        parse_model(bad, source="pendubot.toml").equations


# a buck converter's averaged equations: a dimensionless input (the duty cycle) and a resistance
# an ideal switch makes 0
BUCK = buck_toml()


def test_a_constant_whose_bounds_start_at_0_may_be_0():
    """Bounds [0, 1] take 0 as bounds [-1, 1] do (a value lies within its bounds, ends included);
    the bounds alone say what sympy may assume, so both give the same equations, and a copy
    moved to 0 keeps the equations derived for the bounds."""
    zero = BUCK.replace("R_L = 0.02", "R_L = 0.0")
    model = parse_model(zero, "buck.toml")
    straddling = parse_model(zero.replace("bounds = [0.0, 1.0]", "bounds = [-1.0, 1.0]"), "b.toml")
    assert str(model.equations.derivatives) == str(straddling.equations.derivatives)
    (r_l,) = [p for p in model.equations.params if p.name == "R_L"]
    assert r_l.is_nonnegative and r_l.is_positive is None
    assert model.interface.state("i_L").initial == 2.0
    moved = parse_model(BUCK, "buck.toml").with_params({"R_L": 0.0})
    assert moved.plant["R_L"] == 0.0 and moved.interface.input.name == "d"
    with pytest.raises(PendcError, match=r"buck\.toml: plant\.R_L = -0\.1 is outside its bounds \[0, 1\] ohm$"):
        parse_model(BUCK.replace("R_L = 0.02", "R_L = -0.1"), "buck.toml")


def test_a_refused_0_says_why_and_what_to_do():
    """Without bounds a constant is positive: the line says so and how to allow 0; with bounds
    above 0 it quotes them."""
    motor = (Path(__file__).parent / "plant_dc_motor.toml").read_text(encoding="utf-8")
    with pytest.raises(PendcError) as info:
        parse_model(motor.replace("R = 2.6", "R = 0.0"), "m.toml")
    assert str(info.value) == ("m.toml: plant.R must be positive, got 0.0: a constant declared without bounds is "
                               "positive; to allow 0, declare its bounds (constants.R.bounds = [low, high])")
    with pytest.raises(PendcError, match=r"^b\.toml: plant\.C_f must be positive, got 0\.0: its bounds are "
                                         r"\[1e-07, 100\] F$"):
        parse_model(buck_toml(C=0.0), "b.toml")


def test_plant_check_prints_a_dimensionless_input_without_a_dash(tmp_path, capsys):
    from pendc.cli import main

    path = tmp_path / "buck.toml"
    path.write_text(BUCK, encoding="utf-8")
    assert main(["plant", "check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "  d [dimensionless] switch duty cycle (0..1); range 0-1\n" in out, out
    assert "  v_C [V] output capacitor voltage (V)" in out and " -\n" not in out and "[-]" not in out


@pytest.mark.parametrize("old, new, says", [
    ('core = "buck_core"', 'core = "module"', "plant: 'module' is a Verilog keyword and cannot name a core"),
    ("[sensors.adc_v]", "[sensors.wire]", "sensors: 'wire' is a Verilog keyword and cannot name a sensor"),
    ("[sensors.adc_i]", "[sensors.step]", "sensors: 'step' is a port every core has"),
])
def test_a_name_verilog_reserves_is_one_line(old, new, says):
    """Round I: a core named module built `module module (`, a state named step a traceback."""
    with pytest.raises(PendcError, match=f"^b\\.toml: {re.escape(says)}"):
        parse_model(BUCK.replace(old, new), "b.toml")


def test_a_singular_mass_matrix_from_energies_names_the_kinetic_energy():
    """Round I: a kinetic energy without the elbow's rate was blamed on "bodies:" in a file that has none."""
    text = (Path(__file__).parent / "data" / "pendubot.toml").read_text(encoding="utf-8")
    bad = text.replace('kinetic = "th1*dq1^2/2 + th2*(dq1 + dq2)^2/2 + th3*cos(q2)*dq1*(dq1 + dq2)"',
                       'kinetic = "th1*dq1^2/2"')
    assert bad != text
    with pytest.raises(PendcError, match=r"^pendubot\.toml: mechanics\.kinetic: the mass matrix is singular .*"
                                         r"every coordinate's rate appears squared\)$"):
        parse_model(bad, source="pendubot.toml").equations
