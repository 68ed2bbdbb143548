"""The compiled golden model agrees with the reference interpreters (bit for bit in fixed mode)."""

import math

import numpy as np
import pytest

from pendc import load_model
from pendc.ir import lut as lut_sem
from pendc.ir.compiled import CompiledGraph, quantize
from pendc.ir.kernel_module import kernel_source
from pendc.ir.graph import Graph
from pendc.ir.interpret import FixedInterpreter, FloatInterpreter
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import Overflow, QFormat, Rounding
from pendc.passes.lower import lower_model
from plants import swing_up

Q = QFormat.parse
MODES = {"nt": (Rounding.NEAREST, Overflow.WRAP), "ns": (Rounding.NEAREST, Overflow.SATURATE),
         "tw": (Rounding.TRUNCATE, Overflow.WRAP), "ts": (Rounding.TRUNCATE, Overflow.SATURATE)}


def lut(name, src, fin, fout, expr, lo, hi, bits, interpolate, periodic, rounding):
    shift = lut_sem.grid_shift(lo, hi, bits, fin)
    table = lut_sem.fill_table(expr, lo, bits, shift, fin, fout, interpolate, periodic)
    return make(name, Kind.LUT, [src], qformat=fout, rounding=rounding, expr=expr, lo=lo, hi=hi,
                addr_bits=bits, interpolate=interpolate, periodic=periodic, shift=shift, table=table)


def block(sfx, rounding, overflow):
    """One copy of every node kind, all in one rounding/overflow mode (names end in ``sfx``)."""
    def n(name, kind, inputs=(), fmt="UFIX1_0", **params):
        return make(f"{name}_{sfx}", kind, [f"{i}_{sfx}" if i not in ("u", "w") else i for i in inputs],
                    qformat=Q(fmt), rounding=rounding, overflow=overflow, **params)

    def L(name, src, fin, fout, expr, lo, hi, bits, interp, periodic):
        return lut(f"{name}_{sfx}", f"{src}_{sfx}" if src not in ("u", "w") else src, Q(fin), Q(fout),
                   expr, lo, hi, bits, interp, periodic, rounding)

    three = dict(states=("A", "B", "C"), outputs=(1, 2, 5), reset="B", lo=-20.0, hi=20.0)
    return [
        n("c1", Kind.CONST, fmt="FIX8_4", value=1.75), n("c2", Kind.CONST, fmt="FIX16_10", value=-3.3),
        n("g1", Kind.GAIN, ["u"], "FIX12_6", value=0.7, cfmt="FIX16_14"),           # right shift
        n("g2", Kind.GAIN, ["w"], "FIX20_12", value=-3.0, cfmt="FIX8_5"),           # left shift, overflows
        n("a1", Kind.ADD, ["u", "w"], "FIX10_3"), n("s1", Kind.SUB, ["g1", "c2"], "UFIX8_2"),
        n("n1", Kind.NEG, ["w"], "FIX12_4"), n("m1", Kind.MUL, ["u", "w"], "FIX24_8"),
        n("m2", Kind.MUL, ["a1", "n1"], "FIX8_0"),
        n("k1", Kind.CAST, ["u"], "FIX6_1"), n("k2", Kind.CAST, ["w"], "FIX32_20"),
        n("k3", Kind.CAST, ["u"], "FIX64_50"), n("k4", Kind.ADD, ["k3", "k3"], "FIX64_50"),
        n("k5", Kind.CAST, ["u"], "FIX8_-2"), n("k6", Kind.CAST, ["u"], "UFIX4_6"),
        n("k7", Kind.CAST, ["u"], "FIX16_70"), n("k8", Kind.CAST, ["k7"], "FIX8_0"),  # shifts >= 64
        n("k9", Kind.CAST, ["u"], "FIX16_12"),                                       # angle in turns
        *[n(f"cmp_{op}", Kind.COMPARE, ["w", "c1"], op=op) for op in ("lt", "le", "gt", "ge", "eq", "ne")],
        n("sign", Kind.SLICE, ["a1"], "UFIX1_0", hi=-1, lo=-1),
        n("field", Kind.SLICE, ["u"], "UFIX4_0", hi=5, lo=2),
        n("sel2", Kind.SLICE, ["w"], "UFIX2_0", hi=1, lo=0),
        n("mux4", Kind.MUX, ["sel2", "a1", "g1", "s1", "n1"], "FIX9_5"),
        n("abs", Kind.MUX, ["sign", "a1", "n1"], "FIX12_3"),
        n("r1", Kind.REGISTER, ["acc"], "FIX14_6", reset=0.5),
        n("r2", Kind.REGISTER, ["r1"], "FIX14_6", reset=-1.0),
        n("acc", Kind.ADD, ["r1", "g1"], "FIX14_6"),
        L("lut_ci", "u", "FIX16_8", "FIX16_14", "sin(v)", -2.0, 3.0, 4, True, False),   # covers [-2, 6]
        L("lut_cn", "u", "FIX16_8", "UFIX12_6", "v**2", 0.0, 4.0, 5, False, False),
        L("lut_pi", "k9", "FIX16_12", "FIX16_14", "cos(2*pi*v)", 0.0, 1.0, 6, True, True),
        L("lut_pn", "k9", "FIX16_12", "FIX12_10", "sin(2*pi*v)", 0.0, 1.0, 5, False, True),
        n("fsm", Kind.FSM, ["a1"], "UFIX3_0", transitions=(("A", "gt", 2.0, "B"), ("B", "lt", -1.0, "C"),
                                                             ("*", "ge", 10.0, "A"), ("C", "le", 0.5, "A")),
          **three),
        n("fsm2", Kind.FSM, ["g1"], "UFIX3_0", transitions=(("*", "ge", 1.0, "C"), ("*", "lt", -1.0, "A")),
          **three),
        n("fbit", Kind.SLICE, ["fsm"], "UFIX2_0", hi=2, lo=1),
        n("fmux", Kind.MUX, ["fbit", "c1", "c2", "k1"], "FIX16_8"),
        n("fsum", Kind.ADD, ["fsm", "fsm2"], "UFIX4_0"),
    ]


