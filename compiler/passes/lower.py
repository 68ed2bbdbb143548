"""Lower a plant model's sympy equations into the dataflow IR (untyped).

The hardware step is the thesis' (IV.4-IV.7): forward-Euler integrators, one
register per state, ``s[n+1] = s[n] + dt * s'[n]``, the cart velocity clamped after
integration. Everything else follows from the structure of the equations:

* Sums are split into terms; in each term the factors that are smooth functions of a
  single variable (``cos(q)``, ``1/k(q)``, the Stribeck exponential of
  ``|dx|``) are gathered, and terms with the same remaining factors are summed into
  one table: ``ddp = F*T1(q) + dq**2*T2(q) + T3(q) + tau*T4(q)``.
  No divider is ever emitted and each table is the exact coefficient, not a product of
  rounded tables.
* Non-smooth operations are structural: ``Abs`` and multiply-by-``sign`` become
  sign-bit slice + negate + mux (IV.2-IV.8), ``Piecewise``/``Min``/``Max`` become
  compare + mux chains.
* A periodic state (an angle; see :mod:`pendc.model.interface`) is kept continuous
  (unwrapped), as measurements and the float model have it, with integer bits for the
  interface's ``turns`` periods either way (a declared range that range analysis honours).
  A turn counter keeps ``<state>_phase`` = the state less its whole turns within about half a
  period either side of zero, and tables of that state are periodic and addressed by the state
  in *turns* (phase / period), whose fraction bits are the position within one revolution, so
  wrapping costs nothing and the state never jumps.

Every plant-specific fact (state and input names, meanings, periods, the velocity clamp, the
encoders, the core's name) comes from the model's :class:`~pendc.model.interface.PlantInterface`,
which the graph carries in its ``info`` for the passes after this one.
"""

from __future__ import annotations

import sympy as sp

from ..errors import PendcError
from ..ir.graph import Graph
from ..ir.compare_ops import CompareOp
from ..ir.nodes import Kind, make
from ..model.interface import INFO_KEY, StateSpec
from ..model.plant import PlantModel
from .fold_constants import live_nodes
from .lower_encoders import lower_encoder
from .lower_expr import ExpressionLowerer
from .lower_sensors import lower_adc
from .lower_sums import push_sums_into_muxes

READ_AHEAD_KEY = "read_ahead"   # graph info: (register, state, period) of each table read a step ahead


