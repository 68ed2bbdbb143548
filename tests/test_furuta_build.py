"""The Furuta pendulum through the compiler: lowered, typed and run bit-accurately by the golden
model with no pendulum-specific code path. The build is `pendc build --model models/furuta_qube.toml`'s
own (1 us steps, the full training and error budget), from the build cache: tests/test_emit.py
needs the same build for the QUBE's Verilog, so the two files share one compile."""

import math
from pathlib import Path

import numpy as np
import pytest

import pendc
from pendc.golden import GoldenModel
from pendc.ir.nodes import Kind
from pendc.model.interface import require_interface
from pendc.caching.build_cache import compile_cached

QUBE = Path(__file__).resolve().parents[1] / "models" / "furuta_qube.toml"
DT = 1e-6                  # the file's own step: the full build's


@pytest.fixture(scope="module")
def qube():
    return pendc.load_model(QUBE)


@pytest.fixture(scope="module")
def build(qube):
    built = compile_cached(qube)
    assert built.options.dt == DT
    return built


def test_the_graph_is_the_furutas(qube, build):
    g = build.graph
    iface = require_interface(g)
    assert iface == qube.interface and g.name == "furuta_core"
    assert [p for p, _ in g.outputs] == ["phi_r", "dphi_r", "alpha_p", "dalpha_p", "enc_phi_r_a", "enc_phi_r_b",
                                         "enc_alpha_p_a", "enc_alpha_p_b"]
    assert [n.name for n in g.of_kind(Kind.INPUT)] == ["u"]
    names = set(g.by_name)
    assert not names & {"x", "dx", "theta", "dtheta", "enc_x_a", "enc_theta_a"}
    # the error budget held both angles to half an encoder count
    assert set(build.error.budgets) == {"phi_r", "alpha_p"}
    for runs in build.error.errors.values():
        assert runs["phi_r"] <= iface.budgets()["phi_r"] and runs["alpha_p"] <= iface.budgets()["alpha_p"]


def test_tables_are_functions_of_the_pendulum_angle_in_turns(build):
    """1/det(alpha_p) and the trigonometric coefficients are periodic tables addressed by the
    pendulum's angle in turns; no divider and no table of the arm's angle (it appears nowhere)."""
    g = build.untyped                     # before Q-formats narrow the address
    luts = g.of_kind(Kind.LUT)
    assert len(luts) >= 8 and all(n.inputs == ("alpha_p_turns",) for n in luts)
    assert all(n.param("periodic") for n in luts)
    assert "phi_r_turn" not in g.by_name and "alpha_p_turn" in g.by_name


def test_a_golden_run_stays_in_range_and_follows_the_float_model(qube, build):
    """Full-scale switching for 100 ms: no node leaves its format (the golden model would stop
    naming it), and the bit-exact states stay within a few counts of the float simulation of the
    same forward-Euler step."""
    t = np.arange(0, 0.1 + 1e-12, 1e-3)
    u = np.where((np.arange(len(t)) // 20) % 2 == 0, 10.0, -10.0)
    fixed = GoldenModel(build.graph, DT)(t, u).result
    assert list(fixed.columns()) == ["t", "u", "phi_r", "alpha_p", "dphi_r", "dalpha_p"]   # the file's columns
    ref = pendc.Simulator(qube, dt=DT)(t, u)
    iface = qube.interface
    for q in ("phi_r", "alpha_p"):
        assert np.max(np.abs(fixed[q] - ref[q])) < iface.budgets()[q], q
    assert np.ptp(fixed["phi_r"]) > 0.1 and np.ptp(fixed["alpha_p"]) > 0.05         # both moved
    assert all(np.all(np.isfinite(fixed[s])) for s in iface.outputs)
    # the encoders, decoded x4, count what the angle registers hold (every step recorded)
    golden = GoldenModel(build.graph, DT)
    trace = golden.run_steps(np.repeat(u[:-1], round(1e-3 / DT)))
    for sensor in iface.sensors:
        a = np.asarray(trace.outputs[f"{sensor.name}_a"], dtype=np.int64)
        b = np.asarray(trace.outputs[f"{sensor.name}_b"], dtype=np.int64)
        counts = _decode_x4(a, b)
        angle = np.asarray(trace.outputs[sensor.state], dtype=float) * build.graph.output(sensor.state).qformat.lsb
        assert np.max(np.abs(counts * sensor.resolution - angle)) <= 1.5 * sensor.resolution, sensor.name
        assert np.ptp(counts) > 10
    assert iface.sensor_of("phi_r").resolution == pytest.approx(2 * math.pi / 2048)


def _decode_x4(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A x4 quadrature decoder of our own: +1 per edge when A leads, -1 when B leads."""
    state = (b << 1) | (a ^ b)            # 0, 1, 2, 3 as (A, B) go 00, 10, 11, 01: moving forward
    step = (np.diff(state) + 2) % 4 - 2   # +1, -1, or 0 (a skipped edge would be +-2)
    assert not np.any(np.abs(step) == 2)
    return np.concatenate([[0], np.cumsum(step)])
