"""The compiler pipeline: every pass, in order, as plain calls in one function.

    lower -> fold constants -> eliminate common subexpressions -> ranges
          -> tabulate LUTs -> Q-formats -> fill tables -> error budget -> resources

The verifier runs between passes. Options come from :class:`BuildOptions`, which a
model file's ``[hardware]`` table can set (see :func:`options_from_model`). What the passes
know of the plant (states, input, encoders, error tolerances) is the model's plant interface
(:mod:`pendc.model.interface`), carried in the graph's ``info``; no pass names a state.
"""

from __future__ import annotations

import math

from dataclasses import dataclass, field, fields

from ..errors import PendcError
from ..ir.graph import Graph, GraphError
from ..ir.limits import MAX_LUT_ADDR_BITS
from ..ir.nodes import Kind
from ..ir.qformat import QFormat
from ..ir.verify import verify
from ..model.interface import PlantInterface
from ..model.plant import PlantModel
from ..model.modes import euler_instability
from ..sim.stimuli import Stimuli
from .eliminate_common import eliminate_common_subexpressions
from .error_budget import BudgetError, ErrorReport, meet_error_budget
from .fold_constants import fold_constants
from .lower import lower_model
from .narrow_products import narrow_products
from .qformats import MAX_LEVEL, MULT_SHAPES, assign_qformats, product_kinds
from .ranges import Ranges, analyze_ranges
from .reassociate import add_last_term_to_state
from .resources import Resources, estimate_resources
from .round_early import round_operands_early
from .tabulate import fill_lut_tables, tabulate_luts

MAX_DT = 0.01     # s: the longest core step (the float simulator's bound too)
# The model file spells a state's tolerance ``budget_<state> = ...`` in [hardware] (the older
# form), or ``[hardware.budget] <state> = ...``; both end in BuildOptions.budget.
BUDGET_ALIAS = "budget_"


@dataclass(frozen=True)
class BuildOptions:
    """Knobs of the hardware build. ``training_scale`` shortens the training stimuli
    (tests use it); ``ranges`` / ``qformats`` are per-node overrides."""

    dt: float = 1e-6
    width: int = 32
    margin_bits: int = 1
    lut_addr_bits: int = 10
    lut_margin: float = 0.125
    training_scale: float = 1.0
    check_seconds: float = 2.0
    # > 0: each state's LSB is at most 2 budget dt / hold_seconds, so an increment that would move
    # the state by its budget over that long is not lost to rounding (a slow plant near its
    # equilibrium, whose increments are far below its largest, creeps as its float twin does)
    hold_seconds: float = 0.0
    budget: dict = field(default_factory=dict)   # state -> allowed |fixed - float|; others: the interface's
    error_budget: bool = True
    target: str = "ecp5-85k"          # whose DSP shape the products are fitted to (qformats.MULT_SHAPES)
    fit_multipliers: bool = True      # False: the thesis' 32-bit rule for every product
    ranges: dict = field(default_factory=dict)
    qformats: dict = field(default_factory=dict)
    engine: str = "compiled"
    # a shorter critical chain of a step (pendc.passes.lower.lower_model: fold_dt, turns_phase,
    # deep_last, narrow_abs, lookahead, clamp_on_increment, sum_into_mux): dt folded into the
    # derivatives' tables and gains, the whole turns from a register, every sum's latest term added
    # last, |dx| rounded once, the angle's tables read a step ahead into registers, the velocity
    # clamp compared on the increment, a selected term added in each branch; a different arithmetic
    # (and golden model) from the default build's, held to the same error budget
    short_chain: bool = False
    # after the budget is met, the products it raised to two DSP blocks without needing them go
    # back to one (pendc.passes.narrow_products): fewer blocks and a shorter step, same budget
    narrow_products: bool = False

    def __getattr__(self, name: str):
        # Transitional, read-only: ``options.budget_<state>`` as before the plant interface (the
        # tolerance set in ``budget``, else the default model's). The file key is mapped by
        # :func:`options_from_model`; new code reads ``budgets_for``.
        if name.startswith(BUDGET_ALIAS) and "budget" in self.__dict__:
            state = name[len(BUDGET_ALIAS):]
            if state in self.budget:
                return self.budget[state]
            from ..model.modelfile import load_model
            default = load_model().interface.budgets()
            if state in default:
                return default[state]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def budgets_for(self, interface: PlantInterface) -> dict:
        """State -> error tolerance for a plant: the interface's, overridden by ``budget``.
        A state the plant does not report is a one-line PendcError."""
        reported = interface.outputs
        unknown = sorted(set(self.budget) - set(reported))
        if unknown:
            raise PendcError(f"[hardware] error budget for unknown state(s) {', '.join(unknown)} "
                             f"(the plant reports: {', '.join(reported)})")
        return {**interface.budgets(), **{k: float(v) for k, v in self.budget.items()}}


