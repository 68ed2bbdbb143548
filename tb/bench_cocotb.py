"""cocotb side of bench/bench_verilator.py: the core under cocotb, Python out of the loop.

Reads ``$PENDC_BENCH_IN`` (JSON: ii, period_ns, chunk, u per chunk, per_step_steps) and
writes ``$PENDC_BENCH_OUT`` (JSON) with the wall time of

* ``timer``: step held high, ``u`` changed every ``chunk`` steps with one ``Timer`` await
  per chunk (how the regression's long runs go);
* ``per_step``: one ``Timer`` await per step, reading the four states each step (how the
  regression's every-step windows go).
"""

from __future__ import annotations

import json
import os
import time

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, Timer


@cocotb.test()
async def throughput(dut):
    with open(os.environ["PENDC_BENCH_IN"]) as fh:
        cfg = json.load(fh)
    ii, period, chunk = cfg["ii"], cfg["period_ns"], cfg["chunk"]
    mask = (1 << cfg["u_width"]) - 1
    dut.rst.value = 1
    dut.step.value = 0
    dut.u.value = 0
    Clock(dut.clk, period, unit="ns", impl="gpi").start(start_high=False)
    await FallingEdge(dut.clk)
    await Timer(3 * period, unit="ns")
    dut.rst.value = 0
    dut.step.value = 1
    t0 = time.perf_counter()
    for u in cfg["u"]:
        dut.u.value = int(u) & mask
        await Timer(chunk * ii * period, unit="ns")
    timer_s = time.perf_counter() - t0
    x_timer = dut.x.value.to_signed()
    n = cfg["per_step_steps"]
    states = (dut.x, dut.dx, dut.theta, dut.dtheta)
    t0 = time.perf_counter()
    for _ in range(n):
        _ = [h.value.to_signed() for h in states]
        await Timer(ii * period, unit="ns")
    per_step_s = time.perf_counter() - t0
    dut.step.value = 0
    with open(os.environ["PENDC_BENCH_OUT"], "w") as fh:
        json.dump({"timer": {"steps": len(cfg["u"]) * chunk, "wall_s": timer_s, "x_at_end": x_timer},
                   "per_step": {"steps": n, "wall_s": per_step_s}}, fh)
