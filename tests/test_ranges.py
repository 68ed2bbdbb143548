"""Range analysis (pendc.passes.ranges): per-node maxima from simulating the untyped graph."""

from pathlib import Path

import numpy as np
import pytest

import pendc
from pendc.ir.graph import Graph
from pendc.ir.nodes import Kind, make
from pendc.passes.eliminate_common import eliminate_common_subexpressions
from pendc.passes.fold_constants import fold_constants
from pendc.passes.lower import lower_model
from pendc.ir.compiled import quantize
from pendc.ir.qformat import QFormat
from pendc.passes.ranges import envelope_runs, full_scale_switching, Ranges, analyze_ranges, per_step, per_step_integers
from plants import steps as step_stimulus
from plants import swing_up

DT = 1e-6


# -- per_step ------------------------------------------------------------------------------

def test_per_step_holds_each_sample_for_its_interval():
    t = np.array([0.0, 3e-6, 4e-6, 9e-6])
    u = np.array([1.0, 2.0, 3.0, 4.0])
    np.testing.assert_array_equal(per_step(u, t, DT), [1, 1, 1, 2, 3, 3, 3, 3, 3])   # last sample: no interval


def test_per_step_at_the_stimulus_rate():
    t, u = swing_up(duration=0.01)
    held = per_step(u, t, DT)
    assert len(held) == 10_000
    np.testing.assert_array_equal(held[::1000], u[:-1])
    assert np.all(held[:1000] == u[0]) and np.all(held[1000:2000] == u[1])


def test_per_step_integers_are_every_held_step_quantised():
    """Each sample quantised once and held: the integers of quantising every step, including
    rounding ties and saturation; the last sample (no interval) is never quantised."""
    t, u = swing_up(duration=0.01)
    u = (u - u.mean()) * 400.0             # beyond the format both ways: both saturations
    u[3] = 2.5 * 2.0 ** -8                   # a tie at the format's LSB
    u[-1] = np.nan                           # held for no step
    fmt = QFormat.parse("FIX16_8")
    ints = per_step_integers(u, t, DT, fmt)
    np.testing.assert_array_equal(ints, quantize(per_step(u, t, DT), fmt))
    assert ints.dtype == np.int64 and ints.max() == fmt.max_int and ints.min() == fmt.min_int


def test_per_step_rounds_interval_lengths_and_never_drops_a_sample():
    t = np.array([0.0, 2.4e-6, 2.6e-6, 5.0e-6])    # 2.4 steps, 0.2 steps (-> 1), 2.4 steps
    np.testing.assert_array_equal(per_step(np.array([5.0, 6.0, 7.0, 8.0]), t, DT), [5, 5, 6, 7, 7])


# -- a hand-made graph -------------------------------------------------------------------------

def small_graph():
    """acc[n+1] = acc[n] + 0.5*u;  y = sin(acc) by table;  sq = u*u."""
    nodes = [
        make("u", Kind.INPUT, port="u"),
        make("acc", Kind.REGISTER, ["acc_next"], reset=0.25),
        make("half", Kind.GAIN, ["u"], value=0.5),
        make("acc_next", Kind.ADD, ["acc", "half"]),
        make("y", Kind.LUT, ["acc"], expr="sin(v)", lo=None, hi=None, periodic=False, addr_bits=6,
             interpolate=True),
        make("sq", Kind.MUL, ["u", "u"]),
    ]
    return Graph.build("small", nodes, [("acc", "acc"), ("y", "y"), ("sq", "sq")])


def ramp_stimuli():
    t = np.arange(6) * DT
    return {"up": (t, np.array([1.0, 2.0, -3.0, 0.5, 0.0, 9.0])),
            "down": (t[:4], np.array([-4.0, -1.0, -1.0, 7.0]))}


