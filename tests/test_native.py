"""pendc.native: kernels compiled by the C compiler give numba's bits.

Each check runs one source twice, through numba (``pendc.codegen.load_source``) and through the
C translation (``NativeFunction``), on the same arguments, and compares every array the kernel
writes and its result exactly. Warnings are errors here: a fall-back to numba would make the
comparison vacuous.
"""

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from pendc.codegen import load_source
from pendc.errors import PendcError
from pendc.ir.compiled import CompiledGraph
from pendc.native import NativeFunction, Untranslatable, backend, translate
from pendc.native.build import toolchain
from pendc.native.types import FLOAT
from pendc.ir.graph import Graph
from pendc.ir.nodes import Kind, make
from pendc.ir.qformat import QFormat
from test_compiled import MODES, block, random_inputs

pytestmark = pytest.mark.skipif(toolchain() is None, reason="no C compiler or Python headers here")

# every construct the kernel printers use, and the corners where C and numba could part
SOURCE = '''
import math

import numpy as np
from numba import njit


@njit(cache=True)
def helper(k, a, out):
    out[k, 0] = a[k] * 3
    return a[k] >> 2


@njit(cache=True, nogil=True, error_model="numpy")
def kernel(a, b, x, y, out, fl, n, scale, flag):
    acc = 0
    total = 0.0
    buf = np.zeros(8, np.int64)
    for k in range(n):
        p = a[k]
        q = b[k]
        out[k, 1] = p * q                         # wraps
        out[k, 2] = (p << 13) >> 7                # unsigned left shift, arithmetic right shift
        out[k, 3] = p // q if q != 0 else 0
        out[k, 4] = p % q if q != 0 else 0
        out[k, 5] = abs(p) + min(p, q) - max(p, q)
        out[k, 6] = int((p > q) | (p == 0)) + int(not (q < 0)) * 2
        out[k, 7] = p * (q > 0) + q * (p <= 0) - (p & 255) + (q ^ 7) + (~p | 1)
        out[k, 8] = (p % 9) ** 3 + 2 ** 5 + (q % 4) ** 0
        out[k, 9] = helper(k, a, out) + (1 if flag else -1) + (-p)
        buf[k % 8] = p
        out[k, 10] = buf[-1] + buf[(k + 3) % 8]
        u = x[k]
        v = y[k]
        fl[k, 0] = u * v - u / v
        fl[k, 1] = u // v + u % v
        fl[k, 2] = math.exp(-abs(u)) + math.sin(u) * math.cos(v) + math.copysign(1.0, v) + math.atan2(u, v)
        fl[k, 3] = u ** 2 + u ** 3 + abs(v) ** 0.5 + abs(u) ** 1.0 + (u ** 17) % 3 + u ** v + (abs(u) + 1.0) ** -3
        fl[k, 3] += (abs(v) + 0.5) ** ((p % 7) - 3) + (((q % 2) + 1) ** -2) + (abs(u) + 1.1) ** (p % 200000)
        fl[k, 4] = max(u, v) - min(u, v) + max(v, 0.25) + min(u, math.nan)
        fl[k, 5] = 1.0 * (u < v) + -2.5 * (u == v) + 0.0 * (u > v) + u * (v > 0) + math.inf * (u != u)
        w = u if math.isfinite(u) else 0.5
        z = v if math.isfinite(v) else 1.5
        fl[k, 6] = float(math.floor(w)) + math.ceil(z) + int(w * 3.7) + (u if u > v else p)
        fl[k, 7] = scale * p + (1.0 if math.isfinite(u) else 0.0) + (2.0 if math.isnan(v) else 0.0)
        total += fl[k, 0] if fl[k, 0] == fl[k, 0] else 0.0
        acc += 1
    j = 0
    while True:
        j += 3
        if j < 10:
            continue
        if j > 20:
            break
    for i in range(n - 1, -1, -2):
        acc += i
    return acc + j + int(total > 0)
'''


def _arguments(seed: int, n: int = 4000):
    rng = np.random.default_rng(seed)
    edges = np.array([0, 1, -1, 2**62, -2**63, 2**63 - 1, 7, -7, 255, -256], np.int64)
    a = rng.integers(-2**40, 2**40, n)
    b = rng.integers(-50, 50, n)
    a[:len(edges)] = edges
    b[:len(edges)] = edges[::-1]
    x = rng.normal(0, 10, n)
    y = rng.normal(0, 3, n)
    x[:6] = [0.0, -0.0, np.inf, -np.inf, np.nan, 1e308]
    y[:6] = [-0.0, 0.0, 2.0, np.nan, 1.0, -1e-308]
    return [a, b, x, y, np.zeros((n, 11), np.int64), np.zeros((n, 8)), n, 0.75, True]