def lower_model(model: PlantModel, dt: float = 1e-6, encoders: bool = True, fold_dt: bool = False,
                turns_phase: bool = False, deep_last: bool = False, narrow_abs: bool = False,
                lookahead: bool = False, clamp_on_increment: bool = False, sum_into_mux: bool = False) -> Graph:
    """The untyped IR graph of one model step of ``dt`` seconds (forward Euler, IV.4-IV.7).

    Outputs: the states the plant interface reports and, with ``encoders``, the two channel
    levels of each of its encoders, then the code of each of its converters (ADCs,
    :mod:`pendc.passes.lower_sensors`). The interface rides along in the graph's ``info``.

    Two arithmetic choices shorten the critical chain of a step (docs/hardware.md, "What blocks
    100 ns per step"); both change the arithmetic, so the golden model, which follows the graph:

    * ``fold_dt``: the increment ``dt * s'`` is lowered as one sum of terms, so ``dt`` lands in
      the tables and gains of the derivative (``dp_inc = F*(dt T1)(q) + ...``) and no
      separate ``derivative x dt`` product sits between the sums and the integrator;
    * ``turns_phase``: ``period x turns``, subtracted from a periodic state for its tables'
      address, is a register loaded a step ahead (:meth:`ExpressionLowerer._whole_turns_register`), so
      the product leaves the path from the state to the tables;
    * ``deep_last``: every sum adds its terms in the order their values are ready
      (:meth:`ExpressionLowerer.term_depth`), so the friction loop's ``F_cart`` term passes one adder
      to the increment, not three;
    * ``narrow_abs``: ``|a|`` is taken of a cast of ``a`` (its own format, from its range): a
      wide state (a rate, 56 bits) is rounded once, before the negation, instead of by the
      negation, the select and the table address each;
    * ``lookahead`` (needs ``turns_phase``): every periodic table is a register loaded with its
      read for the next step (addressed by the next phase in turns: this step's phase, its
      increment and the turns gained, :meth:`ExpressionLowerer.read_ahead`), so the step starts
      with the tables of the angle, and only the cart's own loop (velocity ->
      friction table -> force -> increment) is left on the chain; a run started elsewhere than
      the reset state must start these registers at their tables' values too;
    * ``clamp_on_increment``: the velocity clamp compares the increment with the room left to
      the bound (``bound - state``, from the register at the start of the step) instead of the
      sum with the bound, so its compares run beside the state's wide sum, not after it;
    * ``sum_into_mux``: a sum whose last term is selected by muxes adds it in each branch
      (:func:`pendc.passes.lower_sums.push_sums_into_muxes`): the friction joins the force one
      adder after its table, with no negation and no zero test under ``dx != 0``.
    """
    eq = model.equations
    iface = model.interface
    if eq.delay is not None:
        name = next((n for n in model.effects if model.catalogue[n].kind == "delay"), "delay")
        raise PendcError(f"effect '{name}' (an input delay) has no hardware form yet (it needs a delay-line memory)")
    values = {s: sp.Float(v) for s, v in zip(eq.params, model.parameter_vector())}
    port = iface.input
    variables = {eq.input: port.name, **{s: s.name for s in eq.states}}
    if lookahead and not turns_phase:
        raise PendcError("lookahead tables need turns_phase (the next whole turns come from its register's input)")
    low = ExpressionLowerer(variables, iface, turns_phase=turns_phase, deep_last=deep_last, narrow_abs=narrow_abs,
                            lookahead=lookahead)
    low.nodes.append(make(port.name, Kind.INPUT, port=port.name, max_abs=port.full_scale, meaning=port.meaning))

    inlined: dict = {}
    assigned: dict = {}                  # symbol -> its expression (fold_dt lowers dt * it anew)
    for sym, expr in eq.assignments:
        expr = expr.subs(values).subs(inlined)
        assigned[sym] = expr
        low.depth[sym] = 1 + low.expr_depth(expr)
        free = expr.free_symbols
        if not free or (len(free) == 1 and free <= set(low.periodic)):
            inlined[sym] = expr          # constants and functions of one angle alone go into tables
            continue
        node = low.value(expr, sym.name, iface.meaning(sym.name))
        if node != sym.name and sym.name not in low.used_names:
            node = low.emit(Kind.CAST, [node], sym.name, iface.meaning(sym.name))
        low.variables[sym] = node
        low.memo[sym] = node

    nxt = {}
    increments = {}
    derivatives = [d.subs(values).subs(inlined) for d in eq.derivatives]
    for state, deriv in zip(eq.states, derivatives):
        spec = iface.state(state.name)
        if fold_dt:
            # the derivative's own node (if any) goes dead and fold_constants drops it
            inc = low.value(sp.expand(sp.Float(dt) * assigned.get(deriv, deriv)), f"{state.name}_inc",
                            f"{state.name} increment per step")
        else:
            d = low.value(deriv, f"d_{state.name}")
            inc = low.emit(Kind.GAIN, [d], f"{state.name}_inc", f"{state.name} increment per step", value=float(dt))
        increments[state.name] = inc
        total = low.emit(Kind.ADD, [state.name, inc], f"{state.name}_sum")
        if spec.velocity_bound is not None:
            total = _clamp(low, total, spec, (state.name, inc) if clamp_on_increment else None)
        nxt[state.name] = total
    low.read_ahead({s.name: assigned.get(d, d) for s, d in zip(eq.states, derivatives)}, dt)
    initial = {s.name: iface.state(s.name).initial for s in eq.states}
    declared = {s.name: s.capacity for s in iface.periodic if s.capacity is not None}
    regs = [make(s.name, Kind.REGISTER, [nxt[s.name]], reset=initial[s.name], meaning=iface.meaning(s.name, s.name),
                 **({"max_abs": declared[s.name]} if s.name in declared else {}))
            for s in eq.states]
    outputs = [(s, s) for s in iface.outputs]
    nodes = regs + low.nodes
    if encoders:
        for sensor in iface.sensors:
            if sensor.is_adc:
                continue
            enc_nodes, levels = lower_encoder(sensor.name, increments[sensor.state], sensor.band, sensor.body)
            nodes += enc_nodes
            outputs += [(channel, levels[key]) for channel, key in zip(sensor.channels, ("a", "b"))]
        offsets = model.sensor_offset_values()
        for sensor in iface.sensors:       # the converters' codes after the channels
            if sensor.is_adc:
                adc_nodes, code = lower_adc(sensor, nxt[sensor.state], iface.state(sensor.state).label,
                                            initial[sensor.state], offsets.get(sensor.state, 0.0))
                nodes += adc_nodes
                outputs.append((sensor.code_port, code))
    reached = {n.name for n in live_nodes(nodes, outputs)}
    unread = [s.name for s in eq.states if s.name not in reached]
    if unread:
        raise PendcError(f"{model.source or iface.name}: states.{unread[0]}: nothing reads it and it is not "
                         f"reported (output = false): report it, or leave it out of the file")
    if sum_into_mux:
        nodes = push_sums_into_muxes(nodes)
    if fold_dt or lookahead or sum_into_mux:   # the derivatives' own nodes (``ddx``), the tables' old
        # address, the muxes a sum was pushed through feed nothing now
        ahead = {name for name, *_ in low.ahead}       # a table register is live only if read
        nodes = live_nodes(nodes, outputs, keep=[n.name for n in nodes if n.kind is Kind.REGISTER
                                                 and n.name not in ahead])
    # which state each read-ahead register's table is read along (a run started from a state
    # fills them: pendc.golden.register_integers)
    ahead = tuple((name, spec.name, float(spec.period)) for name, spec, *_ in low.ahead)
    return Graph.build(iface.core, nodes, outputs,
                       info=(("dt", float(dt)), ("model", model.source), (INFO_KEY, iface), (READ_AHEAD_KEY, ahead)))