@pytest.mark.parametrize("engine", ["interpreter", "compiled"])
def test_hand_graph_maxima(engine):
    r = analyze_ranges(small_graph(), ramp_stimuli(), DT, engine=engine)
    assert isinstance(r, Ranges)
    assert r.sources == ("up", "down") and r.overridden == ()
    # "up" runs 5 steps (u = 1, 2, -3, 0.5, 0) and "down" 3 steps (u = -4, -1, -1)
    assert r["u"] == 4.0
    assert r["sq"] == 16.0
    assert r["half"] == 2.0
    # acc rows: up 0.25, 0.75, 1.75, 0.25, 0.5; down 0.25, -1.75, -2.25
    assert r["acc"] == pytest.approx(2.25)
    assert r["acc_next"] == pytest.approx(2.75)   # after the last step of "down" (-2.25 - 0.5)
    assert r["y"] == pytest.approx(max(abs(np.sin(v)) for v in (0.25, 0.75, 1.75, 0.5, -1.75, -2.25)))
    # LUT inputs get their signed extent too
    assert set(r.lo) == set(r.hi) == {"acc"}
    assert r.lo["acc"] == pytest.approx(-2.25) and r.hi["acc"] == pytest.approx(1.75)


def test_hand_graph_engines_agree():
    a = analyze_ranges(small_graph(), ramp_stimuli(), DT, engine="interpreter")
    b = analyze_ranges(small_graph(), ramp_stimuli(), DT, engine="compiled")
    assert a.max_abs == pytest.approx(b.max_abs, rel=1e-15)
    assert a.lo == b.lo and a.hi == b.hi


def test_overrides_replace_what_was_measured():
    r = analyze_ranges(small_graph(), ramp_stimuli(), DT, overrides={"sq": 100, "acc": 0.5},
                       engine="interpreter")
    assert r["sq"] == 100.0 and r["acc"] == 0.5
    assert r.overridden == ("acc", "sq")
    assert r["u"] == 4.0


def test_override_of_unknown_node_raises():
    with pytest.raises(ValueError, match="nonexistent"):
        analyze_ranges(small_graph(), ramp_stimuli(), DT, overrides={"nonexistent": 1.0}, engine="interpreter")


def test_unknown_engine_raises():
    with pytest.raises(ValueError, match="engine"):
        analyze_ranges(small_graph(), ramp_stimuli(), DT, engine="verilator")


# -- the default model ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def model():
    return pendc.load_model()


@pytest.fixture(scope="module")
def untyped(model):
    return eliminate_common_subexpressions(fold_constants(lower_model(model, dt=DT)))


@pytest.fixture(scope="module")
def stimuli():
    return {"swing_up": swing_up(duration=0.05), "steps": step_stimulus(duration=0.05)}


@pytest.fixture(scope="module")
def ranges(untyped, stimuli):
    return analyze_ranges(untyped, stimuli, DT, envelope=False)


def test_state_ranges_are_the_simulated_maxima(model, stimuli, ranges):
    """Each state's range is its largest |value| in the float simulator over the same inputs,
    except theta, whose declared capacity (the plant interface's turns) is larger."""
    sim = pendc.Simulator(model, dt=DT)
    for s in ("x", "dx", "theta", "dtheta"):
        peak = 0.0
        for t, u in stimuli.values():
            held = per_step(u, t, DT)
            res = sim(np.arange(len(held)) * DT, held)
            peak = max(peak, float(np.max(np.abs(res[s]))))
        assert peak > 0
        if s == "theta":
            turns = model.interface.state("theta").turns
            assert turns >= 100 and ranges[s] == pytest.approx(2 * np.pi * turns) and peak < ranges[s]
        else:
            assert ranges[s] == pytest.approx(peak, rel=1e-9), s


def test_every_node_has_a_range(untyped, ranges):
    assert set(ranges.max_abs) == {n.name for n in untyped.nodes}
    assert all(np.isfinite(v) and v >= 0 for v in ranges.max_abs.values())
    assert ranges["u"] == 10.0      # the input port's declared full scale, above the swing-up's 7.76 V peak
    for n in untyped.of_kind(Kind.CONST):
        assert ranges[n.name] == abs(n.param("value"))


