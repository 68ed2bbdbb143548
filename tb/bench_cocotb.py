"""cocotb side of bench/bench_verilator.py: the core under cocotb, Python out of the loop.

Reads ``$PENDC_BENCH_IN`` (JSON: ii, period_ns, chunk, u per chunk, per_step_steps) and
writes ``$PENDC_BENCH_OUT`` (JSON) with the wall time of

* ``timer``: step held high, ``u`` changed every ``chunk`` steps with one ``Timer`` await
  per chunk (how the regression's long runs go);
* ``per_step``: one ``Timer`` await per step, reading every reported state each step (how the
  regression's every-step windows go).

The core's input and states are named by the plant interface of ``$PENDC_BENCH_MODEL`` (default:
the default model), the model whose core the benchmark built.
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
    from pendc import load_model
    from pendc.hil.plants.core_ports import CorePorts
    ports = CorePorts.of_interface(load_model(os.environ.get("PENDC_BENCH_MODEL")).interface)
    ii, period, chunk = cfg["ii"], cfg["period_ns"], cfg["chunk"]
    mask = (1 << cfg["u_width"]) - 1
    drive = getattr(dut, ports.input)
    dut.rst.value = 1
    dut.step.value = 0
    drive.value = 0
    Clock(dut.clk, period, unit="ns", impl="gpi").start(start_high=False)
    await FallingEdge(dut.clk)
    await Timer(3 * period, unit="ns")
    dut.rst.value = 0
    dut.step.value = 1
    t0 = time.perf_counter()
    for u in cfg["u"]:
        drive.value = int(u) & mask
        await Timer(chunk * ii * period, unit="ns")
    timer_s = time.perf_counter() - t0
    states = [getattr(dut, p) for p in ports.states]
    first_timer = states[0].value.to_signed()
    n = cfg["per_step_steps"]
    t0 = time.perf_counter()
    for _ in range(n):
        _ = [h.value.to_signed() for h in states]
        await Timer(ii * period, unit="ns")
    per_step_s = time.perf_counter() - t0
    dut.step.value = 0
    with open(os.environ["PENDC_BENCH_OUT"], "w") as fh:
        json.dump({"timer": {"steps": len(cfg["u"]) * chunk, "wall_s": timer_s, "first_state_at_end": first_timer},
                   "per_step": {"steps": n, "wall_s": per_step_s}}, fh)