def _clamp(low: ExpressionLowerer, value: str, spec: StateSpec, step: tuple | None = None) -> str:
    """Velocity saturation after integration (thesis Fig. III.2): two compares, two muxes.
    With ``step`` = (state, increment) the compares are ``increment > bound - state`` and
    ``increment < -bound - state``: in real numbers the same tests as on the sum."""
    hi, lo = low.const(spec.velocity_bound), low.const(-spec.velocity_bound)
    if step is None:
        over = low.emit(Kind.COMPARE, [value, hi], f"{spec.name}_over", op=CompareOp.GT)
        under = low.emit(Kind.COMPARE, [value, lo], f"{spec.name}_under", op=CompareOp.LT)
    else:
        state, inc = step
        room_up = low.emit(Kind.SUB, [hi, state], f"{spec.name}_room_up", f"room to the upper bound ({spec.unit})")
        room_down = low.emit(Kind.SUB, [lo, state], f"{spec.name}_room_down", f"room to the lower bound ({spec.unit})")
        over = low.emit(Kind.COMPARE, [inc, room_up], f"{spec.name}_over", op=CompareOp.GT)
        under = low.emit(Kind.COMPARE, [inc, room_down], f"{spec.name}_under", op=CompareOp.LT)
    upper = low.emit(Kind.MUX, [over, value, hi], f"{spec.name}_upper")
    return low.emit(Kind.MUX, [under, upper, lo], f"{spec.name}_next", f"{spec.label} after the clamp ({spec.unit})")
