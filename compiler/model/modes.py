"""How fast a plant moves: the fastest mode of its linearisation where it starts, and what the
core's forward Euler step does to it.

Reading data faster than the hardware's 1 kHz keeps as many samples as the plant's fastest
mode needs (:func:`pendc.sim.resample.regrid`): a power stage or an electrical ladder rings at
hundreds of hertz to kilohertz, and averaging its record down to 1 kHz would erase what is to be
identified. The linearisation is the controllers' (derivative of a sign is zero: :func:`without_delta`),
at each state's ``initial`` value with the input at zero.
"""

from __future__ import annotations

import math

import numpy as np

from .plant import PlantModel


def fastest_mode_hz(model: PlantModel) -> float:
    """The largest |eigenvalue| / 2 pi of the state equations' Jacobian at the start state (Hz;
    0 for a plant without dynamics there). Made once per model."""
    return float(abs(fastest_eigenvalue(model))) / (2 * math.pi)


def fastest_eigenvalue(model: PlantModel) -> complex:
    """The eigenvalue of largest magnitude of the Jacobian at the start state (0 if none); kept
    on disk by the model's fingerprint, as differentiating the equations takes up to seconds
    (a double pendulum's: 5 s) and ``pendc simulate`` asks on every float run."""
    return model.derived("fastest_eigenvalue", _stored)


def _stored(model: PlantModel) -> complex:
    import hashlib
    import os
    import tempfile
    from pathlib import Path

    from ..codegen import cache_dir
    from .modelfile import model_fingerprint

    # what the eigenvalue depends on: the model's values and physics, and the code that derives
    # and differentiates its equations (this folder)
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256((model_fingerprint(model) + str(model.experiment)).encode())
    for f in sorted(here.glob("*.py")):
        digest.update(f.read_bytes())
    key = digest.hexdigest()[:24]
    path = cache_dir("modes") / f"{key}.txt"
    try:
        return complex(path.read_text().strip())
    except (OSError, ValueError):
        pass
    value = _fastest(model)
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".mode_")
        with os.fdopen(fd, "w") as f:
            f.write(repr(value))
        os.replace(tmp, path)
    except OSError:           # a read-only cache: computed again next time
        pass
    return value


def euler_growth(eigenvalue: complex, dt: float) -> float:
    """How much faster (1/s) forward Euler at ``dt`` lets a mode ``eigenvalue`` grow than the
    equations do: Euler multiplies it by 1 + lambda dt a step, the rate log|1 + lambda dt| / dt
    against Re lambda (an undamped mode of angular frequency w gains about w^2 dt / 2)."""
    factor = abs(1 + complex(eigenvalue) * dt)
    if factor == 0.0:
        return 0.0
    return math.log(factor) / dt - complex(eigenvalue).real


def mode_words(eigenvalue: complex) -> str:
    """An eigenvalue in words: "a 1154 Hz oscillation decaying at 119 /s", "a real pole at -31.3 /s
    (5 Hz corner)"."""
    lam = complex(eigenvalue)
    if abs(lam.imag) <= 1e-9 * abs(lam):
        return f"a real pole at {lam.real:.3g} /s ({abs(lam) / (2 * math.pi):.3g} Hz corner)"
    verb = "decaying" if lam.real < 0 else "growing"
    return f"a {abs(lam.imag) / (2 * math.pi):.4g} Hz oscillation {verb} at {abs(lam.real):.3g} /s"


def euler_instability(model: PlantModel, dt: float) -> str | None:
    """Words for a step at which forward Euler makes the plant's fastest mode at the start state
    grow (None where it does not): why a build or an Euler simulation at ``dt`` diverged, said
    instead of the range or square-root hints that cannot help."""
    lam = fastest_eigenvalue(model)
    words = euler_unstable(lam, dt) if lam != 0 else None
    return f"the plant's fastest mode ({abs(lam) / (2 * math.pi):.4g} Hz): {words}" if words else None


