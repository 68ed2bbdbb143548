"""The input range of the plant interface (what the actuator takes: the SCT drive 0-10 V as the
thesis prints it, the QUBE's amplifier ±10 V as its user manual does), read from the model
file where it says, validated, and used by identification: the saturation regime, the
identification stimuli and DAC, and the reader's plausibility checks."""

from pathlib import Path

import numpy as np
import pytest

import pendc
from pendc.errors import PendcError
from pendc.ident.datagen import dac_output, degrade_input, identification_experiment
from pendc.ident.regimes import regime_partitions
from pendc.model.interface import InputSpec
from pendc.model.modelfile import model_fingerprint, parse_model
from pendc.model.model_writer import dumps_model
from pendc.sim.measurements import format_csv, parse_measurements
from pendc.sim.readers import ReadOptions

MODELS = Path(__file__).resolve().parents[1] / "models"
THESIS_LINE = "converts the input voltage having a range from 0 to 10V"


@pytest.fixture(scope="module")
def sct():
    return pendc.load_model()


@pytest.fixture(scope="module")
def qube():
    return pendc.load_model(MODELS / "furuta_qube.toml")


def test_the_shipped_plants_declare_what_their_actuators_take(sct, qube):
    thesis = Path("/work/shared/reference/thesis.txt")
    if thesis.is_file():                  # the figure the SCT's range comes from
        assert THESIS_LINE in thesis.read_text()
    drive, amplifier = sct.interface.input.range, qube.interface.input.range
    assert (drive.lo, drive.hi, drive.unit) == (0.0, 10.0, "V") and drive.describe() == "0-10 V"
    assert (amplifier.lo, amplifier.hi, amplifier.unit) == (-10.0, 10.0, "V") and amplifier.describe() == "±10 V"
    # the model file's source figures: the QUBE's recommended amplifier range
    assert "recommended output range +-10 V" in (MODELS / "furuta_qube.toml").read_text()
    # the hardware port keeps its full scale (the larger end)
    assert sct.interface.input.full_scale == 10.0 and qube.interface.input.full_scale == 10.0


def _saturated(plant, u):
    partitions = dict(regime_partitions(plant, {}, np.asarray(u, float), 0.0))
    return {name: mask for name, _, mask in partitions["input saturation"]}["saturated"]


def test_saturation_at_0_and_10_volts_on_the_sct(sct):
    u = [0.0, 0.04, 0.2, 5.26, 9.8, 9.96, 10.0]
    assert _saturated(sct, u).tolist() == [True, True, False, False, False, True, True]


def test_saturation_at_both_signs_on_the_furuta(qube):
    u = [-10.0, -9.95, -5.0, 0.0, 0.04, 9.8, 9.95, 10.0]
    assert _saturated(qube, u).tolist() == [True, True, False, False, False, False, True, True]


def test_the_saturation_regime_says_where_it_starts(sct, qube):
    for plant, words in ((sct, "u <= 0.05 or >= 9.95 V"), (qube, "u <= -9.9 or >= 9.9 V")):
        part = dict(regime_partitions(plant, {}, np.zeros(3), 0.0))["input saturation"]
        assert part[0][1] == words


def test_a_model_file_gives_the_range_and_it_round_trips(sct):
    text = (MODELS / "sct_rig.toml").read_text()
    narrow = parse_model(text + "\n[input]\nrange = [0.5, 8.0]\n", "narrow.toml")
    spec = narrow.interface.input
    assert (spec.lo, spec.hi, spec.full_scale) == (0.5, 8.0, 8.0)
    assert parse_model(dumps_model(narrow), "again.toml") == narrow
    # what the compiler reads changes (the port's full scale), so the fingerprint does;
    # a file without [input] keeps the fingerprint it had
    plain = parse_model(text, "plain.toml")
    assert plain.input_range is None and model_fingerprint(plain) != model_fingerprint(narrow)
    assert model_fingerprint(parse_model(text + "\n[input]\nrange = [0.0, 10.0]\n", "same.toml")) != \
        model_fingerprint(plain)


