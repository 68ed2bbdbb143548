"""Lower a sampled converter (an ADC sensor of the plant interface) into IR nodes.

The converter reads the state's value after the step (the value the state register is
loaded with), so its code register updates with the states at the end of the step and the
code on the core's ``NAME_code`` port is always the code of the states on the other ports.
The rule (:meth:`pendc.model.sensors.SensorSpec.code`) is

    code = clamp(floor((s - lo) * 2**bits / (hi - lo)), 0, 2**bits - 1)

built from compares, additions and muxes only, no multiplier and no divider: a
successive-approximation search, as a SAR converter does it. With ``q = (hi - lo) / 2**bits``
(one LSB) and ``base = lo``, for k = bits-1 .. 0: the threshold is ``t = base + 2**k q``, bit k
is ``s >= t`` and, when it is set, ``base`` becomes ``t``; the code is the sum of the set bits'
weights (each a mux of 0 and ``2**k``). Below ``lo`` no bit is set (code 0), from the top
code's threshold ``lo + (2**bits - 1) q`` up every bit is (the top code): the clamp costs
nothing.

A sensor offset (the catalogue's ``offset``: the converter reads ``s + offset``) moves the
range instead of adding a node: ``lo`` and ``hi`` less the offset, the same compares.

The state is compared as it is (a compare is exact, whatever the formats), so the code steps
exactly at the thresholds; the thresholds themselves are sums of the constants ``lo`` and
``2**k q``, stored as the compiler stores every constant (to nearest, 32 bits or more), in
nodes whose format holds ``max(|lo|, |hi|)`` (32 bits): a threshold sits within about
``2**-30 max(|lo|, |hi|)`` of ``lo + m q`` (exactly on it when ``lo`` and ``q`` are
binary fractions of few bits). Each node declares the capacity it has by construction
(``max_abs``), so a code the training runs never reached still fits its format.
"""

from __future__ import annotations

from ..ir.compare_ops import CompareOp
from ..ir.nodes import Kind, make


def lower_adc(sensor, value: str, meaning: str, initial: float = 0.0, offset: float = 0.0) -> tuple[list, str]:
    """Nodes of converter ``sensor`` (a :class:`~pendc.model.sensors.SensorSpec` of kind
    ``adc``) reading node ``value`` (the state's next value) plus ``offset`` (a sensor offset
    effect's value); returns the node list and the name of the code register (the core's
    ``sensor.code_port`` output)."""
    p, bits = sensor.name, sensor.bits
    lo, hi = sensor.lo - offset, sensor.hi - offset   # s + offset >= t  <=>  s >= t - offset
    q = (sensor.hi - sensor.lo) / (1 << bits)
    top = (1 << bits) - 1
    nodes = []

    def add(name, kind, inputs=(), what="", **params):
        nodes.append(make(name, kind, inputs, meaning=what, **params))
        return name

    zero = add(f"{p}_zero", Kind.CONST, value=0.0)
    edge = max(abs(lo), abs(hi))
    base = add(f"{p}_lo", Kind.CONST, value=float(lo), what=f"bottom of {sensor.name}'s range"
               + (", less the sensor offset" if offset else ""))
    code = None
    for k in range(bits - 1, -1, -1):
        weight = add(f"{p}_w{k}", Kind.CONST, value=(1 << k) * q, what=f"weight of code bit {k}")
        level = add(f"{p}_t{k}", Kind.ADD, [base, weight], f"threshold of code bit {k}", max_abs=edge)
        bit = add(f"{p}_b{k}", Kind.COMPARE, [value, level], f"code bit {k}", op=CompareOp.GE)
        if k:
            base = add(f"{p}_base{k}", Kind.MUX, [bit, base, level], f"bottom of the step above bit {k}",
                       max_abs=edge)
        place = add(f"{p}_v{k}", Kind.CONST, value=float(1 << k))
        term = add(f"{p}_c{k}", Kind.MUX, [bit, zero, place], max_abs=float(1 << k))
        code = term if code is None else add(f"{p}_s{k}", Kind.ADD, [code, term], max_abs=float(top))
    code = add(f"{p}_next", Kind.CAST, [code], f"{meaning} converter code after the step", max_abs=float(top))
    reg = add(f"{p}_code", Kind.REGISTER, [code], f"{meaning} converter code ({bits} bits)",
              reset=float(sensor.code(initial + offset)), max_abs=float(top))
    return nodes, reg