def hand_graph(name="hand"):
    nodes = [make("u", Kind.INPUT, qformat=Q("FIX16_8"), port="u"),
             make("w", Kind.INPUT, qformat=Q("FIX12_4"), port="w")]
    for sfx, (rounding, overflow) in MODES.items():
        nodes += block(sfx, rounding, overflow)
    outputs = [(x.name, x.name) for x in nodes]
    return Graph.build(name, nodes, outputs)


def random_inputs(steps=3000, seed=7):
    rng = np.random.default_rng(seed)
    u = rng.uniform(-160.0, 160.0, steps)                       # FIX16_8 holds [-128, 128)
    small = rng.random(steps) < 0.3
    u[small] = rng.uniform(-3.0, 8.0, int(small.sum()))        # around the clamped LUTs' domains
    edges = rng.random(steps) < 0.05                           # exactly on and next to the domain ends
    u[edges] = rng.choice([-2.0, 6.0, 0.0, 4.0, 4.0 - 2**-8, 6.0 + 2**-8, -2.0 - 2**-8], int(edges.sum()))
    w = rng.integers(-40, 40, steps) / 4.0                      # often exactly 1.75 (eq compares)
    big = rng.random(steps) < 0.1
    w[big] = rng.uniform(-200.0, 200.0, int(big.sum()))         # FIX12_4 holds [-128, 128)
    return {"u": u, "w": w}


@pytest.fixture(scope="module")
def hand():
    g = hand_graph()
    return g, CompiledGraph(g, "fixed")


def assert_same(trace, ref, exact=True):
    # numpy's and pytest's assertion helpers cost ~0.3 ms a call, which dominated the exhaustive
    # test (hundreds of thousands of calls): a plain comparison first, the helper (and its message)
    # only where that one already fails
    assert trace.steps == ref.steps
    assert set(trace.outputs) == set(ref.outputs)
    for port, values in ref.outputs.items():
        got = trace.outputs[port]
        if exact:
            assert got.dtype == np.int64
            if got.shape != values.shape or not np.array_equal(got, values):
                np.testing.assert_array_equal(got, values, err_msg=port)
        else:
            assert got.dtype == np.float64
            np.testing.assert_allclose(got, values.astype(float), rtol=1e-12, atol=0, err_msg=port)
    assert trace.overflows == ref.overflows
    assert trace.max_abs.keys() == ref.max_abs.keys()
    for k, v in ref.max_abs.items():
        if not (exact and trace.max_abs[k] == v):
            assert trace.max_abs[k] == pytest.approx(v, rel=0 if exact else 1e-12), k