@pytest.mark.parametrize("table, message", [
    ("range = [10.0, 0.0]", r"^bad\.toml: input\.range must have low < high, got \[10\.0, 0\.0\]$"),
    ("range = [5.0, 5.0]", r"low < high"),
    ("range = [0.0, inf]", r"^bad\.toml: input\.range must be finite"),
    ("range = [0.0, nan]", r"must be finite"),
    ("range = [0.0]", r"^bad\.toml: input\.range must be \[low, high\]"),
    ("range = ['a', 1.0]", r"must be two numbers"),
    ("range = [false, 1.0]", r"must be two numbers"),
    ("lo = 0.0", r"^bad\.toml: \[input\] may only hold 'range = \[low, high\]'"),
    ("", r"^bad\.toml: \[input\] lacks 'range = \[low, high\]'$"),
])
def test_a_bad_range_is_one_line(table, message):
    text = (MODELS / "sct_rig.toml").read_text() + f"\n[input]\n{table}\n"
    with pytest.raises(PendcError, match=message) as err:
        parse_model(text, "bad.toml")
    assert "\n" not in str(err.value)


def test_an_input_spec_checks_its_range():
    assert InputSpec("v", "V", "a voltage", 5.0).range == InputSpec("v", "V", "a voltage", 5.0, -5.0, 5.0).range
    with pytest.raises(PendcError, match="low < high"):
        InputSpec("v", "V", "a voltage", 5.0, 2.0, 1.0)
    with pytest.raises(PendcError, match=r"exceeds its full scale ±5"):
        InputSpec("v", "V", "a voltage", 5.0, 0.0, 10.0)


def test_the_stimuli_and_the_dac_stay_in_the_range(sct, qube):
    t, u = identification_experiment(plant=sct)
    assert u.min() >= 0.0 and u.max() <= 10.0 and u[-1] == sct.interface.input.neutral   # idle at the end
    assert u.max() - u.min() == pytest.approx(5.6)        # the levels' ±2.8 on a 10 V span
    _, u = identification_experiment(plant=qube)
    assert u.min() < -2.0 and u.max() > 2.0 and u[-1] == 0.0   # the ±10 V amplifier takes both signs
    assert u.max() - u.min() == pytest.approx(11.2)       # the same levels on a 20 V span
    amplifier = qube.interface.input.range
    codes = (dac_output(u, amplifier) - amplifier.lo) / (amplifier.span / 4095)
    assert np.allclose(codes, np.round(codes), atol=1e-6)
    assert dac_output(-10.0, amplifier) == -10.0 and dac_output(10.0, amplifier) == pytest.approx(10.0)
    seen = degrade_input(np.full(2000, -3.0), amplifier)
    assert abs(np.mean(seen) + 3.0) < 2e-3 and 0.003 < np.std(seen) < 0.007


def test_the_reader_warns_outside_the_actuators_range(sct, qube):
    t = np.arange(5) / 1000
    u = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
    sct_file = format_csv({"t": t, "u": u, "x": np.zeros(5), "theta": np.zeros(5)})
    warned = parse_measurements(sct_file, source="sct.csv").warnings
    assert any("u outside 0-10 V in 2 of 5 samples" in w for w in warned), warned
    qube_file = format_csv({"t": t, "u": u, "phi_r": np.zeros(5), "alpha_p": np.zeros(5)})
    assert parse_measurements(qube_file, source="qube.csv", options=ReadOptions(plant=qube)).warnings == ()


def test_the_unit_check_quotes_the_range(sct):
    t = np.arange(400) / 1000
    text = format_csv({"t": t, "u": np.full(400, 5000.0), "x": np.zeros(400), "theta": np.zeros(400)})
    with pytest.raises(PendcError, match=r"spans 0-10 V\): use --u-unit mV"):
        parse_measurements(text, source="mv.csv", options=ReadOptions(plausible=True))


def test_without_a_drive_offset_the_input_rests_mid_range(sct, qube):
    from pendc.ident.regimes import input_centre

    assert input_centre(sct) == sct.effects["drive"]["V_off"]
    undriven = parse_model("[plant]\n" + "\n".join(f"{k} = {v!r}" for k, v in sct.plant.items()) + "\n", "rigid.toml")
    # no drive law: the input's neutral, which the file declares (the drive's 5.2646 V; round G's
    # tanks split the drive regime at their range's middle, 11 V, not at their neutral 9.26 V)
    assert input_centre(undriven) == undriven.interface.input.neutral == 5.2646
    assert input_centre(qube) == 0.0