def test_lut_input_extents(untyped, ranges):
    inputs = {n.inputs[0] for n in untyped.of_kind(Kind.LUT)}
    assert set(ranges.lo) == inputs
    for name in inputs:
        assert ranges.lo[name] <= ranges.hi[name]
        seen = max(abs(ranges.lo[name]), abs(ranges.hi[name]))
        declared = untyped[name].params.max_abs      # the phase in turns holds half a turn by construction
        assert max(seen, declared or 0.0) == pytest.approx(ranges[name], rel=1e-12), name
    assert ranges.lo["abs_dx"] >= 0.0           # |dx| is never negative
    assert ranges.lo["theta_turns"] < 0 < ranges.hi["theta_turns"]   # the pendulum swings both ways


def test_interpreter_engine_agrees_on_the_model(untyped):
    t, u = swing_up(duration=0.003)
    stim = {"swing_up": (t, u)}
    a = analyze_ranges(untyped, stim, DT, engine="interpreter", envelope=False)
    b = analyze_ranges(untyped, stim, DT, engine="compiled", envelope=False)
    for name in a.max_abs:
        assert a[name] == pytest.approx(b[name], rel=1e-12, abs=1e-300), name
    assert a.lo == pytest.approx(b.lo, rel=1e-12) and a.hi == pytest.approx(b.hi, rel=1e-12)


def test_envelope_covers_full_scale_input_track_ends_and_a_spinning_pendulum(untyped, stimuli, ranges):
    """The envelope runs reach what a wild controller reaches: the velocity clamp, the drive's
    full-scale force, and the pendulum at the encoders' rate limit."""
    wide = analyze_ranges(untyped, stimuli, DT)
    assert [s for s in wide.sources if s.startswith("envelope:")] == [
        "envelope:full_scale_switching", "envelope:track_ends", "envelope:spin"]
    assert wide["u"] == 10.0
    assert wide["dx"] == pytest.approx(0.55, rel=1e-6)          # clamped, driven into the ends
    # above the encoders' design limit, 8*pi rad/s (spec section 4), and far above the stimuli
    spin = untyped_model_interface(untyped).state("dtheta").training_rate
    assert wide["dtheta"] >= spin > 8 * np.pi and spin > 10 * ranges["dtheta"]
    for name in ranges.max_abs:
        assert wide[name] >= ranges[name], name


def untyped_model_interface(graph):
    """The plant interface the graph carries from lowering (through folding and CSE)."""
    from pendc.model.interface import require_interface
    return require_interface(graph)


def test_without_an_interface_there_is_no_spin_run(untyped, stimuli):
    """A graph that lost its plant interface has no state to spin: only the two input runs."""
    import dataclasses
    bare = dataclasses.replace(untyped, info=tuple(kv for kv in untyped.info if kv[0] != "interface"))
    assert [name for name, _, _ in envelope_runs(bare)] == ["envelope:full_scale_switching",
                                                            "envelope:track_ends"]
    spun = [g for name, g, _ in envelope_runs(untyped) if name == "envelope:spin"]
    assert len(spun) == 1 and spun[0]["dtheta"].param("reset") == untyped_model_interface(untyped).state(
        "dtheta").training_rate


def test_full_scale_switching_is_zero_or_ten_volts_at_one_to_fifty_ms():
    t, u = full_scale_switching(2.0)
    assert set(np.unique(u)) == {0.0, 10.0}
    changes = np.flatnonzero(np.diff(u)) + 1
    gaps = np.diff(t[changes])
    assert gaps.min() >= 1e-3 - 1e-12 and gaps.max() <= 50e-3 + 1e-12
    assert len(changes) > 2.0 / 50e-3


