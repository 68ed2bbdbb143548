"""The experiments identification uses (spec §3, §4; thesis ch. 3): what was held or removed.

A measurement declares its experiment (a ``# experiment: NAME`` metadata line or the
command line's ``--experiment NAME``) and the simulation honours it, so the residual is
not polluted by physics that was not in the experiment. Each rigid body has its own set
(:data:`EXPERIMENTS` is the cart-pendulum's, :data:`FURUTA_EXPERIMENTS` the rotary
pendulum's); ``free`` (everything moves) is in every set and is the default.
"""

from __future__ import annotations

DEFAULT_EXPERIMENT = "free"

EXPERIMENTS: dict[str, str] = {
    "free": "cart and pendulum both move (steps, chirps, closed-loop runs): the full model",
    "cart_held": "the cart is clamped: only the pendulum swings (pivot friction, I, L)",
    "pendulum_removed": "the pendulum is taken off: the cart alone at constant voltages (drive, friction)",
}

FURUTA_EXPERIMENTS: dict[str, str] = {
    "free": "arm and pendulum both move (steps, chirps, closed-loop runs): the full model",
    "arm_held": "the arm is clamped: only the pendulum swings (hinge friction, m_p, L_p)",
    "pendulum_removed": "the pendulum is taken off: the motor turns the arm alone (motor, arm friction, J_r)",
}
