"""cocotb regression of the bus wrappers: ``pendulum_raptor`` (RAPTOR 2000 local bus) and
``pendulum_axil`` (AXI4-Lite, driven by cocotbext-axi's AxiLiteMaster).

The same tests run on both; the bus is chosen by the toplevel (``$PENDC_TB_BUS``
says which HDL folder the runner built). Register offsets come from report.json
("registers"), expectations from the golden vectors (``$PENDC_TB_VECTORS``).

* ``reset_values``: every register after reset, and the map holds exactly the plant's
  registers (``ENC`` and the counts only with encoders, a code word per converter);
* ``read_write``: every writable register reads back what was written (STEP_DIV clamped
  to ii, U sign-extended), pulse bits read 0, writes to read-only registers change nothing;
* ``unmapped``: every unmapped word reads 0, writing it changes no register; address
  bits 1..0 are ignored (RAPTOR only: the AXI master library aligns word accesses);
* ``lockstep``: bursts of N steps with a constant U (and a single STEP) are bit-exact
  against the golden model after every burst, as are the encoder lines and the x4
  counts; STEPS_LEFT counts down, a LOCKSTEP while BUSY is ignored;
* ``free_run``: RUN at STEP_DIV = ii and ii + 3: step counter as expected, state bit-exact
  for the number of steps counted;
* ``soft_and_hard_reset``: SOFT_RESET mid-run clears state, counters and RUN and keeps
  U/STEP_DIV/N_STEPS; the reset pin mid-run restores every register;
* ``step_counter``: 64-bit step counter carries into STEP_COUNT_HI, LO reads latch HI;
* ``overflow_flags``: from the overflow scenario's golden state (just before the full push
  overflows, or near the edge of a state's range: deposited into the core), OVERFLOW.CORE/STICKY
  and STATUS.OVERFLOW rise, STICKY is write-1-to-clear, SOFT_RESET clears both; skipped, saying
  why, for a plant that nothing drives out of range.
"""

from __future__ import annotations

import cocotb
from cocotb.triggers import FallingEdge

from simlib import diff_text, overflow_scenario, vectors

from bus_drivers import (LOCKSTEP, MAGIC, RUN, SOFT_RESET, ST_BUSY, ST_OVERFLOW, ST_RUNNING, STEP,  # noqa: F401
                         AxilBus, Bus, RaptorBus, _bus, _mask)


def _row(run: dict, k: int) -> tuple:
    return tuple(int(x) for x in run["rows"][k])


def _same(got: tuple, want: tuple, what: str):
    """Raise with the differing ports named unless the register read-back ``got`` equals golden ``want``."""
    if got != want:
        raise AssertionError(f"{what}: " + diff_text(got, want))


def _expected_reset(b: Bus) -> dict:
    """Every register's value right after reset."""
    from pendc.backend.wrapper import VERSION
    v = b.v
    row0 = _row(v["bus"]["u_pos"], 0)
    u = v["ports"][v["core_ports"].input]
    n_states = len(b.state_regs)
    exp = {"ID": MAGIC, "VERSION": VERSION, "BUILD_ID": int(b.report["build_id"], 16),
           "CONFIG": (b.ii & 0xFF) | ((u["width"] & 0xFF) << 8) | ((u["frac"] & 0xFF) << 16),
           "CONTROL": 0, "STATUS": 0, "STEP_DIV": b.ii, "N_STEPS": 0, "STEPS_LEFT": 0, b.input_reg: 0,
           "OVERFLOW": 0, "STEP_COUNT_LO": 0, "STEP_COUNT_HI": 0}
    if b.channels:
        exp["ENC"] = sum(row0[n_states + i] << i for i in range(b.channels))
    exp.update({r: 0 for r in b.count_regs})
    first_code = n_states + b.channels          # a converter's code register holds its reset code
    exp.update({r: row0[first_code + i] >> frac for i, (r, frac) in enumerate(b.code_regs)})
    for i, r in enumerate(b.state_regs):
        exp[f"{r}_LO"] = row0[i] & 0xFFFFFFFF
        # a snapshot register, latched by the LO read just before it (_check_all reads in offset
        # order): the upper word of the sign-extended state (nonzero for a large or negative reset)
        exp[f"{r}_HI"] = (row0[i] >> 32) & 0xFFFFFFFF
    missing = set(b.regs) - set(exp)
    assert not missing, f"registers without an expected reset value in the test: {sorted(missing)}"
    absent = set(exp) - set(b.regs)         # the map holds what the plant has (ENC only with an encoder)
    assert not absent, f"registers of this plant missing from the map: {sorted(absent)}"
    return exp


