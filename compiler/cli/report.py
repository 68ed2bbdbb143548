"""``pendc report``: reports on a compiled model (Q-formats with their evidence, resources, and
error drift) and ``report synth`` on a build folder.

Each report is a plain dict (what ``--json`` prints) plus a text rendering of it. The compiler's
modules are imported where a report is made: every command line builds this module's parser, and
``pendc --help`` should not wait for the compiler.
"""

from __future__ import annotations

import json
import re
import sys
from typing import TYPE_CHECKING

from .heldout import format_budget, held_out_check
from ..model.interface import with_unit
from .options import MODEL_HELP, build_model, positive

if TYPE_CHECKING:
    from ..passes.pipeline import BuildResult

DRIFT_TIMES = (1.0, 2.0, 5.0, 10.0, 20.0)


def _unit(meaning: str) -> str:
    """The unit a node's meaning ends with, "(m/s^2)"; not "(F_in)" nor a word that is no unit
    ("(Torricelli)", "(L1)": a tank file's own words, printed as units)."""
    from ..errors import PendcError
    from ..model.units import parse_unit

    m = re.search(r"\(([A-Za-z/^*0-9.]+)\)\s*$", meaning or "")
    if not m:
        return ""
    try:
        parse_unit(m.group(1), "meaning")
    except PendcError:
        return ""
    return m.group(1)


def qformat_report(build: BuildResult) -> dict:
    """Per node: meaning, simulated max, a published design's max/format where the plant file
    gives one (``[reference_formats]``), chosen format, LSB in physical units and max |error|
    against float on the check stimuli."""
    from ..ir.nodes import Kind
    from ..model.reference_formats import FIX
    from ..passes.qformats import thesis_format

    g = build.graph
    definition = build.model.definition
    reference = definition.reference_formats
    errors = build.error.node_errors if build.error else {}
    iface = build.model.interface
    declared = {name: unit for name, _, unit, _ in definition.intermediates if unit}
    declared.update({st.name: st.unit for st in iface.states})
    declared.update({i.name: i.unit for i in iface.inputs})
    nodes = []
    for n in g.nodes:
        if n.kind is Kind.CONST:
            continue
        row = {
            "name": n.name, "kind": n.kind.value, "meaning": n.meaning,
            "max": build.ranges.max_abs.get(n.name), "format": str(n.qformat),
            "lsb": n.qformat.lsb, "unit": declared.get(n.name) or _unit(n.meaning),
            "error_vs_float": errors.get(n.name),
        }
        if n.name in reference:
            row["reference"] = reference[n.name]
        nodes.append(row)
    rule_check = {name: {"reference_max": t["max"], "reference_format": t["format"],
                         "rule_gives": str(thesis_format(t["max"], int(FIX.match(t["format"]).group(1))))}
                  for name, t in reference.items() if "max" in t}
    return {
        "rules": "constants >= 32 bits; i = ceil(log2(max|v|)) + 1 (signed); fraction = width - i; "
                 f"margin {build.options.margin_bits} bit(s) above the simulated maximum",
        "reference_source": definition.reference_source,
        "reference_rule_check": rule_check,
        "training": list(build.ranges.sources),
        "error_budget": build.error.to_json() if build.error else None,
        "nodes": nodes,
    }


def format_qformat_report(report: dict) -> str:
    lines = ["Q-format assignment (" + report["rules"] + ")", ""]
    source = report.get("reference_source") or "a published design"
    lines.append(f"The sizing rule on the published maxima ({source}):")
    if not report["reference_rule_check"]:
        lines.append("  (none: the plant file gives no published formats with maxima, [reference_formats])")
    for name, r in report["reference_rule_check"].items():
        ok = "ok" if r["rule_gives"] == r["reference_format"] else "DIFFERS"
        lines.append(f"  {name:8s} max {r['reference_max']:>8g} -> {r['rule_gives']} "
                     f"(published {r['reference_format']}) {ok}")
    lines.append("")
    header = f"{'node':28s} {'kind':5s} {'sim. max':>11s} {'published':>19s} {'format':>9s} {'LSB':>10s} {'unit':8s} {'err vs float':>12s}  meaning"
    lines += [header, "-" * len(header)]
    for r in report["nodes"]:
        th = r.get("reference", {})
        published = (f"{th.get('max', ''):>8} {th.get('format', '')}" if th else "").strip()
        err = "" if r["error_vs_float"] is None else f"{r['error_vs_float']:.3g}"
        mx = "" if r["max"] is None else f"{r['max']:.5g}"
        lines.append(f"{r['name']:28s} {r['kind']:5s} {mx:>11s} {published:>19s} {r['format']:>9s} "
                     f"{r['lsb']:>10.3g} {r['unit']:8s} {err:>12s}  {r['meaning']}")
    lines += format_budget(report["error_budget"], report.get("held_out"))
    if report.get("drift"):
        lines += ["", "Drift after the budget horizon (max |fixed - float| up to t):"]
        for stim, rows in report["drift"].items():
            lines.append(f"  {stim:10s} " + "  ".join(f"t<={r['t']:g}s " + ", ".join(
                f"{k} {with_unit(f'{v:.3g}', u)}" for k, u in r["units"].items() for v in (r[k],))
                                                    for r in rows))
    return "\n".join(lines) + "\n"


