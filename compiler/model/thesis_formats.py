"""The Q-formats the thesis published for the plant it built (spec §5), for reports to set
beside pendc's own.

The thesis built one plant, the SCT cart-pendulum; its fixed-point design printed a format
for each state register and each acceleration, and the largest value it simulated for the
two accelerations (from which its sizing rule gives the format). The names are the nodes of
that plant's graph (its plant interface's states and named intermediates). Any other plant
has no published formats: :func:`thesis_formats` gives an empty table for it.
"""

from __future__ import annotations

from types import MappingProxyType

# spec §5 (thesis, fixed-point design): node -> {"format": FIX<width>_<fraction>, "max": printed maximum}
CART_PENDULUM_FORMATS = MappingProxyType({
    "x": MappingProxyType({"format": "FIX32_31"}),
    "dx": MappingProxyType({"format": "FIX32_31"}),
    "ddx": MappingProxyType({"format": "FIX32_26", "max": 18.39}),
    "theta": MappingProxyType({"format": "FIX32_28"}),
    "dtheta": MappingProxyType({"format": "FIX32_26"}),
    "ddtheta": MappingProxyType({"format": "FIX32_24", "max": 83.21}),
})

# plant interface name -> its published formats
THESIS_FORMATS = MappingProxyType({"cart_pendulum": CART_PENDULUM_FORMATS})


def thesis_formats(interface) -> dict:
    """Node name -> ``{"format": ..., "max": ...}`` (``max`` where the thesis printed one) for
    the plant of ``interface`` (a :class:`~pendc.model.interface.PlantInterface`, or None for a
    hand-built graph); empty for a plant the thesis did not build."""
    if interface is None:
        return {}
    return {name: dict(row) for name, row in THESIS_FORMATS.get(interface.name, {}).items()}