def test_the_envelope_switches_between_the_inputs_own_range():
    """Full scale is the plant input's range: the QUBE's amplifier -10 V and +10 V, not the SCT
    drive's 0 V and 10 V."""
    from pendc.passes.lower import lower_model
    from plants import plant_named

    graph = lower_model(plant_named("furuta"))
    runs = {name: tu for name, _, tu in envelope_runs(graph)}
    for name in ("envelope:full_scale_switching", "envelope:track_ends"):
        assert set(np.unique(runs[name][1])) == {-10.0, 10.0}, name
    t, u = full_scale_switching(2.0, levels=(-6.0, 6.0))
    assert set(np.unique(u)) == {-6.0, 6.0} and np.array_equal(u > 0, full_scale_switching(2.0)[1] > 0)


# -- a slow plant's working range ----------------------------------------------------------------

SLOW_PLANT = """
[plant]
name = "oven"
k = 0.012
ks = 0.002
C = 2.0
Ta = 296.15
alpha = 0.01

[constants]
k = { unit = "W/K", meaning = "conductance to ambient" }
ks = { unit = "W/K", meaning = "conductance between the nodes" }
C = { unit = "J/K", meaning = "heat capacity" }
Ta = { unit = "K", meaning = "ambient temperature" }
alpha = { unit = "W", meaning = "heater power per unit input" }

[states.T1]
unit = "K"
meaning = "heated node temperature"
derivative = "(k*(Ta - T1) + ks*(T2 - T1) + alpha*Q)/C"
initial = "Ta"

[states.T2]
unit = "K"
meaning = "second node temperature"
derivative = "(k*(Ta - T2) + ks*(T1 - T2))/C"
initial = "Ta"
RANGE

[inputs.Q]
unit = "1"
meaning = "heater input"
range = [0.0, 100.0]
"""


def test_a_slow_states_working_range_starts_training_runs_at_both_ends():
    """A second thermal node (time constant ~170 s) barely moves in seconds of training: its
    increment was sized 1e-9 K per step, which a minute of heating overflows 30 times over.
    Its declared range starts two envelope runs, at each end, so the register holds the range
    and the derivative the cooling rate from its top (k + ks) (553 - 296 K) / C = 1.8 K/s."""
    plain = lower_model(pendc.parse_model(SLOW_PLANT.replace("RANGE", "")), dt=DT)
    ranged = lower_model(pendc.parse_model(SLOW_PLANT.replace("RANGE", "range = [223.15, 553.15]")), dt=DT)
    assert pendc.parse_model(SLOW_PLANT.replace("RANGE", "range = [223.15, 553.15]")).interface.state(
        "T2").working_range == (223.15, 553.15)
    names = [name for name, _, _ in envelope_runs(ranged)]
    assert names[-2:] == ["envelope:range_low", "envelope:range_high"]
    assert not any(name.startswith("envelope:range") for name, _, _ in envelope_runs(plain))
    starts = {name: g["T2"].params.reset for name, g, _ in envelope_runs(ranged)}
    assert starts["envelope:range_low"] == 223.15 and starts["envelope:range_high"] == 553.15
    assert starts["envelope:full_scale_switching"] == pytest.approx(296.15)
    stimulus = {"steps": step_stimulus(duration=0.05)}
    without = analyze_ranges(plain, stimulus, DT)
    with_range = analyze_ranges(ranged, stimulus, DT)
    assert without["T2_inc"] < 1e-8 and without["T2"] < 300
    assert with_range["T2"] == pytest.approx(553.15, rel=1e-6)
    assert with_range["d_T2"] == pytest.approx((0.012 + 0.002) * (553.15 - 296.15) / 2.0, rel=1e-3)
    assert with_range["T2_inc"] == pytest.approx(with_range["d_T2"] * DT, rel=1e-9)


