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

from ..codegen import NumbaPrinter
from ..model.plant import Equations

KERNEL_FORMAT = 8  # bump when the generated source changes shape
# Equations printed longer than this (characters) share their common subexpressions: a chain of
# links expands its mass matrix into polynomials that repeat the same products many times (the
# double pendulum on a cart: 50 kB of source, 70 times slower than a single pendulum's). Below
# it the equations print as written, so the shipped single-pendulum data stay byte-identical.
CSE_ABOVE = 20_000


def tuple_text(items) -> str:
    """The source of a tuple of the source texts ``items`` (with its comma when it has one item)."""
    items = list(items)
    return "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")"


def integration_step(ns: int, pad: str) -> str:
    """The source of one integration step of the state tuple ``S`` (``ns`` states): RK4 when
    ``use_rk4``, else Euler, of step ``h`` (``h2``, ``h6``: its half and sixth) with the input
    ``uk`` held, then ``bound``; each line indented by ``pad``. The simulator's loop and the HIL
    float plant's (:mod:`pendc.hil.plants.plant`) print this same step."""
    def combine(a, b, c):
        return tuple_text(f"{a}[{i}] + {c}*{b}[{i}]" for i in range(ns))

    rk4_sum = tuple_text(f"S[{i}] + h6*(k1[{i}] + 2.0*k2[{i}] + 2.0*k3[{i}] + k4[{i}])" for i in range(ns))
    lines = ("if use_rk4:", "    k1 = rhs(S, uk, P)", f"    k2 = rhs({combine('S', 'k1', 'h2')}, uk, P)",
             f"    k3 = rhs({combine('S', 'k2', 'h2')}, uk, P)", f"    k4 = rhs({combine('S', 'k3', 'h')}, uk, P)",
             f"    S = {rk4_sum}", "else:", "    d = rhs(S, uk, P)", f"    S = {combine('S', 'd', 'h')}",
             "S = bound(S, P)")
    return "".join(f"{pad}{line}\n" for line in lines)


def _clamped_index(eq: Equations, clamped) -> int | None:
    """Index of the state the velocity bound holds: ``clamped`` (a state name) when given,
    else the rate the first state's derivative is (the rigid bodies put the clamped
    coordinate first); None without a bound or when that rate is held (a constant 0)."""
    if eq.velocity_bound is None:
        return None
    names = [s.name for s in eq.states]
    if clamped is not None:
        return names.index(clamped)
    first = eq.derivatives[0]
    return names.index(first.name) if getattr(first, "name", None) in names else None


def _needed_assignments(eq: Equations, exprs) -> list:
    """The assignments ``exprs`` depend on, transitively, in evaluation order."""
    need = set().union(*(e.free_symbols for e in exprs)) if exprs else set()
    keep = []
    for sym, expr in reversed(eq.assignments):
        if sym in need:
            keep.append((sym, expr))
            need |= expr.free_symbols
    return keep[::-1]


def _shared_body(eq: Equations, pr) -> tuple:
    """The derivatives with every assignment inlined and their common subexpressions named once
    (``_cse0``, ``_cse1``... in evaluation order): ``(body, return line)``."""
    import sympy as sp

    inlined = [eq.inline(d) for d in eq.derivatives]
    shared, reduced = sp.cse(inlined, symbols=sp.numbered_symbols("_cse"))
    body = "".join(f"    {sym.name} = {pr.doprint(expr)}\n" for sym, expr in shared)
    return body, f"    return {tuple_text(pr.doprint(d) for d in reduced)}\n"


