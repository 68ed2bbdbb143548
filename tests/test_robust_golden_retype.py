"""pendc.robust.golden_retype: a sampled model's core from the nominal build, without a build.

The rig model's build comes from the build cache (the HIL tests build it too)."""

import numpy as np
import pytest

from pendc.errors import PendcError
from pendc.ir.nodes import Kind
from pendc.ir.qformat import QFormat
from pendc.model.modelfile import load_model
from pendc.robust.golden_retype import RetypeTemplate, fitting_format, lowered, match_structure

SAMPLE = {"alpha": 281.0, "b_end": 1200.0, "m": 0.6, "mu_c": 0.14, "b_theta": 0.0011}


@pytest.fixture(scope="module")
def template():
    return RetypeTemplate.of(load_model("models/sct_rig.toml"))


def test_the_nominal_values_give_the_nominal_core_exactly(template):
    assert template.graph_for(template.build.model) == template.build.graph


def test_a_sample_changes_only_constants_gains_and_tables(template):
    graph = template.graph_for(template.build.model.with_params(SAMPLE))
    nominal = template.build.graph
    changed = {a.name for a, b in zip(nominal.nodes, graph.nodes) if a != b}
    assert {nominal[n].kind for n in changed} <= {Kind.CONST, Kind.GAIN, Kind.LUT}
    assert graph["F_in_u_gain"].params.value == 281.0 and graph["F_in_u_gain"].qformat == nominal["F_in_u_gain"].qformat
    # b_end = 1200 does not fit the nominal gain's FIX18_7 (1000 did): the same width, one integer bit more
    assert nominal["F_cart_pw_then_dx_gain"].params.cfmt == QFormat(True, 18, 7)
    assert graph["F_cart_pw_then_dx_gain"].params.cfmt == QFormat(True, 18, 6)
    # a table keeps its grid and format, its contents are the sample's function
    lut = "ddtheta_tau_pend_lut"
    assert graph[lut].params.shift == nominal[lut].params.shift and graph[lut].qformat == nominal[lut].qformat
    assert graph[lut].params.table != nominal[lut].params.table


def test_fitting_format():
    fmt = QFormat(True, 18, 7)                  # up to 1023.99
    assert fitting_format(1000.0, fmt) is fmt
    assert fitting_format(1200.0, fmt) == QFormat(True, 18, 6)
    assert fitting_format(-3000.0, fmt) == QFormat(True, 18, 5)


def test_the_shared_kernel_gives_the_baked_kernels_integers(template):
    shared, baked = template.plant(SAMPLE), template.plant(SAMPLE, shared=False)
    for u in (9.0, 1.0, 6.5):
        a, b = shared.step(u, 20_000), baked.step(u, 20_000)
        assert a == b
    assert np.array_equal(shared.stepper.state, baked.stepper.state)
    assert shared.stepper.k == baked.stepper.k == 60_000


def test_a_sample_that_changes_the_structure_is_refused(template):
    model = template.build.model
    nominal = template.build.untyped
    other = lowered(model.with_params({"v_stick": 0.01}), template.build.options)   # 0: an exact test, folded
    with pytest.raises(PendcError, match="change the core's structure|add node|change the"):
        match_structure(nominal, other)
    with pytest.raises(PendcError, match="use --plant float"):
        template.graph_for(model.with_params({"v_stick": 0.01}))