def euler_shortfall(model: PlantModel, dt: float, core_dt: float | None = None) -> str | None:
    """What forward Euler at ``dt`` takes of the fastest mode's damping, when it is more than 5 %
    of it (None otherwise): a sentence for ``pendc simulate``. ``core_dt``: the core's step
    (default ``dt``); the sentence says whether the core loses the same."""
    lam = fastest_eigenvalue(model)
    grow, decay = euler_growth(lam, dt), -complex(lam).real
    if lam == 0 or decay <= 0 or grow <= 0.05 * decay:
        return None
    if euler_unstable(lam, dt):
        return euler_instability(model, dt)
    core = ", as the core does" if core_dt is None or core_dt == dt else f" (the core steps {core_dt:g} s)"
    return (f"forward Euler at {dt:g} s takes {100 * grow / decay:.0f} % of the damping of the plant's fastest "
            f"mode ({abs(lam) / (2 * math.pi):.4g} Hz) away{core}; --method rk4 follows the equations")


def euler_unstable(eigenvalue: complex, dt: float) -> str | None:
    """Words for a decaying mode that forward Euler at ``dt`` makes grow (|1 + lambda dt| > 1: the
    core diverges where the equations settle) with the largest step that keeps it decaying;
    None when Euler keeps it decaying."""
    lam = complex(eigenvalue)
    if lam.real >= 0 or abs(1 + lam * dt) <= 1.0:
        return None
    stable = -2.0 * lam.real / abs(lam) ** 2
    return (f"forward Euler at {dt:g} s is unstable for it (|1 + lambda dt| = {abs(1 + lam * dt):.3g} > 1): the "
            f"core diverges where the equations settle; [hardware] dt must be below {stable:.3g} s")


def euler_note(model: PlantModel, dt: float) -> str:
    """One line on the core's integrator and the plant's fastest mode (``plant check``)."""
    lam = fastest_eigenvalue(model)
    head = f"core integrator: forward Euler at {dt:g} s"
    if lam == 0:
        return head + "; no dynamics at the start state"
    unstable = euler_unstable(lam, dt)
    if unstable:
        return f"{head}; fastest mode at the start state: {mode_words(lam)}; {unstable}"
    grow, decay = euler_growth(lam, dt), -complex(lam).real
    line = f"{head}; fastest mode at the start state: {mode_words(lam)}; Euler adds {grow:.3g} /s of growth to it"
    if decay > 0 and grow > 0.05 * decay:
        line += (f", {100 * grow / decay:.0f} % of its damping: the core rings longer than the equations "
                 f"(a smaller [hardware] dt shrinks this)")
    return line


def without_delta(expr):
    """``expr`` with every DiracDelta set to zero: d sign(v)/dv is one, zero away from v = 0,
    where the linearisations are taken."""
    import sympy as sp

    return expr.replace(lambda e: isinstance(e, sp.DiracDelta), lambda e: sp.Integer(0))


def _fastest(model: PlantModel) -> complex:
    import sympy as sp

    eq = model.equations
    n = len(eq.states)
    if n == 0:
        return 0j
    try:
        jac = _start_jacobian(eq, model)
    except (TypeError, ValueError, ZeroDivisionError):   # not a number there (a pole at the start state)
        return 0j
    if not np.all(np.isfinite(jac)):
        return 0j
    eig = np.linalg.eigvals(jac)
    return complex(eig[int(np.argmax(np.abs(eig)))])


def _start_jacobian(eq, model: PlantModel) -> np.ndarray:
    """d(derivatives)/d(states) at the start state (input 0), by the chain rule through the
    assignments: each assignment's value and gradient in turn, every partial derivative taken of
    the assignment as written and valued at once. Inlining first (a chain of links' mass-matrix
    solution into each acceleration) and differentiating the whole took 2 s for the double
    pendulum on a cart, 5 for each variant a diagnosis tries."""
    import sympy as sp

    values = {p: sp.Float(v) for p, v in zip(eq.params, model.parameter_vector())}
    initial = {s.name: s.initial for s in model.interface.states}
    known = dict(values)
    known.update({s: sp.Float(float(initial.get(s.name, 0.0) or 0.0)) for s in eq.states})
    known[eq.input] = sp.Float(0.0)
    n = len(eq.states)
    grads = {s: np.eye(n)[i] for i, s in enumerate(eq.states)}

    def valued(expr) -> float:
        return float(expr.xreplace(known).evalf())

    def gradient(expr) -> np.ndarray:
        out = np.zeros(n)
        for x in expr.free_symbols & grads.keys():
            out += valued(without_delta(sp.diff(expr, x))) * grads[x]
        return out

    for sym, expr in eq.assignments:
        f = expr.xreplace(values)
        grads[sym] = gradient(f)
        known[sym] = sp.Float(valued(f))
    return np.array([gradient(sp.sympify(d).xreplace(values)) for d in eq.derivatives])
