"""Compile a model's state equations into a numba kernel.

Why numba and generated source rather than ``lambdify`` + a numpy loop: the
integrator takes 10^6 steps per simulated second with a state-dependent friction
law, so the loop itself must be compiled; vectorising over time is impossible.
The equations are printed once as plain Python (``math`` functions, conditional
expressions for Piecewise/sign), wrapped in a fixed integrator loop, written to a
cache file named by the hash of the source and compiled by numba with its on-disk
cache. The kernel depends on the model's *structure* only: parameter values are
an argument, so a fit re-runs the same machine code with new values.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import tempfile
from pathlib import Path

from sympy.printing.pycode import PythonCodePrinter

from ..model.plant import Equations

KERNEL_FORMAT = 6  # bump when the generated source changes shape


class _KernelPrinter(PythonCodePrinter):
    def __init__(self):
        super().__init__({"standard": "python3", "fully_qualified_modules": True})

    def _print_Min(self, expr):
        return self._nested("min", expr.args)

    def _print_Max(self, expr):
        return self._nested("max", expr.args)

    def _nested(self, fn, args):
        out = self._print(args[0])
        for a in args[1:]:
            out = f"{fn}({out}, {self._print(a)})"
        return out


def _tuple(items) -> str:
    items = list(items)
    return "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")"


def kernel_source(eq: Equations) -> str:
    """The Python source of the kernel module for ``eq`` (deterministic)."""
    pr = _KernelPrinter()
    names = [s.name for s in eq.states]
    pnames = [s.name for s in eq.params]
    ns = len(names)
    unpack_s = f"    {', '.join(names)}, = S\n"
    unpack_p = f"    {', '.join(pnames)}, = P\n"

    body = "".join(f"    {sym.name} = {pr.doprint(expr)}\n" for sym, expr in eq.assignments)
    rhs = ("@njit(cache=True)\ndef rhs(S, u, P):\n" + unpack_s + unpack_p + body
           + f"    return {_tuple(pr.doprint(d) for d in eq.derivatives)}\n")

    clamped = list(names)
    if eq.velocity_bound is not None:
        clamped[1] = f"min(max(dx, -({pr.doprint(eq.velocity_bound)})), {pr.doprint(eq.velocity_bound)})"
    bound = "@njit(cache=True)\ndef bound(S, P):\n" + unpack_s + unpack_p + f"    return {_tuple(clamped)}\n"

    inits = [f"float({pr.doprint(e)})" for e in eq.initial]  # a literal 0 would make the tuple mixed-type
    force_body = "".join(f"    {sym.name} = {pr.doprint(expr)}\n" for sym, expr in eq.assignments
                         if sym.name in ("F_N", "F_in"))
    init = ("@njit(cache=True)\ndef start(S4, u, P):\n    x, dx, theta, dtheta = S4\n" + unpack_p + force_body
            + f"    return {_tuple(['x', 'dx', 'theta', 'dtheta'] + inits)}\n")

    def combine(a, b, c):
        return _tuple(f"{a}[{i}] + {c}*{b}[{i}]" for i in range(ns))

    rk4_sum = _tuple(f"S[{i}] + h6*(k1[{i}] + 2.0*k2[{i}] + 2.0*k3[{i}] + k4[{i}])" for i in range(ns))
    delay_index = pnames.index(eq.delay.name) if eq.delay is not None else -1
    loop = f'''
@njit(cache=True)
def simulate(t, u, s0, p, dt, use_rk4, k0=0):
    """States at the sample times t; u held constant (ZOH) from t[k] to t[k+1].
    The run starts at row k0 from s0; earlier rows only supply input history (delays)."""
    P = {_tuple(f"p[{i}]" for i in range(len(pnames)))}
    n = t.shape[0]
    out = np.empty((n, {ns}))
    k_first = {"0" if ns > 4 else "k0"}
    S = start((s0[0], s0[1], s0[2], s0[3]), u[k_first], P)
    tau = {f"P[{delay_index}]" if delay_index >= 0 else "0.0"}
    j = 0
    for r in range(k0 + 1):
        for i in range({ns}):
            out[r, i] = S[i]
    for k in range(k_first, n - 1):
        if k == k0:
            # extra states (e.g. a motor lag) were pre-rolled over the input history;
            # the mechanical state starts here from s0
            S = {_tuple(["s0[0]", "s0[1]", "s0[2]", "s0[3]"] + [f"S[{i}]" for i in range(4, ns)])}
            for i in range({ns}):
                out[k0, i] = S[i]
        span = t[k + 1] - t[k]
        nsub = int(math.ceil(span / dt - 1e-6))
        if nsub < 1:
            nsub = 1
        h = span / nsub
        h2 = 0.5 * h
        h6 = h / 6.0
        uk = u[k]
        for m in range(nsub):
            if tau > 0.0:
                ts = t[k] + m * h - tau
                while j + 1 < n and t[j + 1] <= ts + 1e-3 * h:
                    j += 1
                uk = u[j]
            if use_rk4:
                k1 = rhs(S, uk, P)
                k2 = rhs({combine("S", "k1", "h2")}, uk, P)
                k3 = rhs({combine("S", "k2", "h2")}, uk, P)
                k4 = rhs({combine("S", "k3", "h")}, uk, P)
                S = {rk4_sum}
            else:
                d = rhs(S, uk, P)
                S = {combine("S", "d", "h")}
            S = bound(S, P)
        for i in range({ns}):
            out[k + 1, i] = S[i]
        if not math.isfinite({" + ".join(f"S[{i}]" for i in range(ns))}):
            return out, k + 1
    return out, n
'''
    header = (f'"""Generated by pendc.sim.kernel (format {KERNEL_FORMAT}); states {names}."""\n'
              "import math\n\nimport numpy as np\nfrom numba import njit\n\n\n")
    return header + rhs + "\n\n" + bound + "\n\n" + init + "\n" + loop


def _cache_dir() -> Path:
    root = os.environ.get("PENDC_CACHE_DIR")
    path = Path(root) if root else Path.home() / ".cache" / "pendc" / "kernels"
    try:
        path.mkdir(parents=True, exist_ok=True)
        if os.access(path, os.W_OK):
            return path
    except OSError:
        pass
    path = Path(tempfile.gettempdir()) / "pendc-kernels"
    path.mkdir(parents=True, exist_ok=True)
    return path


def load_kernel(eq: Equations):
    """Import (compiling on first use, from numba's disk cache later) the kernel of ``eq``."""
    source = kernel_source(eq)
    digest = hashlib.sha256(source.encode()).hexdigest()[:20]
    name = f"pendc_kernel_{digest}"
    if name in sys.modules:  # already imported in this process
        return sys.modules[name]
    path = _cache_dir() / f"pendc_kernel_{digest}.py"
    if not path.exists() or path.read_text() != source:
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(source)
        os.replace(tmp, path)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
