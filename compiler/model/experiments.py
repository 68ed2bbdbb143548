"""The experiments identification uses (spec §3, §4; thesis ch. 3): what was held or removed.

A measurement declares its experiment (a ``# experiment: NAME`` metadata line or the
command line's ``--experiment NAME``) and the simulation honours it, so the residual is
not polluted by physics that was not in the experiment.
"""

from __future__ import annotations

EXPERIMENTS: dict[str, str] = {
    "free": "cart and pendulum both move (steps, chirps, closed-loop runs): the full model",
    "cart_held": "the cart is clamped: only the pendulum swings (pivot friction, I, L)",
    "pendulum_removed": "the pendulum is taken off: the cart alone at constant voltages (drive, friction)",
}
DEFAULT_EXPERIMENT = "free"
