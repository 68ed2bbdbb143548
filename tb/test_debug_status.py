"""cocotb test of a debug build's per-node overflow status, over the bus (RAPTOR or AXI4-Lite).

Toplevel: the debug build's wrapper (``pendulum_raptor`` or ``pendulum_axil``). Vectors
(``$PENDC_TB_VECTORS``, written by tests/test_sim_debug_status.py): a golden state a little
before the cart leaves x's format under a full push (deposited into the core after reset), the
step ``k_star`` at which the golden model raises :class:`pendc.golden.OverflowStop` and the
node(s) it names there. Through the registers: a lockstep burst of ``k_star`` steps leaves
every OVERFLOW_STATUS bit and OVERFLOW clear; one more step sets exactly the bits of those
nodes (and OVERFLOW); SOFT_RESET clears them all.
"""

from __future__ import annotations

import cocotb

from bus_drivers import SOFT_RESET, STEP, _bus
from simlib import vectors


async def _status(b) -> set:
    """The nodes whose OVERFLOW_STATUS bit is set, read word by word over the bus."""
    nodes = vectors()["status_nodes"]
    high = set()
    for k in range((len(nodes) + 31) // 32):
        word = await b.read(f"OVERFLOW_STATUS_{k}")
        high |= {nodes[32 * k + i] for i in range(32) if word >> i & 1}
        assert word >> min(32, len(nodes) - 32 * k) == 0, f"OVERFLOW_STATUS_{k}: bits beyond the last node set"
    return high


@cocotb.test()
async def status_names_the_golden_node_at_its_step(dut):
    """Clear through k_star steps; exactly the golden model's node(s) after step k_star."""
    v = vectors()
    b = await _bus(dut)
    assert await _status(b) == set() and await b.read("OVERFLOW") == 0
    b.deposit(v["deposit"])
    await b.cycles(1)
    await b.write(b.input_reg, v["u"])
    k_star = v["k_star"]
    if k_star:
        await b.burst(k_star)
    assert await b.read64(b.state_regs[0]) == v["x_before"], "the deposited state did not run as the golden model"
    assert await _status(b) == set(), f"status bits set before step {k_star}: {sorted(await _status(b))}"
    assert await b.read("OVERFLOW") == 0
    await b.write("CONTROL", STEP)
    await b.wait_idle(1, "single step")
    got = await _status(b)
    assert got == set(v["nodes"]), f"after step {k_star} the status names {sorted(got)}, the golden model {v['nodes']}"
    assert await b.read("OVERFLOW") & 2, "OVERFLOW.CORE is low with status bits set"
    dut._log.info("%s: step %d sets exactly %s, as the golden model names", b.bus, k_star, sorted(got))
    await b.write("CONTROL", SOFT_RESET)
    assert await _status(b) == set(), "SOFT_RESET leaves status bits set"
