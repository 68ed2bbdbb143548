"""The compiler pipeline (pendc.passes.pipeline): compile_model and its options."""

import dataclasses
import os
import re
import subprocess
import sys

import pytest

import pendc
from pendc.errors import PendcError
from pendc.ir.nodes import Kind
from pendc.ir.qformat import QFormat
from pendc.ir.verify import verify
from pendc.model.modelfile import default_model_path, parse_model
from pendc.passes.pipeline import (BuildOptions, check_hardware_names, compile_model, options_from_model,
                                   training_stimuli)
from pendc.passes.resources import estimate_resources
from plants import DEFAULT

OPTIONS = BuildOptions(training_scale=0.02)


@pytest.fixture(scope="module")
def model():
    return pendc.load_model()


@pytest.fixture(scope="module")
def build(model):
    return compile_model(model, OPTIONS)


def with_hardware(text: str):
    """The default model file plus a [hardware] section."""
    return parse_model(default_model_path().read_text() + "\n" + text, source="hw.toml")


# -- compile_model ---------------------------------------------------------------------------

def test_result_is_typed_and_verified(build, model):
    assert build.model is model and build.options is OPTIONS
    verify(build.graph, typed=True)
    verify(build.untyped)
    assert all(n.qformat is not None for n in build.graph.nodes)
    assert all(n.qformat is None for n in build.untyped.nodes)
    assert [p for p, _ in build.graph.outputs] == [p for p, _ in build.untyped.outputs]
    for n in build.graph.of_kind(Kind.LUT):
        assert n.param("table") is not None and n.param("shift") is not None
    assert build.resources == estimate_resources(build.graph)
    assert build.error is not None and build.error.met


def test_untyped_graph_is_folded_and_deduplicated(build):
    g = build.untyped
    for n in g.nodes:          # no computation on constants alone is left
        if n.kind not in (Kind.CONST, Kind.INPUT, Kind.REGISTER, Kind.FSM, Kind.MUX) and n.inputs:
            assert any(g[i].kind is not Kind.CONST for i in n.inputs), n.name
    values = [n.param("value") for n in g.of_kind(Kind.CONST)]
    assert len(values) == len(set(values))          # one node per distinct constant
    # typing only adds multiplier-operand casts, and the error feedback of the narrowed input
    extra = {n.name for n in build.graph.nodes} - {n.name for n in g.nodes}
    feedback = {"u_m18_fed", "u_m18_res", "u_m18_res_next"}
    assert feedback <= extra and all(build.graph[n].kind is Kind.CAST for n in extra - feedback)


def test_ranges_cover_the_training_stimuli(build):
    r = build.ranges
    names = tuple(training_stimuli(DEFAULT.interface.input, OPTIONS.training_scale))
    assert set(names) == {"chirp_low", "chirp_high", "steps", "swing_up", "random"}
    assert r.sources[:len(names)] == names
    # then the full-scale envelope a plant must survive (switching, track ends, spinning)
    assert r.sources[len(names):] and all(s.startswith("envelope:") for s in r.sources[len(names):])
    for s in ("x", "dx", "theta", "dtheta"):
        assert r[s] > 0
        assert build.graph[s].qformat.max_value >= r[s]


def test_training_stimuli_are_shortened():
    full = training_stimuli(DEFAULT.interface.input, 1.0)
    short = training_stimuli(DEFAULT.interface.input, 0.02)
    for name, (t, u) in short.items():
        assert len(t) == len(u) == max(2, round(len(full[name][0]) * 0.02))
        assert (t == full[name][0][:len(t)]).all()


def test_compile_is_deterministic(build, model):
    again = compile_model(pendc.load_model(), OPTIONS)
    assert again.graph.text() == build.graph.text()
    assert again.graph == build.graph
    assert again.untyped.text() == build.untyped.text()
    assert again.ranges.max_abs == build.ranges.max_abs
    assert again.error.errors == build.error.errors


def test_compile_is_deterministic_across_hash_seeds(build):
    code = ("import sys, pendc\nfrom pendc.passes.pipeline import BuildOptions, compile_model\n"
            f"sys.stdout.write(compile_model(pendc.load_model(), BuildOptions(training_scale={OPTIONS.training_scale!r}))"
            ".graph.text())\n")
    env = dict(os.environ, PYTHONHASHSEED="977")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300,
                         check=True)
    assert out.stdout == build.graph.text()