def test_states_with_a_range_start_at_their_ends_together():
    """Two ranged states start at their low ends together, then at their high ends (a motor and
    its load through a gear are not twisted apart by the whole range); unranged ones at initial."""
    both = SLOW_PLANT.replace("RANGE", "range = [223.15, 553.15]").replace(
        'initial = "Ta"\n\n[states.T2]', 'initial = "Ta"\nrange = [250.0, 500.0]\n\n[states.T2]')
    graph = lower_model(pendc.parse_model(both), dt=DT)
    starts = {name: (g["T1"].params.reset, g["T2"].params.reset) for name, g, _ in envelope_runs(graph)}
    assert starts["envelope:range_low"] == (250.0, 223.15) and starts["envelope:range_high"] == (500.0, 553.15)
    assert sum(name.startswith("envelope:range") for name in starts) == 2


def test_a_held_input_parts_slow_coupled_states():
    """Round F's TCLab (two sinks, one heater, ranges and hold_seconds = 60): training from ends the
    sinks share never parted them by more than 3 K, so the heat flow between them overflowed at
    its own operating point (14 K apart) and after 18 s of a full heater. With ``hold``, the input is
    also held at its top for that long from the low ends, and at its bottom from the high ends."""
    from pendc.model.modelfile import load_model
    from pendc.passes.lower import lower_model
    graph = lower_model(load_model(Path(__file__).parent / "data" / "tclab1.toml"))
    assert not [n for n, _, _ in envelope_runs(graph) if "hold" in n]
    runs = {name: (g, tu) for name, g, tu in envelope_runs(graph, hold=60.0)}
    g, (t, u) = runs["envelope:hold_high"]
    assert (g["T1"].param("reset"), g["T2"].param("reset")) == (290.0, 290.0)
    assert t.tolist() == [0.0, 60.0] and u.tolist() == [100.0, 100.0]
    g, (t, u) = runs["envelope:hold_low"]
    assert (g["T1"].param("reset"), g["T2"].param("reset")) == (380.0, 380.0) and u.tolist() == [0.0, 0.0]


RUNAWAY = """
[plant]
name = "runaway"
core = "runaway_core"
summary = "a state that grows on its own once it is high (an exothermic reactor's temperature)"
k = 5.0

[constants]
k = { unit = "1/s", meaning = "growth rate", bounds = [0.1, 10.0] }

[states.x]
unit = "1"
meaning = "normalised temperature"
derivative = "k*(x*x - x/5 + u)"
initial = 0.0
range = [0.0, 1.0]

[inputs.u]
unit = "1"
meaning = "heating"
range = [0.0, 0.1]
neutral = 0.0

[sensors.adc_x]
kind = "adc"
state = "x"
bits = 12
range = [0.0, 1.0]

[hardware]
dt = 1e-4
hold_seconds = 10.0
"""


def test_a_run_from_the_top_of_a_declared_range_counts_until_the_plant_leaves_it():
    """Round J: a CSTR started at the top of its declared 300-420 K ran away to 628 K in the range
    analysis' runs from the ranges' ends, and its Arrhenius table, sized for that, was 6 % wrong at
    350 K. Those runs (and the held ones) now count until a ranged state leaves its range by a
    tenth of it: here x' = 5 (x^2 - x/5 + u) blows up from x = 1 within a second."""
    from pendc.model.modelfile import parse_model
    from pendc.passes.pipeline import check_hardware_names, options_from_model, training_stimuli
    from pendc.passes.ranges import RANGE_SLACK, analyze_ranges

    model = parse_model(RUNAWAY, source="runaway.toml")
    opt = options_from_model(model)
    graph = check_hardware_names(model, opt)
    ranges = analyze_ranges(graph, training_stimuli(model.interface.input, opt.training_scale), opt.dt,
                            hold=opt.hold_seconds)
    assert "envelope:range_high" in ranges.sources and "envelope:hold_high" in ranges.sources
    assert 1.0 < ranges["x"] <= 1.0 + RANGE_SLACK + 0.01        # the step that left it, and no further
