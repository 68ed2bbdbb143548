"""Sampled converters (ADC sensors): the plant file's [sensors] kind = "adc", the lowering of
the code rule to IR nodes (bit-exact in the interpreter and the compiled golden kernel), the
float reading of pendc simulate and the data generator, the bus wrapper's register."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendc.errors import PendcError
from pendc.ir.graph import Graph
from pendc.ir.interpret import FixedInterpreter
from pendc.ir.nodes import Kind, make
from pendc.ir.verify import verify
from pendc.model.interface import PlantInterface, StateSpec, InputSpec
from pendc.model.sensors import ADC, ConverterStep, SensorSpec
from pendc.model.modelfile import parse_model
from pendc.passes.lower_sensors import lower_adc
from pendc.passes.qformats import assign_qformats
from pendc.passes.ranges import Ranges
from pendc.sim.encoders import quantize, sensor_reading

from test_plantfile import _ADC, example as example_text


def _spec(lo=-0.212725, hi=0.212725, bits=12):
    return SensorSpec("adc_x", "x", "ball", kind=ADC, bits=bits, lo=lo, hi=hi)


def test_a_plant_file_declares_a_converter():
    model = parse_model(example_text() + _ADC)
    iface = model.interface
    adc = next(s for s in iface.sensors if s.name == "adc_v")
    assert (adc.kind, adc.state, adc.bits, adc.lo, adc.hi) == (ADC, "dx", 12, -5.0, 5.0)
    assert adc.code_port == "adc_v_code" and adc.channels == () and adc.ports == ("adc_v_code",)
    assert float(adc.resolution) == pytest.approx(10.0 / 4096)
    assert iface.register_names()["adc_v"] == ("ADC_V_CODE",)
    enc = next(s for s in iface.sensors if s.name == "enc_x")        # the default kind is the encoder
    assert enc.kind == "quadrature_encoder" and iface.register_names()["enc_x"] == ("ENC_X_COUNT",)


def test_the_float_rule_rounds_down_and_clamps():
    s = _spec(-0.5, 0.5, 4)                                       # q = 1/16 exactly
    values = [-1.0, -0.5, -0.5 + 1 / 16 - 1e-12, -0.5 + 1 / 16, 0.0, 0.49, 0.5, 3.0]
    assert list(s.code(np.array(values))) == [0, 0, 0, 1, 8, 15, 15, 15]
    assert s.reading(0) == pytest.approx(-0.5 + 1 / 32) and s.reading(15) == pytest.approx(0.5 - 1 / 32)


def _graph(spec, full_scale=1.0):
    nodes, reg = lower_adc(spec, "s", "ball position")
    g = Graph.build("adc", [make("s", Kind.INPUT, port="s", max_abs=full_scale)] + nodes, [("code", reg)])
    declared = {n.name: float(n.params.max_abs or 0.0) for n in g.nodes}
    typed = assign_qformats(g, Ranges(max_abs=declared, lo={}, hi={}, sources=()), margin_bits=1)
    verify(typed)
    return typed


def _codes(graph, values):
    """The code register after each value (the register shows the code of the previous step's value)."""
    out = FixedInterpreter(graph).run({"s": np.append(values, 0.0)}).outputs["code"]
    fmt = graph.output("code").qformat
    return np.asarray(out[1:], dtype=np.float64) * fmt.lsb if fmt is not None else np.asarray(out[1:])


@pytest.mark.parametrize("lo, hi, bits", [(-0.5, 0.5, 12), (-0.212725, 0.212725, 12), (0.3, 1.7, 5), (-2.0, 1.0, 1)])
def test_the_lowered_code_follows_the_rule_at_every_edge(lo, hi, bits):
    spec = _spec(lo, hi, bits)
    graph = _graph(spec, full_scale=2 * max(abs(lo), abs(hi)) + 1)
    assert not any(n.kind in (Kind.MUL, Kind.GAIN, Kind.LUT) for n in graph.nodes), "no multiplier, no table"
    q = (hi - lo) / (1 << bits)
    ks = sorted({0, 1, 2, (1 << bits) // 2, (1 << bits) - 2, (1 << bits) - 1, 1 << bits} | set(range(0, 1 << bits, max(1, (1 << bits) // 37))))
    edges = np.array([lo + k * q for k in ks])
    # just below and just above every step (1e-4 LSB: beyond the input port's and the thresholds' rounding)
    values = np.concatenate([edges - 1e-4 * q, edges + 1e-4 * q, [lo - 5 * q, lo - 1.0, hi, hi + q, hi + 1.0]])
    got = _codes(graph, values)
    want = spec.code(values)
    assert np.array_equal(got, want), [(v, g, w) for v, g, w in zip(values, got, want) if g != w][:5]
    assert want.min() == 0 and want.max() == (1 << bits) - 1          # both clamps were exercised


def test_golden_kernel_and_interpreter_agree_with_the_float_rule():
    from pendc.golden import GoldenStepper
    spec = _spec()
    graph = _graph(spec)
    rng = np.random.default_rng(5)
    values = np.concatenate([rng.uniform(-0.3, 0.3, 3000), rng.normal(0.0, 1e-4, 500)])
    interp = _codes(graph, values)
    fmt_in, fmt_out = graph["s"].qformat, graph.output("code").qformat
    stepper = GoldenStepper(graph)
    kernel = []
    for v in values:
        kernel.append(stepper.advance(fmt_in.from_float(float(v)), 1)[-1][0] * fmt_out.lsb)
    assert np.array_equal(interp, np.array(kernel))
    # the rule on the value the hardware saw (the input port rounds it to its format)
    seen = np.array([fmt_in.to_float(fmt_in.from_float(float(v))) for v in values])
    exact = (seen - spec.lo) / float(spec.resolution)
    near = np.abs(exact - np.round(exact)) < 1e-6
    assert np.array_equal(interp[~near], spec.code(seen)[~near])
    assert near.sum() < 5


def test_the_simulated_reading_is_the_converters():
    step = _spec().resolution
    assert isinstance(step, ConverterStep) and float(step) == pytest.approx(0.42545 / 4096)
    x = np.array([0.1, -0.5, 0.0, 0.2127, 0.3, 1e-9])
    got = quantize(x, step)
    code = _spec().code(x)
    assert np.allclose(got, -0.212725 + (code + 0.5) * float(step))
    assert got[1] == pytest.approx(-0.212725 + 0.5 * float(step))     # clipped below, absolute
    assert got[4] == pytest.approx(0.212725 - 0.5 * float(step))      # clipped above
    assert np.all(np.abs(got[[0, 2, 3, 5]] - x[[0, 2, 3, 5]]) <= float(step) / 2)
    enc = SensorSpec("enc", "x", "cart", band=1e-3)                   # an encoder counts from the first sample
    assert np.allclose(sensor_reading(enc, np.array([0.0123, 0.0131])), [0.0123, 0.0133])


_X_OFFSET = """
[catalogue.x_offset]
kind = "offset"
on = "x"
offset = "x_off"
summary = "the converter reads x + x_off"
params.x_off = { unit = "m", default = 0.0, bounds = [-0.1, 0.1], meaning = "offset of the converter" }

[effects.x_offset]
x_off = 0.0123
"""


def _x_on_a_converter(extra: str = ""):
    """The example plant with its cart position read by an 8-bit converter over [-1, 1] m."""
    return parse_model(example_text().replace(
        '[sensors.enc_x]\nstate = "x"\n', '[sensors.enc_x]\nkind = "adc"\nstate = "x"\nbits = 8\nrange = [-1.0, 1.0]\n')
        .replace("band = 1e-4                        # motion of one light or dark band (x4 decoding: band/2 per count)\n"
                 "lines = 1000\nbands_per_rev = 2000\n", "", 1) + extra)


def test_a_converters_sensor_offset_is_in_the_core():
    """The private check ran a maglev 'with a miscalibrated sensor' in HIL and got the run without it
    to the last digit: the core and the HIL plants reported the state itself. A converter now codes
    state + offset: the lowering shifts its range (no node added), the float plant's code rule too."""
    from pendc.hil.plants.plant import FloatPlant
    from pendc.passes.lower import lower_model
    plain, shifted = _x_on_a_converter(), _x_on_a_converter(_X_OFFSET)
    assert shifted.sensor_offset_values() == {"x": pytest.approx(0.0123)}
    assert shifted.sensor_offsets_without_hardware() == []          # build and hil note nothing
    g0, g1 = lower_model(plain), lower_model(shifted)
    assert [n.name for n in g0.nodes] == [n.name for n in g1.nodes]
    assert g1["enc_x_lo"].param("value") == pytest.approx(-1.0123) and g0["enc_x_lo"].param("value") == -1.0
    spec = _spec(-1.0, 1.0, 8)
    nodes, reg = lower_adc(spec, "s", "x", offset=0.0123)
    g = Graph.build("adc", [make("s", Kind.INPUT, port="s", max_abs=3.0)] + nodes, [("code", reg)])
    declared = {n.name: float(n.params.max_abs or 0.0) for n in g.nodes}
    typed = assign_qformats(g, Ranges(max_abs=declared, lo={}, hi={}, sources=()), margin_bits=1)
    values = np.linspace(-1.2, 1.2, 997)
    want = spec.code(values + 0.0123)
    near = np.abs(((values + 0.0123 + 1.0) * 128) % 1.0) < 1e-6     # on a threshold: the constants' rounding
    assert np.array_equal(_codes(typed, values)[~near], want[~near]) and want.min() == 0 and want.max() == 255
    adc = FloatPlant(shifted).ports.adc_of("x")
    assert adc.code(0.5) == spec.code(0.5123) and adc.reading(adc.code(0.5)) == pytest.approx(0.5123, abs=1 / 256)


def test_the_data_generators_readings_use_the_converter():
    from pendc.ident.datagen import encoder_readings
    from pendc.sim.signals import signals_of
    model = _x_on_a_converter()
    sig = signals_of(model)
    x = np.linspace(-1.5, 1.5, 101)
    got = encoder_readings(sig, {"x": x})["x"]
    code = np.clip(np.floor((x + 1.0) * 128), 0, 255)
    assert np.allclose(got, -1.0 + (code + 0.5) / 128)


def test_interface_checks():
    with pytest.raises(ValueError, match="bits must be"):
        SensorSpec("a", "x", "b", kind=ADC, bits=0, lo=0.0, hi=1.0)
    with pytest.raises(ValueError, match="low < high"):
        SensorSpec("a", "x", "b", kind=ADC, bits=8, lo=1.0, hi=1.0)
    states = (StateSpec("x", "m", "x"),)
    with pytest.raises(ValueError, match="also the name of a state"):
        PlantInterface("p", "p_core", states + (StateSpec("a_code", "m", "y"),), (InputSpec("u", "V", "u", 1.0),),
                       sensors=(SensorSpec("a", "x", "b", kind=ADC, bits=8, lo=0.0, hi=1.0),))


def test_the_wrapper_has_a_code_register():
    from pendc.backend.wrapper import code_bits, register_map
    iface = parse_model(example_text() + _ADC).interface
    ports = {"F": {"signed": True, "width": 32, "frac": 25}}
    ports.update({p: {"signed": True, "width": 40, "frac": 30} for p in iface.outputs})
    with pytest.raises(ValueError, match="adc_v_code"):
        register_map(ports, interface=iface)
    ports["adc_v_code"] = {"signed": True, "width": 32, "frac": 18}
    regs = {r["name"]: r for r in register_map(ports, interface=iface)}
    assert regs["ADC_V_CODE"]["width"] == 12 and regs["ADC_V_CODE"]["access"] == "ro"
    assert "floor" in regs["ADC_V_CODE"]["description"]
    assert code_bits(iface.sensors[-1], ports) == (29, 18)
    ports["adc_v_code"] = {"signed": True, "width": 32, "frac": 22}
    with pytest.raises(ValueError, match="cannot hold"):
        code_bits(iface.sensors[-1], ports)


def test_bad_converter_values_are_one_line_errors():
    for text, message in ((_ADC.replace("bits = 12", "bits = 25"), "at most 24"),
                          (_ADC.replace("[-5.0, 5.0]", "[1.0, nan]"), "")):
        with pytest.raises(PendcError) as exc:
            parse_model(example_text() + text)
        assert "\n" not in str(exc.value) and message in str(exc.value)
    assert math.isfinite(float(_spec().resolution))