@dataclass(frozen=True)
class BuildResult:
    """Everything the compiler produced: the typed graph and the evidence behind it."""

    model: PlantModel
    options: BuildOptions
    untyped: Graph
    graph: Graph
    ranges: Ranges
    error: ErrorReport | None
    resources: Resources


# The arithmetic a schedule preset builds with (the CLI passes these to options_from_model): the
# step-time presets take the short-chain arithmetic; the others keep the default build's.
PRESET_OPTIONS = {"fast": {"short_chain": True}, "fmax": {"short_chain": True},
                  "thesis": {"short_chain": True, "narrow_products": True}}


def preset_options(preset: str | None) -> dict:
    """The BuildOptions overrides of a schedule preset (none for presets not in PRESET_OPTIONS)."""
    return dict(PRESET_OPTIONS.get(preset or "", {}))


def training_stimuli(inp, scale: float = 1.0) -> dict:
    """The range-analysis stimuli (swing-up-like, chirps, steps, full-scale random) on the input
    ``inp`` (an InputSpec), optionally shortened."""
    out = {}
    for name, (t, u) in Stimuli(inp).named().items():
        n = max(2, int(round(len(t) * scale)))
        out[name] = (t[:n], u[:n])
    return out


def core_step(model: PlantModel) -> float:
    """The step ``model``'s core integrates at: its plant file's ``[hardware] dt``, read as the
    build reads it (the build's default without one). Every plant that steps as the core does
    (float, golden, RTL; simulate, hil, robust) starts from this, so a golden plant always
    matches its build and a float one never silently takes the default instead."""
    return float(options_from_model(model).dt)


def options_from_model(model: PlantModel, **overrides) -> BuildOptions:
    """Build options from the model file's ``[hardware]`` table, then keyword overrides."""
    known = {f.name for f in fields(BuildOptions)}
    table = _budget_aliases(dict(getattr(model, "hardware", {}) or {}))
    unknown = set(table) - known
    if unknown:
        where = f"{model.source}: " if model.source else ""
        raise PendcError(f"{where}[hardware] has unknown option(s) {', '.join(sorted(unknown))} "
                         f"(known: {', '.join(sorted(known))})")
    try:   # the file's own values first, so a mistake there names the file
        validate_options(dict(table))
    except PendcError as exc:
        raise PendcError(f"{model.source}: {exc}" if model.source else str(exc)) from None
    extra = _budget_aliases({k: v for k, v in overrides.items() if v is not None})
    if isinstance(extra.get("budget"), dict) and isinstance(table.get("budget"), dict):
        extra["budget"] = {**table["budget"], **extra["budget"]}     # an override adds to the file's
    table.update(extra)
    unknown = set(table) - known
    if unknown:
        raise PendcError(f"bad [hardware] option(s) {', '.join(sorted(unknown))}")
    # the budget's state names are checked against the plant by compile_model (budgets_for): here
    # they would cost the equations' derivation on every build-cache hit
    return validate_options(table)