async def _check_all(b: Bus, exp: dict, what: str):
    """Read every register in offset order (a _LO word before its _HI word) against ``exp``."""
    bad = []
    for name in sorted(b.regs, key=lambda n: b.regs[n]["offset"]):
        got = await b.read(name)
        if got != exp[name]:
            bad.append(f"{name} (0x{b.addr(name):02x}) = 0x{got:08x}, want 0x{exp[name]:08x}")
    assert not bad, f"{what}: " + "; ".join(bad)


@cocotb.test()
async def reset_values(dut):
    b = await _bus(dut)
    # the snapshot registers read 0 until their LO word is read
    his = {f"{r}_HI": await b.read(f"{r}_HI") for r in b.state_regs + ["STEP_COUNT"]}
    assert not any(his.values()), f"_HI words before any _LO read: {his}"
    await _check_all(b, _expected_reset(b), "after reset")
    # a LO read latches HI: the 64-bit read of a state is the reset state
    assert await b.read64(b.state_regs[0]) == _row(b.v["bus"]["u_pos"], 0)[0]


@cocotb.test()
async def read_write(dut):
    b = await _bus(dut)
    exp = _expected_reset(b)
    uw = b.v["ports"][b.v["core_ports"].input]["width"]
    patterns = (0xFFFFFFFF, 0xA5A5A5A5, 0x5A5A5A5A, 0x00000001, 0x80000000, 0)
    for name in ("N_STEPS", b.input_reg, "STEP_DIV"):
        for p in patterns:
            await b.write(name, p)
            got = await b.read(name)
            if name == b.input_reg:
                low = p & _mask(uw)
                want = (low - (1 << uw) if low >> (uw - 1) else low) & 0xFFFFFFFF   # sign-extended
            elif name == "STEP_DIV":
                want = max(p, b.ii)
            else:
                want = p
            assert got == want, f"{name}: wrote 0x{p:08x}, read 0x{got:08x}, want 0x{want:08x}"
    for name, value in (("STEP_DIV", b.ii - 1), ("STEP_DIV", b.ii), ("STEP_DIV", b.ii + 1)):
        await b.write(name, value)
        assert await b.read(name) == max(value, b.ii), f"STEP_DIV {value} not clamped to ii = {b.ii}"
    # RUN reads back and shows in STATUS; the pulse bits read 0
    await b.write("CONTROL", RUN)
    assert await b.read("CONTROL") == RUN
    assert (await b.read("STATUS")) & ST_RUNNING
    await b.write("CONTROL", 0)
    assert await b.read("CONTROL") == 0
    assert not (await b.read("STATUS")) & ST_RUNNING
    await b.hw_reset()
    # writes to read-only registers change nothing (checked on the whole map)
    for name, r in b.regs.items():
        if r["access"] == "ro":
            await b.write(name, 0xFFFFFFFF)
    await _check_all(b, exp, "after writing all ones to every read-only register")


@cocotb.test()
async def unmapped(dut):
    b = await _bus(dut)
    exp = _expected_reset(b)
    mapped = {r["offset"] for r in b.regs.values()}
    words = 1 << (8 - 2)
    free = [4 * w for w in range(words) if 4 * w not in mapped]
    assert free, "no unmapped address to test"
    for a in free:
        assert await b.read(a) == 0, f"unmapped 0x{a:02x} does not read 0"
        await b.write(a, 0xFFFFFFFF)
    await _check_all(b, exp, "after writing all ones to every unmapped word")
    for a in free:
        assert await b.read(a) == 0, f"unmapped 0x{a:02x} reads non-zero after a write"
    if isinstance(b, AxilBus):
        return      # AxiLiteMaster turns an unaligned word access into byte lanes of the aligned word
    # bits 1..0 of the byte address are ignored
    for low in (1, 2, 3):
        assert await b.read(b.addr("ID") + low) == MAGIC
    await b.write(b.addr("N_STEPS") + 3, 1234)
    assert await b.read("N_STEPS") == 1234


