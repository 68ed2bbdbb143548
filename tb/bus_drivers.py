"""Bus drivers of the wrapper regression: one interface over the RAPTOR local bus and AXI4-Lite."""

from __future__ import annotations

import logging
import os

from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, Timer

from simlib import to_bits, vectors


MAGIC = 0x50454E44
RUN, LOCKSTEP, STEP, SOFT_RESET = 1, 2, 4, 8
ST_RUNNING, ST_BUSY, ST_OVERFLOW = 1, 2, 4


def _mask(bits: int) -> int:
    return (1 << bits) - 1


class Bus:
    """Register access common to both front-ends: ``read(name)``, ``write(name, value)``."""

    def __init__(self, dut):
        self.dut = dut
        v = vectors()
        self.v = v
        self.bus = os.environ.get("PENDC_TB_BUS") or ("axi-lite" if hasattr(dut, "s_axi_awaddr") else "raptor")
        self.report = v["reports"][self.bus]
        self.regs = {r["name"]: r for r in self.report["registers"]}
        self.period = v["period_ns"]
        self.ii = v["ii"]
        self.core = dut.u_regs.u_core
        names = v.get("register_names") or _register_names_from_report(self.report, self.regs)
        ports = list(self.report["ports"])        # the input first, the reported states, converter codes
        cp = v.get("core_ports")
        self.input_reg = names[ports[0]][0]
        states = cp.states if cp is not None else ports[1:]
        self.state_regs = [names[p][0][:-len("_LO")] for p in states]
        self.count_regs = [names[e.name][0] for e in cp.encoders] if cp is not None else []
        self.channels = len(cp.channels) if cp is not None else 0
        # each converter's code register and its port's fraction bits (the golden row holds the port)
        self.code_regs = ([(names[a.name][0], self.report["ports"][a.port]["frac"]) for a in cp.adcs]
                          if cp is not None else [])

    def addr(self, name: str) -> int:
        return self.regs[name]["offset"]

    async def read(self, name_or_addr) -> int:
        a = self.addr(name_or_addr) if isinstance(name_or_addr, str) else name_or_addr
        return await self.read_addr(a)

    async def write(self, name_or_addr, value: int):
        a = self.addr(name_or_addr) if isinstance(name_or_addr, str) else name_or_addr
        await self.write_addr(a, to_bits(value, 32))

    async def read64(self, name: str) -> int:
        """A LO/HI pair, LO first (that latches HI), as a signed 64-bit value."""
        lo = await self.read(f"{name}_LO")
        hi = await self.read(f"{name}_HI")
        v = (hi << 32) | lo
        return v - (1 << 64) if v >> 63 else v

    async def cycles(self, n: int):
        await Timer(n * self.period, unit="ns")

    async def state(self) -> tuple:
        """The reported states, the encoder lines and the converter codes read through the
        registers, like golden rows (a code register holds the code; the row, the port's integer)."""
        vals = [await self.read64(r) for r in self.state_regs]
        enc = await self.read("ENC") if self.channels else 0
        codes = [(await self.read(r)) << frac for r, frac in self.code_regs]
        return tuple(vals) + tuple((enc >> i) & 1 for i in range(self.channels)) + tuple(codes)

    async def counts(self) -> tuple:
        """Every encoder's count register (signed), in the plant interface's order."""
        def s32(v):
            return v - (1 << 32) if v >> 31 else v
        return tuple([s32(await self.read(r)) for r in self.count_regs])

    async def wait_idle(self, steps: int, what: str):
        """After starting a burst of ``steps``: wait its duration, then poll STATUS.BUSY."""
        if steps * self.ii > 4:
            await self.cycles(steps * self.ii - 4)
        for _ in range(50 + 4 * self.ii):
            if not (await self.read("STATUS")) & ST_BUSY:
                return
        raise AssertionError(f"{what}: STATUS.BUSY still set long after {steps} steps")

    async def burst(self, n: int, u: int | None = None):
        """A lockstep burst of ``n`` steps (input register set to ``u`` first if given), waited out."""
        if u is not None:
            await self.write(self.input_reg, u)
        await self.write("N_STEPS", n)
        await self.write("CONTROL", LOCKSTEP)
        await self.wait_idle(n, f"lockstep burst of {n}")

    def deposit(self, state: dict):
        for name, (value, width) in state.items():
            getattr(self.core, name).value = to_bits(value, width)


class RaptorBus(Bus):
    async def start(self):
        d = self.dut
        d.rst.value = 1
        d.wr.value = 0
        d.rd.value = 0
        d.addr.value = 0
        d.wdata.value = 0
        Clock(d.clk, self.period, unit="ns", impl="gpi").start(start_high=False)
        await FallingEdge(d.clk)
        await self.hw_reset()

    async def hw_reset(self):
        self.dut.rst.value = 1
        await self.cycles(3)
        self.dut.rst.value = 0

    async def write_addr(self, a: int, value: int):
        d = self.dut
        d.addr.value = a
        d.wdata.value = value
        d.wr.value = 1
        await self.cycles(1)
        d.wr.value = 0
        assert int(d.ack.value) == 1, f"no ack the cycle after a write to 0x{a:02x}"

    async def read_addr(self, a: int) -> int:
        d = self.dut
        d.addr.value = a
        d.rd.value = 1
        await self.cycles(1)
        d.rd.value = 0
        assert int(d.ack.value) == 1, f"no ack the cycle after a read of 0x{a:02x}"
        return int(d.rdata.value)


class AxilBus(Bus):
    async def start(self):
        from cocotbext.axi import AxiLiteBus, AxiLiteMaster
        d = self.dut
        d.aresetn.value = 0
        Clock(d.aclk, self.period, unit="ns", impl="gpi").start(start_high=False)
        await FallingEdge(d.aclk)
        self.master = AxiLiteMaster(AxiLiteBus.from_prefix(d, "s_axi"), d.aclk, d.aresetn,
                                    reset_active_level=False)
        for name in ("cocotb.tb", f"cocotb.{d._name}", f"cocotb.{d._name}.s_axi"):
            logging.getLogger(name).setLevel(logging.WARNING)
        await self.hw_reset()

    async def hw_reset(self):
        self.dut.aresetn.value = 0
        await self.cycles(3)
        self.dut.aresetn.value = 1
        await self.cycles(2)

    async def write_addr(self, a: int, value: int):
        from cocotbext.axi.constants import AxiResp
        r = await self.master.write(a, value.to_bytes(4, "little"))
        assert r.resp == AxiResp.OKAY, f"write to 0x{a:02x}: response {r.resp}"

    async def read_addr(self, a: int) -> int:
        from cocotbext.axi.constants import AxiResp
        r = await self.master.read(a, 4)
        assert r.resp == AxiResp.OKAY, f"read of 0x{a:02x}: response {r.resp}"
        return int.from_bytes(bytes(r.data), "little")


def _register_names_from_report(report: dict, regs: dict) -> dict:
    """Port -> register name(s) for vectors made without the plant interface's names: the
    report's data ports (input first), each as the LO/HI pair or the single word the map has."""
    out = {}
    for p in report["ports"]:
        pair = (f"{p.upper()}_LO", f"{p.upper()}_HI")
        out[p] = pair if pair[0] in regs else (p.upper(),)
    return out


async def _bus(dut) -> Bus:
    b = AxilBus(dut) if hasattr(dut, "s_axi_awaddr") else RaptorBus(dut)
    await b.start()
    return b