def drift_report(build: BuildResult, stimuli: dict) -> dict:
    """Max |fixed - float| of every encoder-read state (the plant interface's) up to each of
    DRIFT_TIMES, per stimulus (full length): rows ``{"t": limit, <state>: error..., "units": {state: unit}}``."""
    import numpy as np

    from ..golden import GoldenModel
    from ..model.interface import require_interface
    from ..sim.simulator import Simulator
    iface = require_interface(build.graph)
    measured = [s.state for s in iface.sensors]
    units = {s: iface.state(s).unit for s in measured}
    golden = GoldenModel(build.graph, build.options.dt)
    sim = Simulator(build.model, dt=build.options.dt)
    out = {}
    for name, (t, u) in stimuli.items():
        g = golden(t, u).result
        f = sim(t, u)
        rows = []
        for limit in DRIFT_TIMES:
            mask = t <= limit + 1e-9
            if limit > t[-1] + 1e-9:
                break
            rows.append({"t": limit, **{s: float(np.max(np.abs(g[s][mask] - f[s][mask]))) for s in measured},
                         "units": units})
        out[name] = rows
    return out


def resources_report(build: BuildResult, request: dict | None = None) -> dict:
    """The resource estimate, with per product the operand widths it got and why, and the DSP
    blocks of the schedule ``request`` (default: the default preset) once products share units."""
    from ..backend.hdl import schedule_of
    from ..passes.qformats import MULT_SHAPES
    from ..passes.resources import schedule_lut4
    from ..passes.share import scheduled_blocks
    out = build.resources.to_json()
    sched = schedule_of(build.graph, dict(request or {}, target=build.options.target))
    shape = MULT_SHAPES[build.options.target]
    out["schedule"] = {"preset": sched.preset or None, "ii": sched.ii, "units": len(sched.units)}
    out["dsp_scheduled"] = scheduled_blocks(build.graph, sched, shape) if sched.units else out["dsp"]
    extra = schedule_lut4(sched.to_json())
    out["lut4_scheduled"] = out["lut4_est"] + extra["lut4"]
    out["schedule"].update(estimated_period_ns=sched.estimated_period_ns, estimated_step_ns=sched.estimated_step_ns)
    out["notes"] = ["DSP blocks: products of the schedule share multiplier units when a multiplier per product "
                    "exceeds the budget (dsp_scheduled); 'dsp' is one multiplier per product",
                    f"LUT4s: lut4_est is the graph's arithmetic; lut4_scheduled adds the schedule's shared-multiplier "
                    f"operand muxes ({extra['unit_mux']}) and phase logic ({extra['phase']}); pipeline registers "
                    f"cost flip-flops only. Checked against Yosys synth_ecp5 (docs/hardware.md): within 20 % for "
                    f"the presets of the default model",
                    "iCE40/Xilinx: the same LUT4 count is a 4-input-LUT figure; synth_xilinx packs LUT6s, so "
                    "its LUT count is lower (no calibration for it)"]
    levels = (build.error.levels if build.error else None) or {}
    opt = build.options
    from ..model.interface import graph_interface
    iface = graph_interface(build.graph)
    budgeted = " or ".join(iface.budgets()) if iface is not None else "a budgeted state"
    why_off = ("multiplier fitting off (fit_multipliers = false): the thesis' 32-bit rule"
               if not opt.fit_multipliers else "no error budget to decide (error_budget = false): the thesis' 32-bit rule")
    for row in out.get("products", []):
        node = row["node"]
        if node in opt.qformats:
            row["level"], row["why"] = None, "format given in [hardware.qformats]"
        elif node not in levels:
            row["level"], row["why"] = None, why_off
        elif levels[node] == 0:
            row["level"], row["why"] = 0, f"fits one {out['dsp_shape']} DSP block and the error budget holds"
        else:
            row["level"] = levels[node]
            row["why"] = (f"widened {levels[node]} level(s) by the error budget: with one block "
                          f"{budgeted} missed its budget, and this product's own rounding was among the "
                          f"largest relative errors")
    return out