def _budget_aliases(table: dict) -> dict:
    """``table`` with every ``budget_<state>`` key moved into its ``budget`` table; a state
    given both ways is a one-line PendcError."""
    aliased = {k[len(BUDGET_ALIAS):]: v for k, v in table.items() if k.startswith(BUDGET_ALIAS)}
    if not aliased:
        return table
    out = {k: v for k, v in table.items() if not k.startswith(BUDGET_ALIAS)}
    given = out.get("budget", {})
    if not isinstance(given, dict):
        raise PendcError(f"[hardware] budget must be a table of state = tolerance, got {given!r}")
    twice = sorted(set(aliased) & set(given))
    if twice:
        raise PendcError(f"[hardware] error budget of {', '.join(twice)} given twice "
                         f"({BUDGET_ALIAS}<state> and [hardware.budget])")
    out["budget"] = {**given, **aliased}
    return out


def validate_options(values) -> BuildOptions:
    """Check option types and override values; one-line PendcError on the first bad one."""
    table = dict(values.__dict__) if isinstance(values, BuildOptions) else _budget_aliases(dict(values))
    defaults = BuildOptions()
    for key, value in table.items():
        expected = type(getattr(defaults, key))
        ok = isinstance(value, expected) and not (expected is int and isinstance(value, bool))
        if expected is float and isinstance(value, int) and not isinstance(value, bool):
            table[key], ok = float(value), True
        if not ok:
            article = "an" if expected.__name__[0] in "aeiou" else "a"
            raise PendcError(f"[hardware] {key} must be {article} {expected.__name__}, got {value!r}")
    addr_bits = table.get("lut_addr_bits", defaults.lut_addr_bits)
    if not 1 <= addr_bits <= MAX_LUT_ADDR_BITS:
        raise PendcError(f"[hardware] lut_addr_bits must be 1..{MAX_LUT_ADDR_BITS} (a table of 2**n segments), "
                         f"got {addr_bits}")
    if table.get("target", defaults.target) not in MULT_SHAPES:
        raise PendcError(f"[hardware] target must be one of {', '.join(MULT_SHAPES)}, got {table['target']!r}")
    dt = table.get("dt", defaults.dt)
    if not (math.isfinite(dt) and 0 < dt <= MAX_DT):        # Euler's growth divides by it; a nan passed every test
        raise PendcError(f"[hardware] dt must be a step in (0, {MAX_DT:g}] s, got {dt!r}")
    if table.get("hold_seconds", 0.0) < 0:
        raise PendcError(f"[hardware] hold_seconds must be 0 (off) or positive, got {table['hold_seconds']!r}")
    for state, value in table.get("budget", {}).items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
            raise PendcError(f"[hardware.budget] {state} must be a positive number (allowed |fixed - float|), "
                             f"got {value!r}")
    for node, value in table.get("ranges", {}).items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
            raise PendcError(f"[hardware.ranges] {node} must be a positive number (max |value|), got {value!r}")
    for node, value in table.get("qformats", {}).items():
        try:
            QFormat.parse(str(value))
        except ValueError as exc:
            raise PendcError(f"[hardware.qformats] {node}: {exc}") from None
    checked = BuildOptions(**table)
    return values if checked == values else checked


def _checked(graph: Graph, stage: str, typed: bool = False) -> Graph:
    try:
        verify(graph, typed=typed)
    except GraphError as exc:
        raise PendcError(f"internal compiler error after {stage}: {exc}") from None
    return graph


def compile_model(model: PlantModel, options: BuildOptions | None = None) -> BuildResult:
    """Run every pass on ``model`` and return the typed graph with ranges, error and resources.
    A build that fails because the core's forward Euler step makes the plant diverge says so."""
    opt = validate_options(options) if options is not None else options_from_model(model)
    try:
        return _compile(model, opt)
    except PendcError:
        words = euler_instability(model, opt.dt)
        if words:
            raise PendcError(f"{model.source or model.name}: [hardware] dt: {words}") from None
        raise


def check_hardware_names(model: PlantModel, opt: BuildOptions | None = None) -> Graph:
    """The untyped graph the passes start from, after checking that the states and nodes the
    options name (budgets, range and Q-format overrides) are the plant's: ``pendc plant check``
    says so before a build, in one line naming the file."""
    opt = opt or options_from_model(model)
    try:
        opt.budgets_for(model.interface)
        graph = _untyped(model, opt)
        _require_nodes(graph, opt.ranges, "range")
        _require_nodes(graph, opt.qformats, "Q-format")
    except PendcError as exc:
        if model.source and str(exc).startswith("[hardware"):
            raise PendcError(f"{model.source}: {exc}") from None
        raise
    return graph