def test_fixed_bit_identical_on_every_node_kind(hand):
    g, cg = hand
    inputs = random_inputs()
    ref = FixedInterpreter(g).run(inputs, track_max=True)
    trace = cg.run(inputs, track_max=True)
    assert_same(trace, ref)
    kinds = {n.kind for n in g.nodes}
    assert kinds == set(Kind)
    # the test inputs really exercise overflow in every mode, LUT domains and FSM ranges
    for sfx in MODES:
        for name in ("g1", "g2", "s1", "n1", "k1", "k7", "lut_ci", "lut_cn", "fsm", "mux4"):
            assert f"{name}_{sfx}" in trace.overflows, f"{name}_{sfx}"


def test_fixed_every_steps_and_integer_inputs(hand):
    g, cg = hand
    inputs = random_inputs(1000, seed=3)
    ints = {"u": np.round(inputs["u"] * 256).astype(np.int64), "w": np.round(inputs["w"] * 16).astype(np.int32)}
    ints["w"][::7] = 5000                                       # out of FIX12_4: raw integers pass as they are
    for ins, every, steps in ((inputs, 7, None), (ints, 3, 500), (ints, 1, None)):
        ref = FixedInterpreter(g).run(ins, steps=steps, every=every, track_max=True)
        trace = cg.run(ins, steps=steps, every=every, track_max=True)
        assert_same(trace, ref)
        assert len(trace.outputs["u"]) == -(-trace.steps // every)
    empty = cg.run(inputs, steps=0)
    assert empty.steps == 0 and len(empty.outputs["u"]) == 0 and empty.overflows == {}


def test_float_mode_on_hand_graph(hand):
    g, _ = hand
    inputs = random_inputs(2000, seed=11)
    ref = FloatInterpreter(g).run(inputs, track_max=True, every=2)
    trace = CompiledGraph(g, "float").run(inputs, track_max=True, every=2)
    assert_same(trace, ref, exact=False)
    assert any(k.startswith("lut_ci") for k in trace.overflows) and any(k.startswith("fsm") for k in trace.overflows)


def test_float_mode_matches_interpreter_on_pendulum():
    g = lower_model(load_model())
    _, u = swing_up()
    inputs = {"u": np.repeat(u, 1000)[:20_000]}
    record = ("abs_dx", "theta_turns", "ddx", "enc_x_a_fsm")
    trace = CompiledGraph(g, "float").run(inputs, track_max=True, record=record)
    extra = Graph(name=g.name, nodes=g.nodes, outputs=g.outputs + tuple((r, r) for r in record))
    ref = FloatInterpreter(extra).run(inputs, track_max=True)
    assert_same(trace, ref, exact=False)
    assert trace.outputs["theta"][-1] != 0.0
    # the tracked signed extremes are those of every step's value (what range analysis reads
    # instead of recording tens of millions of steps)
    every = CompiledGraph(g, "float").run(inputs, record=tuple(n.name for n in g.nodes))
    for name, (low, high) in trace.extremes.items():
        assert (low, high) == (float(np.min(every.outputs[name])), float(np.max(every.outputs[name]))), name
        assert trace.max_abs[name] == max(abs(low), abs(high)), name
    assert any(low < 0 < high for low, high in trace.extremes.values())


def test_float_extremes_keep_a_nan_and_start_from_no_value():
    """A NaN anywhere in a node's run is its maximum and its minimum (as numpy's min and max say),
    and a run of no steps reports 0 as before, not the starting infinities."""
    g = Graph.build("nan", [make("u", Kind.INPUT, port="u"), make("y", Kind.GAIN, ["u"], value=2.0)], [("y", "y")])
    trace = CompiledGraph(g, "float").run({"u": np.array([1.0, np.nan, -3.0])}, track_max=True)
    assert all(math.isnan(v) for v in trace.extremes["y"]) and math.isnan(trace.max_abs["y"])
    empty = CompiledGraph(g, "float").run({"u": np.zeros(0)}, track_max=True)
    assert empty.max_abs == {"u": 0.0, "y": 0.0} and empty.extremes == {}


def requant_nodes(modes=MODES) -> list:
    """Casts to formats around a small one, gains, sums, tables and an FSM fed by one input ``a``
    (FIX8_2), in every mode of ``modes``."""
    targets = ["FIX8_4", "FIX6_3", "UFIX5_4", "FIX5_0", "UFIX4_1", "FIX3_-1", "FIX8_2", "FIX4_2", "FIX7_1",
               "UFIX8_2", "FIX10_2", "FIX16_70", "FIX12_-60", "FIX8_-70", "FIX64_10", "FIX64_-10"]
    nodes = [make("a", Kind.INPUT, qformat=Q("FIX8_2"), port="a"), make("c", Kind.CONST, qformat=Q("FIX8_2"),
                                                                        value=3.25)]
    for sfx, (rnd, ovf) in modes.items():
        def n(name, kind, inputs, fmt, **params):
            nodes.append(make(f"{name}_{sfx}", kind, inputs, qformat=Q(fmt), rounding=rnd, overflow=ovf, **params))
        n("b", Kind.CAST, ["a"], "FIX8_2")                      # in its format: static bounds apply
        for src in ("a", f"b_{sfx}"):
            for j, fmt in enumerate(targets):
                n(f"cast{j}_{src}", Kind.CAST, [src], fmt)
            n(f"neg_{src}", Kind.NEG, [src], "FIX8_2")
            n(f"gain_{src}", Kind.GAIN, [src], "FIX6_1", value=-0.75, cfmt="FIX4_2")
            n(f"add_{src}", Kind.ADD, [src, "c"], "FIX8_2")
            n(f"sub_{src}", Kind.SUB, ["c", src], "UFIX8_2")
            n(f"mul_{src}", Kind.MUL, [src, src], "FIX10_-2")
            for interp in (True, False):                        # domain ends exactly on the grid
                nodes.append(lut(f"lc{interp:d}_{src}_{sfx}", src, Q("FIX8_2"), Q("FIX8_4"), "v/2", -3.0, 5.0, 3,
                                 interp, False, rnd))
                nodes.append(lut(f"lp{interp:d}_{src}_{sfx}", src, Q("FIX8_2"), Q("FIX8_6"), "sin(pi*v/2)", 0.0,
                                 4.0, 2, interp, True, rnd))
        n("fsm", Kind.FSM, [f"b_{sfx}"], "UFIX2_0", states=("A", "B", "C", "D"), outputs=(0, 1, 2, 3), reset="A",
          transitions=(("A", "le", -1.25, "B"), ("A", "gt", 2.5, "C"), ("*", "ge", 2.0, "D"),
                       ("B", "lt", 0.0, "A")), lo=-5.0, hi=6.25)
    return nodes


def test_requantize_exhaustively_per_value():
    """Every integer of (and around) a small format through casts, gains and sums in every mode;
    one run per value, so every overflow flag is compared, not just the first."""
    nodes = requant_nodes()
    g = Graph.build("requant", nodes, [(x.name, x.name) for x in nodes])
    cg, interp = CompiledGraph(g, "fixed"), FixedInterpreter(g)
    for v in range(-300, 300):
        ins = {"a": np.array([v, v, v], dtype=np.int64)}
        assert_same(cg.run(ins, track_max=True), interp.run(ins, track_max=True))


def test_record_and_argument_errors(hand):
    g, cg = hand
    inputs = random_inputs(50)
    trace = cg.run(inputs, record=("u",))                        # a port naming its own node
    assert set(trace.outputs) == {p for p, _ in g.outputs}
    with pytest.raises(ValueError, match="unknown node"):
        cg.run(inputs, record=("nope",))
    with pytest.raises(ValueError, match="every"):
        cg.run(inputs, every=0)
    with pytest.raises(ValueError, match="no values"):
        cg.run({"u": inputs["u"]})
    with pytest.raises(ValueError, match="not typed"):
        CompiledGraph(lower_model(load_model()), "fixed")
    with pytest.raises(ValueError, match="mode"):
        CompiledGraph(g, "double")


@pytest.mark.parametrize("fmt", ["FIX16_8", "UFIX8_3", "FIX64_0", "FIX64_20", "UFIX63_0", "FIX8_-2",
                                 "FIX16_70", "FIX32_31", "UFIX1_0"])
def test_vectorised_quantisation_is_the_scalar_rule(fmt):
    fmt = Q(fmt)
    rng = np.random.default_rng(5)
    lsb = math.ldexp(1.0, -fmt.frac)
    k = rng.integers(-2000, 2000, 500).astype(float)
    special = [0.0, -0.0, 0.49999999999999994, -0.49999999999999994, 0.5, -0.5, 1.5, -1.5, 2.5, -2.5,
               5e-324, -5e-324, 1e300, -1e300, fmt.max_value, fmt.min_value, fmt.max_value + lsb / 2,
               fmt.min_value - lsb / 2, math.ldexp(1.0, 62), -math.ldexp(1.0, 63), math.ldexp(1.0, 63)]
    values = np.concatenate([(k + 0.5) * lsb, k * lsb, rng.normal(0, fmt.max_value, 500),
                             rng.normal(0, 1, 500), np.array(special) * 1.0, np.array(special) * lsb])
    with np.errstate(over="ignore"):
        values = values[np.isfinite(np.ldexp(values, fmt.frac))]
    np.testing.assert_array_equal(quantize(values, fmt), [fmt.from_float(float(v)) for v in values])
    with pytest.raises(ValueError):
        quantize(np.array([1.0, math.nan]), fmt)


def test_source_is_deterministic_and_independent_of_table_contents(hand):
    g, cg = hand
    again = hand_graph()
    assert kernel_source(again, "fixed") == kernel_source(g, "fixed")
    assert cg.source == CompiledGraph(again, "fixed").source
    assert "def kernel(ins, steps, every, tab, rst, sel, out, track, mx, mn, ov, st, k0):" in cg.source
    pend = lower_model(load_model())
    assert kernel_source(pend, "float") == kernel_source(lower_model(load_model()), "float")
    refilled = g.map_nodes(lambda n: n.with_params(table=tuple(0 for _ in n.param("table")))
                           if n.kind is Kind.LUT else n)
    assert kernel_source(refilled, "fixed", runtime_data=True) == kernel_source(g, "fixed", runtime_data=True)
    assert CompiledGraph(refilled, "fixed").source == cg.source


def test_kernel_reused_across_register_resets_matches_each_interpreter(hand):
    """Register resets are kernel data: a graph differing only in resets (the spinning training
    run) compiles to the same source and machine code, and each run is its own interpreter's."""
    g, cg = hand
    reset = {"r1_nt": 3.25, "r2_ts": -7.5, "r1_ns": 31.0}          # r1_ns: saturates at once
    other = g.map_nodes(lambda n: n.with_params(reset=reset[n.name]) if n.name in reset else n)
    again = CompiledGraph(other, "fixed")
    assert again.source == cg.source and again._kernel is cg._kernel
    inputs = random_inputs(400, seed=5)
    for graph, compiled in ((g, cg), (other, again)):
        assert_same(compiled.run(inputs, track_max=True), FixedInterpreter(graph).run(inputs, track_max=True))
    assert again.run(inputs).outputs["r2_ts"][0] == -480 != cg.run(inputs).outputs["r2_ts"][0]
    flt, flt2 = CompiledGraph(g, "float"), CompiledGraph(other, "float")
    assert flt2._kernel is flt._kernel
    assert_same(flt2.run(inputs, track_max=True), FloatInterpreter(other).run(inputs, track_max=True), exact=False)


def _step_loop(source: str):
    import ast
    return next(n for n in ast.walk(ast.parse(source)) if isinstance(n, ast.For) and n.target.id == "k")


def _guarded_stores(loop) -> list:
    """The step's ``if keep:`` blocks (values stored where computed, C kernels only)."""
    import ast
    return [n for n in ast.walk(loop) if isinstance(n, ast.If) and ast.unparse(n.test) == "keep"]


@pytest.mark.parametrize("kernels", ["numba", "native"])
def test_step_is_single_assignment_and_nearly_branch_free(kernels, monkeypatch):
    """What keeps numba's compile cheap (its SSA pass costs blocks x redefined variables): in the
    step loop every node's locals are assigned once, and the only branches are the per-step
    record/overflow blocks, not one per range check; the checks that fired are stored into an
    array in the overflow block and read by one loop, not tested by an ``if`` each. The C kernels
    add one branch per node: its value stored into ``buf`` where it is computed, when the step is
    recorded or tracked (GCC's compile does not grow with blocks, and the values need not live to
    the step's end)."""
    import ast
    monkeypatch.setenv("PENDC_KERNELS", kernels)
    g = hand_graph()
    loop = _step_loop(CompiledGraph(g, "fixed").source)
    assigned = [t.id for st in ast.walk(loop) if isinstance(st, ast.Assign) for t in st.targets
                if isinstance(t, ast.Name)]
    node_locals = [x for x in assigned if x[0] in "vtrbdfjy" and x[1:2].isdigit() or x[:2] in ("jj", "ff")]
    repeated = sorted({x for x in node_locals if node_locals.count(x) > 1})
    assert node_locals and not repeated, repeated
    guards = _guarded_stores(loop)
    ifs = [n for n in ast.walk(loop) if isinstance(n, (ast.If, ast.IfExp)) and n not in guards]
    stored = [st for st in ast.walk(loop) if isinstance(st, ast.Assign) and isinstance(st.targets[0], ast.Subscript)
              and ast.unparse(st.targets[0]).startswith("fl[")]
    assert len(stored) > 20                                         # one store per checked node
    assert len(ifs) <= 8 and not any(isinstance(n, ast.IfExp) for n in ifs)
    # the guards hold nothing but stores of values into buf; every node is stored once a step
    assert all(ast.unparse(st).startswith("buf[") for n in guards for st in n.body)
    stores = [ast.unparse(st) for st in ast.walk(loop) if isinstance(st, ast.Assign)
              and ast.unparse(st.targets[0]).startswith("buf[")]
    varying = [i for i, n in enumerate(g.nodes) if n.kind is not Kind.CONST]
    assert sorted(stores) == sorted(f"buf[{i}] = v{i}" for i in varying)
    assert (len(guards) > 0) == (kernels == "native")


def test_cache_dir_from_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("PENDC_CACHE_DIR", str(tmp_path))
    g = Graph.build(f"tiny_{tmp_path.name}", [make("a", Kind.INPUT, qformat=Q("FIX8_4"), port="a"),
                                              make("b", Kind.GAIN, ["a"], qformat=Q("FIX8_2"), value=2.0,
                                                   cfmt="FIX8_4")], [("b", "b")])
    inputs = {"a": np.array([1.0, -1.0, 9.0, -40.0])}
    trace = CompiledGraph(g, "fixed").run(inputs)
    np.testing.assert_array_equal(trace.outputs["b"], [8, -8, 64, -64])
    assert trace.overflows == FixedInterpreter(g).run(inputs).overflows == {}
    from pendc.native import backend
    cached = "native/pendc_native_*.so" if backend() == "native" else "kernels/pendc_ir_*.py"
    assert list(tmp_path.glob(cached))


def test_float_kernel_resumes_where_it_stopped(hand):
    """The float kernel is resumable like the fixed one (pendc.ir.resumable): a run in two calls,
    the second from the state the first left (registers and FSM states in float64), records every
    node exactly as one call does; and a state edited in between is where the second call starts."""
    from pendc.ir.resumable import reset_state, state_indices
    g, _ = hand
    flt = CompiledGraph(g, "float")
    inputs = random_inputs(600, seed=3)
    whole = flt.run(inputs)
    ins = np.ascontiguousarray(np.stack([np.asarray(inputs[n.params.port], float)
                                         for n in g.nodes if n.kind is Kind.INPUT]))
    sel = np.array([flt.index[node] for _, node in g.outputs], np.int64)
    st = reset_state(g, "float")
    assert st.dtype == np.float64 and np.array_equal(st, flt.start)
    parts = []
    for k, n in ((0, 250), (250, 350)):
        out = np.empty((len(sel), n), np.float64)
        flt.call(np.ascontiguousarray(ins[:, k:k + n]), n, 1, sel, out, np.full(len(g.nodes), -1, np.int64), st, k)
        parts.append(out)
    joined = np.concatenate(parts, axis=1)
    for j, (port, _) in enumerate(g.outputs):
        np.testing.assert_array_equal(joined[j], whole.outputs[port], err_msg=port)
    reg = next(p for p, i in enumerate(state_indices(g)) if g.nodes[i].kind is Kind.REGISTER)
    st[reg] = 1.5
    out = np.empty((len(sel), 1), np.float64)
    flt.call(np.ascontiguousarray(ins[:, :1]), 1, 1, sel, out, np.full(len(g.nodes), -1, np.int64), st, 600)
    name = g.nodes[state_indices(g)[reg]].name            # the hand graph outputs every node
    assert out[[node for _, node in g.outputs].index(name), 0] == 1.5


def test_record_rows_are_not_a_multiple_of_4_kib_apart():
    """A kernel's record array: at least ``rows`` wide, its columns an odd number of 64-byte lines
    apart (a multiple of 4 KiB put every column of a step in one L1 set), for the powers of two the
    segmented comparison records and for any other length."""
    from pendc.ir.compiled import record_buffer
    for rows in (1, 7, 8, 256, 1000, 4096, 16384, 16385, 2_000_000):
        out = record_buffer(13, rows, np.int64)
        assert out.shape[0] == 13 and out.shape[1] >= rows and out.flags.c_contiguous
        assert (out.strides[0] // 64) % 2 == 1 and out.strides[0] % 64 == 0, rows