def _same(numba_args, native_args):
    for mine, theirs in zip(native_args, numba_args):
        if isinstance(theirs, np.ndarray):
            np.testing.assert_array_equal(mine, theirs)
            if mine.dtype.kind == "f":       # -0.0 is not 0.0 (a NaN's sign is no value's)
                numbers = ~np.isnan(theirs)
                assert np.array_equal(np.signbit(mine[numbers]), np.signbit(theirs[numbers]))


def test_every_construct_gives_numbas_bits():
    reference = load_source(SOURCE, "pendc_test").kernel
    native = NativeFunction(SOURCE, "pendc_test")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with np.errstate(all="ignore"):
            for seed in (1, 2):
                theirs, mine = _arguments(seed), _arguments(seed)
                assert native(*mine) == reference(*theirs)
                _same(theirs, mine)


def test_strided_arrays_are_copied_in_and_written_back():
    reference = load_source(SOURCE, "pendc_test").kernel
    native = NativeFunction(SOURCE, "pendc_test")
    theirs, mine = _arguments(3), _arguments(3)
    mine[4] = np.zeros((11, 4000), np.int64).T                # the output array in Fortran order
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("error")
        assert native(*mine) == reference(*theirs)
    _same(theirs, mine)


def test_scalar_types_specialize_like_numba():
    """An int where a float was passed before is another specialization, as numba types it."""
    native = NativeFunction(SOURCE, "pendc_test")
    with np.errstate(all="ignore"):
        native(*_arguments(4))
        args = _arguments(4)
        args[7] = 3                                          # scale: an int this time
        native(*args)
    assert len(native._calls) == 2


@pytest.mark.parametrize("change", [("    j = 0\n", "    j = 0\n    pair = [1, 2]\n    j = pair[0] - 1\n", "List"),
                                    ("buf[k % 8] = p", "buf[k % 8] = np.sum(a)", "np.sum")])
def test_a_source_outside_the_subset_runs_on_numba_with_a_warning(change):
    old, new, why = change
    source = SOURCE.replace(old, new)
    with pytest.raises(Untranslatable, match=why):
        translate(source, "kernel", tuple(_argument_types(_arguments(5))))
    with pytest.warns(RuntimeWarning, match="runs on numba"), np.errstate(all="ignore"):
        got = NativeFunction(source, "pendc_test")(*_arguments(5))
    with np.errstate(all="ignore"):
        assert got == load_source(SOURCE, "pendc_test").kernel(*_arguments(5))


def _argument_types(args):
    from pendc.native.build import arg_type
    return [arg_type(a) for a in args]


@pytest.mark.parametrize("mode", ["fixed", "float"])
def test_every_node_kind_kernel_gives_numbas_bits(mode):
    """Every node kind's kernel (both roundings and overflows, LUTs, FSMs), run by numba and by C:
    every recorded node, the extremes and the first overflow steps."""
    nodes = [make("u", Kind.INPUT, qformat=QFormat.parse("FIX16_8"), port="u"),
             make("w", Kind.INPUT, qformat=QFormat.parse("FIX12_4"), port="w")]
    for sfx in ("nt", "ts"):        # both roundings, both overflows; numba compiles a kernel per mode here
        nodes += block(sfx, *MODES[sfx])
    g = Graph.build("native_pair", nodes, [(n.name, n.name) for n in nodes])
    cg = CompiledGraph(g, mode)
    reference = load_source(cg.source, "pendc_ir").kernel
    inputs = random_inputs(3000, seed=11)
    results = []
    for kernel in (reference, NativeFunction(cg.source, "pendc_ir")):
        cg._kernel = kernel
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            trace = cg.run(inputs, track_max=True, every=3)
        results.append(trace)
    theirs, mine = results
    assert mine.steps == theirs.steps and mine.overflows == theirs.overflows
    assert mine.max_abs == theirs.max_abs or mode == "float"
    for port, values in theirs.outputs.items():
        np.testing.assert_array_equal(mine.outputs[port], values, err_msg=port)


def test_backend_follows_the_environment(monkeypatch):
    monkeypatch.setenv("PENDC_KERNELS", "numba")
    assert backend() == "numba"
    monkeypatch.setenv("PENDC_KERNELS", "native")
    assert backend() == "native"
    monkeypatch.setenv("PENDC_KERNELS", "llvm")
    with pytest.raises(PendcError, match="PENDC_KERNELS"):
        backend()