def kernel_source(eq: Equations, clamped: str | None = None) -> str:
    """The Python source of the kernel module for ``eq`` (deterministic). ``clamped`` names
    the state ``eq.velocity_bound`` holds (see :func:`_clamped_index` without it)."""
    pr = NumbaPrinter()
    names = [s.name for s in eq.states]
    pnames = [s.name for s in eq.params]
    ns = len(names)
    nm = ns - len(eq.initial)          # mechanical states; the rest (lags) start from the input
    mech = names[:nm]
    unpack_s = f"    {', '.join(names)}, = S\n"
    unpack_p = f"    {', '.join(pnames)}, = P\n"
    # a plant file names its input as it likes: the kernel binds that name to its input argument
    alias = f"    {eq.input.name} = inp\n"

    body = "".join(f"    {sym.name} = {pr.doprint(expr)}\n" for sym, expr in eq.assignments)
    result = f"    return {tuple_text(pr.doprint(d) for d in eq.derivatives)}\n"
    if len(body) + len(result) > CSE_ABOVE:
        body, result = _shared_body(eq, pr)
    rhs = "@njit(cache=True)\ndef rhs(S, inp, P):\n" + unpack_s + unpack_p + alias + body + result

    held = list(names)
    index = _clamped_index(eq, clamped)
    if index is not None:
        limit = pr.doprint(eq.velocity_bound)
        held[index] = f"min(max({names[index]}, -({limit})), {limit})"
    bound = "@njit(cache=True)\ndef bound(S, P):\n" + unpack_s + unpack_p + f"    return {tuple_text(held)}\n"

    inits = [f"float({pr.doprint(e)})" for e in eq.initial]  # a literal 0 would make the tuple mixed-type
    force_body = "".join(f"    {sym.name} = {pr.doprint(expr)}\n" for sym, expr in _needed_assignments(eq, eq.initial))
    init = (f"@njit(cache=True)\ndef start(SM, inp, P):\n    {', '.join(mech)}, = SM\n" + unpack_p + alias + force_body
            + f"    return {tuple_text(mech + inits)}\n")

    delay_index = pnames.index(eq.delay.name) if eq.delay is not None else -1
    loop = f'''
@njit(cache=True)
def simulate(t, u, s0, p, dt, use_rk4, k0, out):
    """States at the sample times t into the rows of out; u held constant (ZOH) from t[k] to
    t[k+1]. The run starts at row k0 from s0; earlier rows only supply input history (delays).
    Returns the number of rows written (fewer when the run diverged)."""
    P = {tuple_text(f"p[{i}]" for i in range(len(pnames)))}
    n = t.shape[0]
    k_first = {"0" if ns > nm else "k0"}
    S = start({tuple_text(f"s0[{i}]" for i in range(nm))}, u[k_first], P)
    tau = {f"P[{delay_index}]" if delay_index >= 0 else "0.0"}
    j = 0
    for r in range(k0 + 1):
        for i in range({ns}):
            out[r, i] = S[i]
    for k in range(k_first, n - 1):
        if k == k0:
            # extra states (e.g. a motor lag) were pre-rolled over the input history;
            # the mechanical state starts here from s0
            S = {tuple_text([f"s0[{i}]" for i in range(nm)] + [f"S[{i}]" for i in range(nm, ns)])}
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
{integration_step(ns, "            ")}        for i in range({ns}):
            out[k + 1, i] = S[i]
        if not math.isfinite({" + ".join(f"S[{i}]" for i in range(ns))}):
            return k + 1
    return n
'''
    header = (f'"""Generated by pendc.sim.kernel (format {KERNEL_FORMAT}); states {names}."""\n'
              "import math\n\nimport numpy as np\nfrom numba import njit\n\n\n")
    return header + rhs + "\n\n" + bound + "\n\n" + init + "\n" + loop


def stored_kernel_source(eq: Equations, clamped: str | None = None) -> str:
    """:func:`kernel_source`, kept in the cache folder under a hash of the equations (their
    ``srepr``), ``clamped`` and the code that prints them. Printing a chain of links' equations
    with their common subexpressions takes 1.5 s (the double pendulum on a cart; its srepr 0.2 s),
    and a diagnosis builds a dozen simulators of three models."""
    import hashlib
    from pathlib import Path

    import sympy as sp

    from ..atomic import write_atomic
    from ..codegen import cache_dir
    from ..errors import PendcError

    fields = (eq.states, eq.input, eq.params, eq.assignments, eq.derivatives, eq.initial, eq.velocity_bound,
              eq.delay)
    digest = hashlib.sha256(f"{KERNEL_FORMAT}\0{clamped}\0{sp.srepr(fields)}".encode())
    for code in (__file__, Path(__file__).parents[1] / "codegen.py"):
        digest.update(Path(code).read_bytes())
    path = cache_dir("kernel_sources") / f"{digest.hexdigest()[:24]}.py"
    try:
        return path.read_text(encoding="utf-8")
    except OSError:
        pass
    source = kernel_source(eq, clamped)
    try:
        write_atomic(path, source)
    except PendcError:            # a read-only cache: printed again next time
        pass
    return source
