"""Lower the two quadrature encoders (spec §4, thesis Fig. II.14/II.16) into IR nodes.

Each channel is the thesis' Moore machine over a two-band window: a phase register
(in bands) accumulates the encoder-disk increment of each step; the FSM classifies
the phase as Lightness / Darkness, or Over_upper_limit / Lower_lower_limit when it
left the window, and in those two states the next step folds the phase back by two
bands. Channel B's window is channel A's shifted by half a band, so B lags A by a
quarter period (A leads when the position grows).

The disk increment is the integrator's own increment of the state the encoder reads,
scaled to bands (the band width, in the state's unit, is the plant interface's
:class:`~pendc.model.sensors.SensorSpec`; for the thesis' cart, Δφ = (2π/k)·Δx, II.55), so the
encoder sees exactly the motion the state registers see.
"""

from __future__ import annotations

from ..ir import fsm as fsm_sem
from ..ir.compare_ops import CompareOp
from ..ir.nodes import ANY_STATE, FsmParams, Kind, SliceParams, Transition, make

STATES = ("LIGHTNESS", "DARKNESS", "OVER_UPPER_LIMIT", "LOWER_LOWER_LIMIT")
# Moore output word: bit 0 = channel level, bits 2..1 = fold code (0 none, 1 minus two bands, 2 plus two bands)
OUTPUTS = (1, 0, 0 | (1 << 1), 1 | (2 << 1))
FOLD = {"none": 0.0, "minus": -2.0, "plus": 2.0}


def channel_window(offset: float) -> tuple[float, float, float]:
    """(lower limit, light/dark boundary, upper limit) in bands; A has offset 0, B 0.5."""
    return -1.0 + offset, 0.0 + offset, 1.0 + offset


def channel_transitions(offset: float) -> tuple:
    """The channel's Moore machine rules, tried in order from any state."""
    lower, mid, upper = channel_window(offset)
    return (
        Transition(ANY_STATE, CompareOp.GE, upper, "OVER_UPPER_LIMIT"),
        Transition(ANY_STATE, CompareOp.LT, lower, "LOWER_LOWER_LIMIT"),
        Transition(ANY_STATE, CompareOp.GE, mid, "LIGHTNESS"),
        Transition(ANY_STATE, CompareOp.LT, mid, "DARKNESS"),
    )


def lower_encoder(prefix: str, increment: str, band: float, meaning: str) -> tuple[list, dict]:
    """Nodes of one encoder (two channels) fed by the state increment node ``increment``.

    Returns the node list and ``{"a": node, "b": node}`` naming the channel-level nodes.
    """
    nodes = [make(f"{prefix}_dphi", Kind.GAIN, [increment], value=1.0 / band,
                  meaning=f"{meaning} disk increment per step (bands)")]
    levels = {}
    for channel, offset in (("a", 0.0), ("b", 0.5)):
        name = f"{prefix}_{channel}"
        lower, _, upper = channel_window(offset)
        transitions = channel_transitions(offset)
        reset = STATES[fsm_sem.next_state_float(0, 0.0, STATES, transitions)]
        nodes += [
            make(f"{name}_phase", Kind.REGISTER, [f"{name}_sum"], reset=0.0,
                 meaning=f"channel {channel.upper()} phase in its two-band window (bands)"),
            make(f"{name}_moved", Kind.ADD, [f"{name}_phase", f"{prefix}_dphi"]),
            make(f"{name}_fold_code", Kind.SLICE, [f"{name}_fsm"], params=SliceParams(hi=2, lo=1)),
            make(f"{name}_fold_none", Kind.CONST, value=FOLD["none"]),
            make(f"{name}_fold_minus", Kind.CONST, value=FOLD["minus"]),
            make(f"{name}_fold_plus", Kind.CONST, value=FOLD["plus"]),
            make(f"{name}_fold", Kind.MUX, [f"{name}_fold_code", f"{name}_fold_none", f"{name}_fold_minus",
                                           f"{name}_fold_plus"], meaning="window re-adjustment (bands)"),
            make(f"{name}_sum", Kind.ADD, [f"{name}_moved", f"{name}_fold"]),
            make(f"{name}_fsm", Kind.FSM, [f"{name}_sum"],
                 params=FsmParams(states=STATES, reset=reset, transitions=transitions, outputs=OUTPUTS,
                                  lo=lower - 2.0, hi=upper + 2.0),
                 meaning=f"channel {channel.upper()} Moore machine (thesis Fig. II.16)"),
            make(f"{name}_level", Kind.SLICE, [f"{name}_fsm"], params=SliceParams(hi=0, lo=0),
                 meaning=f"{meaning} encoder channel {channel.upper()}"),
        ]
        levels[channel] = f"{name}_level"
    return nodes, levels