@pytest.mark.parametrize("method", ["rk4", "euler"])
def test_float_simulator_gives_numbas_bits(method):
    """The identification simulator (tuples of states and parameters, helper functions returning
    tuples, numba's raising error model) from the same source, run both ways."""
    from pendc import load_model
    from pendc.sim.kernel import kernel_source
    from pendc.sim.simulator import Simulator
    sim = Simulator(load_model(), dt=1e-4, method=method)
    t = np.arange(0.0, 1.5, 1e-3)
    u = 4.0 * np.sin(9.0 * t)
    s0 = np.array([0.0, 0.05, 0.3, -0.1])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mine, rows = sim.raw(t, u, s0, sim.param_vector)
    source = kernel_source(sim.model.equations, sim.signals.clamped())
    theirs = np.empty_like(mine)
    assert load_source(source, "pendc_kernel").simulate(t, u, s0, sim.param_vector, 1e-4, method == "rk4", 0,
                                                        theirs) == rows == len(t)
    np.testing.assert_array_equal(mine, theirs)


@pytest.mark.parametrize("body", ["a / b + a // b", "a + b ** -2", "a - (b * 1.5) ** -1"])
def test_a_division_by_zero_raises_as_in_numba(body):
    source = f"from numba import njit\n\n\n@njit(cache=True)\ndef ratio(a, b):\n    return {body}\n"
    with pytest.raises(ZeroDivisionError):
        load_source(source, "pendc_test").ratio(1.0, 0.0)
    native = NativeFunction(source, "pendc_test", "ratio")
    assert native(7.0, 2.0) == load_source(source, "pendc_test").ratio(7.0, 2.0)
    with pytest.raises(ZeroDivisionError):
        native(1.0, 0.0)


def test_a_compiler_that_fails_means_numba_without_a_warning(monkeypatch, tmp_path):
    from pendc.native.build import kernel_function
    monkeypatch.setenv("PENDC_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", "false")                 # exists, and fails on everything
    toolchain.cache_clear()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert toolchain() is None and backend() == "numba"
            assert not isinstance(kernel_function(SOURCE, "pendc_test"), NativeFunction)
    finally:
        monkeypatch.undo()
        toolchain.cache_clear()


def test_the_kernels_read_python_h_precompiled(monkeypatch, tmp_path):
    """GCC makes the prelude's precompiled header once in the cache folder and uses it for a
    kernel's C with the kernels' own flags (-H marks a used one with '!'); another compiler gets
    no arguments and parses the headers as text."""
    import subprocess
    from pendc.native.build import FLAGS, _compiler_version, precompiled_prelude
    monkeypatch.setenv("PENDC_CACHE_DIR", str(tmp_path))
    cc, include, _ = toolchain()
    if "Free Software Foundation" not in _compiler_version(cc):
        assert precompiled_prelude() == ()
        return
    args = precompiled_prelude()
    header = Path(args[1])
    assert args[0] == "-include" and header.parent == tmp_path / "native" and Path(f"{header}.gch").is_file()
    c = tmp_path / "k.c"
    c.write_text("#include <Python.h>\nint twice(int a) { return 2 * a; }\n")
    done = subprocess.run([cc, *FLAGS, *args, f"-I{include}", "-H", str(c), "-o", str(tmp_path / "k.so")],
                          capture_output=True, text=True)
    assert done.returncode == 0 and f"! {header}.gch" in done.stderr, done.stderr[:500]
    assert precompiled_prelude() == args                  # made once


@pytest.mark.parametrize("line", ["    j = 0 if flag else 1\n    t2 = (1.0, 2.0) if flag else (3.0, 4.0)\n",
                                  "    t2 = (1.0, 2.0) + (3.0,)\n", "    t2 = max((1.0, 2.0), (0.5, 3.0))\n"])
def test_tuples_outside_the_subset_are_refused(line):
    """numba adds, compares and picks tuples; the translator refuses rather than guess."""
    source = SOURCE.replace("    j = 0\n", "    j = 0\n" + line)
    with pytest.raises(Untranslatable, match="tuple"):
        translate(source, "kernel", tuple(_argument_types(_arguments(6))))


def test_short_callees_are_inlined_and_long_ones_stay_calls():
    """A function the entry calls is inlined when it is short (a plant's derivatives, four calls a
    RK4 step), and stays a call when long; the bits are numba's either way."""
    from pendc.native.emit import INLINE_LINES
    long_body = "".join(f"    a = a * 1.0000001 + {i}.0\n" for i in range(INLINE_LINES + 1))
    source = ("from numba import njit\n\n\n@njit(cache=True)\ndef short(a):\n    return a * 2.0 + 1.0\n\n\n"
              f"@njit(cache=True)\ndef long(a):\n{long_body}    return a\n\n\n"
              "@njit(cache=True)\ndef entry(a):\n    return short(a) + long(a) + short(a + 1.0)\n")
    text, _ = translate(source, "entry", (FLOAT,))
    heads = {m.group(2): m.group(1) for m in re.finditer(r"^static (.*?)double f\d+_(\w+)\(", text, re.M)}
    assert heads == {"short": "inline __attribute__((always_inline)) ", "long": "", "entry": ""}
    assert NativeFunction(source, "pendc_test", "entry")(0.3) == load_source(source, "pendc_test").entry(0.3)