@cocotb.test()
async def lockstep(dut):
    b = await _bus(dut)
    run = b.v["bus"]["u_pos"]
    k = 0
    steps = [("STEP", 1), ("LOCKSTEP", 7), ("LOCKSTEP", 100), ("LOCKSTEP", 1), ("LOCKSTEP", 2500)]
    await b.write(b.input_reg, run["input"])
    for kind, n in steps:
        if kind == "STEP":
            await b.write("CONTROL", STEP)
            await b.wait_idle(1, "single step")
        elif n < 1000:
            await b.burst(n)
        else:                               # a long burst: watch STEPS_LEFT, poke LOCKSTEP while busy
            await b.write("N_STEPS", n)
            await b.write("CONTROL", LOCKSTEP)
            await b.cycles(n * b.ii // 2)
            left = await b.read("STEPS_LEFT")
            status = await b.read("STATUS")
            assert status & ST_BUSY, "STATUS.BUSY low in the middle of a burst"
            assert 0 < left < n, f"STEPS_LEFT = {left} in the middle of a burst of {n}"
            await b.write("CONTROL", LOCKSTEP)          # ignored while busy
            await b.write("CONTROL", STEP)              # ignored while busy
            await b.wait_idle(left, f"burst of {n}")
        k += n
        _same(await b.state(), _row(run, k), f"after {kind} x{n} (step {k})")
        cnt = await b.counts()
        assert cnt == tuple(int(c) for c in run["cnt"][k]), \
            f"after step {k}: encoder counts {cnt}, decoded golden lines {tuple(run['cnt'][k])}"
        assert await b.read64("STEP_COUNT") == k, f"STEP_COUNT != {k}"
        assert await b.read("STEPS_LEFT") == 0
        ovf = await b.read("OVERFLOW")
        want_ovf = any(s < k for s in run["overflows"].values())
        assert ovf == (3 if want_ovf else 0), f"OVERFLOW = {ovf} after step {k}, golden overflow: {want_ovf}"
    # a slow plant (a geared servo) may not turn its encoder by a count in the bursts: then its
    # reported states must have moved (the bursts compared them with the golden rows)
    moved = any(cnt) or _row(run, k)[:len(b.state_regs)] != _row(run, 0)[:len(b.state_regs)]
    assert moved, "neither an encoder nor a state moved: not a useful lockstep test"
    # N_STEPS = 0: LOCKSTEP starts nothing
    await b.write("N_STEPS", 0)
    await b.write("CONTROL", LOCKSTEP)
    await b.cycles(4 * b.ii)
    assert not (await b.read("STATUS")) & ST_BUSY
    assert await b.read64("STEP_COUNT") == k


@cocotb.test()
async def free_run(dut):
    b = await _bus(dut)
    run = b.v["bus"]["u_neg"]
    total = 0
    await b.write(b.input_reg, run["input"])
    for div, cycles in ((b.ii, 2000 * b.ii), (b.ii + 3, 200 * (b.ii + 3))):
        await b.write("STEP_DIV", div)
        before = await b.read64("STEP_COUNT")
        await b.write("CONTROL", RUN)
        await b.cycles(cycles)
        await b.write("CONTROL", 0)
        await b.cycles(2 * b.ii + 2)                # the step in flight completes
        total = await b.read64("STEP_COUNT")
        made = total - before
        assert abs(made - cycles / div) <= 3, f"free run at STEP_DIV {div}: {made} steps in {cycles} cycles"
        assert not (await b.read("STATUS")) & (ST_RUNNING | ST_BUSY)
        _same(await b.state(), _row(run, total), f"free run at STEP_DIV {div}: after {total} steps")
        assert await b.counts() == tuple(int(c) for c in run["cnt"][total])
        dut._log.info("free run at STEP_DIV %d: %d steps in %d cycles, bit-exact", div, made, cycles)


@cocotb.test()
async def soft_and_hard_reset(dut):
    b = await _bus(dut)
    run = b.v["bus"]["u_pos"]
    exp = _expected_reset(b)
    await b.write(b.input_reg, run["input"])
    await b.write("N_STEPS", 100)
    await b.write("STEP_DIV", b.ii + 1)
    await b.write("CONTROL", RUN)
    await b.cycles(777)
    await b.write("CONTROL", SOFT_RESET | RUN)      # SOFT_RESET wins: RUN cleared
    await b.cycles(2)
    kept = dict(exp, N_STEPS=100, STEP_DIV=b.ii + 1)
    kept[b.input_reg] = run["input"] & 0xFFFFFFFF
    await _check_all(b, kept, "after SOFT_RESET mid-run")
    await b.write("CONTROL", LOCKSTEP)
    await b.wait_idle(100, "burst after SOFT_RESET")
    _same(await b.state(), _row(run, 100), "100 steps after SOFT_RESET")
    assert await b.counts() == tuple(int(c) for c in run["cnt"][100])
    # the reset pin in the middle of a burst restores every register
    await b.write("N_STEPS", 3000)
    await b.write("CONTROL", LOCKSTEP)
    await b.cycles(1001)
    await b.hw_reset()
    await _check_all(b, exp, "after the reset pin mid-burst")


@cocotb.test()
async def step_counter(dut):
    b = await _bus(dut)
    sc = b.dut.u_regs.step_count
    await b.write(b.input_reg, b.v["bus"]["u_pos"]["input"])
    start = (1 << 32) - 5
    sc.value = start                                 # white box: skip 4 billion steps
    await b.cycles(1)
    await b.burst(10)
    assert await b.read64("STEP_COUNT") == start + 10, "STEP_COUNT does not carry into STEP_COUNT_HI"
    # HI is a snapshot taken by the LO read
    lo = await b.read("STEP_COUNT_LO")
    await b.burst(3)
    assert await b.read("STEP_COUNT_HI") == 1 and lo == 5
    assert await b.read("STEP_COUNT_LO") == 8
    sc.value = (1 << 40) + 7
    await b.cycles(1)
    assert await b.read64("STEP_COUNT") == (1 << 40) + 7


@cocotb.test()
async def overflow_flags(dut):
    o = overflow_scenario()
    b = await _bus(dut)
    rel = o["k_star"] - o["k0"]
    u = o["u_win"]
    n1 = 1000
    n2 = min(len(u), 2 * n1) - n1
    assert n1 < rel < n1 + n2, f"overflow {rel} steps into the window, outside the second burst"
    assert (u[:n1] == u[0]).all() and (u[n1:n1 + n2] == u[n1]).all(), "U not constant per burst"
    b.deposit(o["state"])                             # white box: the golden state at step k0
    await b.cycles(2)
    await b.burst(n1, int(u[0]))
    _same(await b.state(), _row(o, n1), f"{n1} steps after the golden state at step {o['k0']}")
    assert await b.read("OVERFLOW") == 0 and not (await b.read("STATUS")) & ST_OVERFLOW
    await b.burst(n2, int(u[n1]))
    _same(await b.state(), _row(o, n1 + n2), f"{n1 + n2} steps after the golden state at step {o['k0']}")
    assert await b.read("OVERFLOW") == 3, "OVERFLOW.CORE/STICKY not set after the golden model overflowed"
    assert (await b.read("STATUS")) & ST_OVERFLOW
    await b.write("OVERFLOW", 1)                      # w1c: STICKY clears, CORE stays
    assert await b.read("OVERFLOW") == 2
    assert not (await b.read("STATUS")) & ST_OVERFLOW
    await b.write("OVERFLOW", 2)                      # CORE is read-only
    assert await b.read("OVERFLOW") == 2
    await b.write("CONTROL", SOFT_RESET)
    await b.cycles(2)
    assert await b.read("OVERFLOW") == 0, "SOFT_RESET does not clear the core's overflow flag"