def format_resources_report(r: dict) -> str:
    lines = ["Resource estimate (from the typed graph, before synthesis)", ""]
    lines.append("multipliers (operand widths):")
    for k, v in r["multipliers"].items():
        lines.append(f"  {k:>8s} x {v}")
    rows = [(f"DSP blocks {r.get('dsp_shape', '18x18')} (est.)", r.get("dsp", r["dsp18"])),
            ("DSP blocks, scheduled", f"{r.get('dsp_scheduled', '')} (preset {r.get('schedule', {}).get('preset')}, "
                                      f"ii {r.get('schedule', {}).get('ii')}, estimated step "
                                      f"{r.get('schedule', {}).get('estimated_step_ns')} ns)"),
            # in 18x18 blocks too, where the target's multiplier has another shape (the same number twice otherwise)
            *([("18x18 DSP blocks (est.)", r["dsp18"])] if r.get("dsp_shape", "18x18") != "18x18" else []),
            ("tables", r["luts"]), ("table bits", r["lut_bits"]),
            ("36-kbit block RAMs", r["brams"]), ("16-kbit block RAMs (ECP5)", r.get("bram16", "")),
            ("LUT4s (fabric arithmetic)", r.get("lut4_est", "")),
            ("LUT4s with the schedule", r.get("lut4_scheduled", "")), ("carry cells", r.get("carry_est", "")),
            ("register bits", r["register_bits"]),
            ("adders/subtractors", f"{r['adders']} ({r['adder_bits']} bits)"), ("muxes", r["muxes"]),
            ("comparators", r["comparators"]), ("logic depth (nodes)", r["logic_depth"])]
    lines += [f"{k:26s} {v}" for k, v in rows]
    lines.append("critical path: " + " -> ".join(r["critical_path"]))
    for note in r.get("notes", []):
        lines.append(f"note: {note}")
    if r.get("products"):
        lines += ["", f"products ({r['dsp']} DSP blocks of {r['dsp_shape']}, the target's multiplier):"]
        for p in r["products"]:
            lines.append(f"  {p['node']:28s} {p['kind']:5s} {p['widths']:>7s} {p['dsp']} block(s)  {p.get('why', '')}")
    return "\n".join(lines) + "\n"


def _emit_json(obj) -> None:
    json.dump(obj, sys.stdout, indent=2, sort_keys=False)
    sys.stdout.write("\n")


def cmd_report(args) -> int:
    from ..model.modelfile import load_model

    if args.what == "synth":
        from ..synth.flow import format_synth_report, synthesize
        result = synthesize(args.build_dir, args.target, freq_mhz=args.freq, use_cache=not args.no_cache,
                            log=lambda text: print(f"pendc: {text}", file=sys.stderr))
        if args.json:
            _emit_json(result.to_json())
        else:
            sys.stdout.write(format_synth_report(result))
        return 0
    model = load_model(args.model)
    build = build_model(model, args)
    if args.what == "qformat":
        report = qformat_report(build)
        if build.error is not None:         # the budget on inputs it was not tuned on (cli/heldout.py)
            report["held_out"] = held_out_check(build)
        if args.drift:
            from ..sim.stimuli import Stimuli
            on = Stimuli(model.interface.input)
            report["drift"] = drift_report(build, {"chirp": on.chirp(), "swing_up": on.swing_up()})
        text = format_qformat_report(report)
    else:
        report = resources_report(build)
        text = format_resources_report(report)
    if args.json:
        _emit_json(report)
    else:
        sys.stdout.write(text)
    return 0


def add_parsers(sub) -> None:
    """``report qformat|resources|synth``: a sub-parser per kind, so each takes (and its --help
    lists) only the options that mean something for it."""
    p = sub.add_parser("report", help="reports on the compiled model: qformat, resources, or synth "
                       "(Yosys + nextpnr on a build folder)",
                       description="Reports on the compiled model. Each kind takes its own options: "
                                   "pendc report KIND --help.")
    kinds = p.add_subparsers(dest="what", metavar="KIND", required=True)  # a _Parser, like `p`
    q = kinds.add_parser("qformat", help="per signal its range, chosen Q-format and error against float")
    r = kinds.add_parser("resources", help="the resource estimate and DSP blocks per product")
    s = kinds.add_parser("synth", help="Yosys + nextpnr on a `pendc build` output folder (--build-dir)")
    for k in (q, r):
        k.add_argument("--model", help=MODEL_HELP)
        k.add_argument("--target", choices=("ecp5-85k", "ice40-up5k", "xc7"),
                       help="FPGA whose multiplier shape the formats fit (default ecp5-85k: 18x18)")
        k.add_argument("--json", action="store_true", help="machine-readable output")
        k.add_argument("--no-cache", action="store_true", help="recompile even if a cached build exists")
    q.add_argument("--drift", action="store_true", help="also measure fixed-vs-float drift on the full 20 s chirp "
                   "and 5 s swing-up")
    s.add_argument("--build-dir", default="hdl_out", help="the `pendc build` output folder (default hdl_out)")
    from ..synth.targets import TARGETS
    s.add_argument("--target", choices=tuple(TARGETS), default="ecp5-85k",
                   help="FPGA target (default ecp5-85k: LFE5U-85F speed 6; xc7: Yosys counts only; "
                        "docs/hardware.md lists them)")
    s.add_argument("--freq", type=positive, default=100.0, help="clock goal for nextpnr in MHz (default 100)")
    s.add_argument("--json", action="store_true", help="machine-readable output: target, top, ii, fmax_mhz, "
                   "step_ns, lut, ff, carry, dsp, bram, logic_depth, critical_path, cells, estimate, thesis")
    s.add_argument("--no-cache", action="store_true", help="run Yosys and nextpnr even if a cached result exists")
    p.set_defaults(func=cmd_report)