def test_without_error_budget(model, build):
    opts = dataclasses.replace(OPTIONS, error_budget=False)
    res = compile_model(model, opts)
    assert res.error is None
    verify(res.graph, typed=True)
    if not build.error.widened and not build.error.actions:
        assert res.graph.text() == build.graph.text()      # the budget changed nothing here


def test_qformat_override_reaches_the_graph(model):
    opts = dataclasses.replace(OPTIONS, error_budget=False, qformats={"ddx": "FIX32_20"})
    res = compile_model(model, opts)
    assert res.graph["ddx"].qformat == QFormat.parse("FIX32_20")


@pytest.mark.parametrize("field, what", [("ranges", "range"), ("qformats", "Q-format")])
def test_override_of_unknown_node_is_refused(model, field, what):
    opts = dataclasses.replace(OPTIONS, **{field: {"no_such_node": 1.0 if field == "ranges" else "FIX32_16"}})
    with pytest.raises(PendcError, match=f"{what} override names unknown node.*no_such_node"):
        compile_model(model, opts)


@pytest.mark.parametrize("override", [{"qformats": {"ddx": "Q15"}}, {"ranges": {"ddx": "big"}},
                                      {"margin_bits": "two"}])
def test_malformed_override_value_is_a_pendc_error(model, override):
    opts = dataclasses.replace(OPTIONS, error_budget=False, **override)
    with pytest.raises(PendcError):
        compile_model(model, opts)


# -- options from the model file ------------------------------------------------------------------

def test_default_model_has_default_options(model):
    assert options_from_model(model) == BuildOptions()


def test_hardware_table_sets_options():
    m = with_hardware("[hardware]\nmargin_bits = 2\ntraining_scale = 0.5\n\n[hardware.qformats]\nddx = \"FIX32_24\"\n")
    opts = options_from_model(m)
    assert opts.margin_bits == 2 and opts.training_scale == 0.5
    assert opts.qformats == {"ddx": "FIX32_24"}
    assert opts.width == BuildOptions().width


def test_keyword_overrides_win_and_none_is_ignored():
    m = with_hardware("[hardware]\nmargin_bits = 2\n")
    opts = options_from_model(m, margin_bits=3, training_scale=None, check_seconds=0.5)
    assert opts.margin_bits == 3 and opts.check_seconds == 0.5
    assert opts.training_scale == BuildOptions().training_scale


@pytest.mark.parametrize("bits", [0, 21, 100])
def test_table_size_outside_the_ir_limit_is_one_line(bits):
    # 2**100 segments would be tabulated before any verifier ran
    m = with_hardware(f"[hardware]\nlut_addr_bits = {bits}\n")
    with pytest.raises(PendcError, match=rf"^hw\.toml: \[hardware\] lut_addr_bits must be 1\.\.20 .*got {bits}$"):
        options_from_model(m)


def test_unknown_hardware_key_is_rejected():
    m = with_hardware("[hardware]\nmargin_bits = 2\nclock_mhz = 100\nbogus = 1\n")
    with pytest.raises(PendcError, match=r"^hw\.toml: \[hardware\] has unknown option\(s\) bogus, clock_mhz"):
        options_from_model(m)
    with pytest.raises(PendcError, match=r"^hw\.toml: \[hardware\] margin_bits must be an int, got 'two'"):
        options_from_model(with_hardware('[hardware]\nmargin_bits = "two"\n'))


@pytest.mark.parametrize("table, says", [("[hardware.ranges]\nno_such_node = 2.0\n", "range override names unknown"),
                                         ("[hardware.budget]\nZ = 0.1\n", "error budget for unknown state(s) Z")])
def test_a_name_the_hardware_table_gets_wrong_names_the_file(table, says):
    """Round J: the file's [hardware] names that no node or state has were the only errors of a
    plant file that did not name the file."""
    with pytest.raises(PendcError, match=rf"^hw\.toml: \[hardware\] {re.escape(says)}"):
        compile_model(with_hardware(table))
    # plant check says it before any build (round J, N6): it passed such a file
    with pytest.raises(PendcError, match=rf"^hw\.toml: \[hardware\] {re.escape(says)}"):
        check_hardware_names(with_hardware(table))
    check_hardware_names(with_hardware("[hardware.ranges]\nx = 0.5\n[hardware.budget]\nx = 1e-4\n"))


def test_unknown_keyword_override_is_rejected(model):
    with pytest.raises(PendcError, match="bad \\[hardware\\] option"):
        options_from_model(model, not_an_option=1)