def _untyped(model: PlantModel, opt: BuildOptions) -> Graph:
    short = opt.short_chain
    graph = _checked(lower_model(model, dt=opt.dt, fold_dt=short, turns_phase=short, deep_last=short,
                                 narrow_abs=short, lookahead=short, clamp_on_increment=short,
                                 sum_into_mux=short), "lower_model")
    graph = _checked(fold_constants(graph), "fold_constants")
    return _checked(eliminate_common_subexpressions(graph), "eliminate_common_subexpressions")


def _compile(model: PlantModel, opt: BuildOptions) -> BuildResult:
    graph = untyped = check_hardware_names(model, opt)
    budgets = opt.budgets_for(model.interface)
    ranges = analyze_ranges(graph, training_stimuli(model.interface.input, opt.training_scale), opt.dt, overrides=opt.ranges,
                            engine=opt.engine, hold=opt.hold_seconds)
    graph = _checked(tabulate_luts(graph, ranges, margin=opt.lut_margin, addr_bits=opt.lut_addr_bits),
                     "tabulate_luts")

    shape = MULT_SHAPES[opt.target] if opt.fit_multipliers else None
    products = tuple(n.name for n in graph.of_kind(*product_kinds())
                     if n.name not in opt.qformats) if shape else ()

    ceilings = {s: 2.0 * b * opt.dt / opt.hold_seconds for s, b in budgets.items()} if opt.hold_seconds else {}

    def typed(widen: dict, addr_bits: dict, levels: dict | None = None) -> Graph:
        g = graph.map_nodes(lambda n: n.with_params(addr_bits=addr_bits[n.name]) if n.name in addr_bits else n)
        g = tabulate_luts(g, ranges, margin=opt.lut_margin) if addr_bits else g
        g = assign_qformats(g, ranges, width=opt.width, margin_bits=opt.margin_bits,
                            overrides=opt.qformats, widen=widen, shape=shape, lsb_ceiling=ceilings,
                            levels=levels if levels is not None else {p: MAX_LEVEL for p in products})
        if opt.short_chain:     # the same numbers: roundings off the sums, the last term onto the state
            g = add_last_term_to_state(round_operands_early(g))
        return _checked(fill_lut_tables(g), "assign_qformats/fill_lut_tables", typed=True)

    if opt.error_budget:
        seconds = min(opt.check_seconds, 5.0 * opt.training_scale)  # never check beyond what trained the ranges
        try:
            final, error = meet_error_budget(typed, budgets, opt.dt, seconds, engine=opt.engine, products=products,
                                             max_level=MAX_LEVEL)
            if opt.narrow_products and products:
                grown = {n.name: error.addr_bits[n.name] for n in graph.of_kind(Kind.LUT)
                         if error.addr_bits.get(n.name, n.params.addr_bits) != n.params.addr_bits}
                final, error = narrow_products(typed, final, error, budgets, opt.dt, seconds, shape, opt.engine, grown)
        except BudgetError as exc:
            raise PendcError(str(exc)) from None
    else:
        final, error = typed({}, {}), None
    return BuildResult(model=model, options=opt, untyped=untyped, graph=_checked(final, "error budget", True),
                       ranges=ranges, error=error, resources=estimate_resources(final, shape or MULT_SHAPES[opt.target]))


def _require_nodes(graph: Graph, table: dict, what: str) -> None:
    unknown = sorted(set(table) - set(graph.by_name))
    if unknown:
        import difflib
        named = [n.name for n in graph.nodes]
        near = sorted({m for u in unknown for m in difflib.get_close_matches(u, named, 3, 0.6)})
        hint = f" (nearest: {', '.join(near)})" if near else ""
        raise PendcError(f"[hardware] {what} override names unknown node(s) {', '.join(unknown)}{hint}; a state X "
                         f"is node X, its increment per step X_inc (and its derivative d_X unless the file names "
                         f"it); 'pendc report qformat' lists every node")
