"""Simulator side of the regression: vectors, clock, reset and the step-by-step driver.

Timing convention (both simulators): the design only uses rising edges, so the
testbench drives and samples at falling edges. A *step boundary* is the falling edge
at which ``ready`` is high; there the outputs hold golden row k (the state at the start
of step k) and ``u`` is set for step k. With ``step`` held high the next boundary is
``ii`` clock periods later, so runs advance with ``Timer`` awaits (one per step, or one
per CHUNK steps in long runs) and Python never sees individual clock edges.
"""

from __future__ import annotations

import os
import pickle
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, Timer

_VECTORS = None


def vectors() -> dict:
    """The golden vectors written by pendtb.prepare (path in $PENDC_TB_VECTORS)."""
    global _VECTORS
    if _VECTORS is None:
        path = os.environ.get("PENDC_TB_VECTORS")
        if not path or not Path(path).is_file():
            raise RuntimeError("PENDC_TB_VECTORS does not name a vector file; run the regression through "
                               "tb/run.py or tests/test_sim.py")
        with open(path, "rb") as fh:
            _VECTORS = pickle.load(fh)
    return _VECTORS


def overflow_scenario() -> dict:
    """The golden overflow scenario (tb/overflow_runs.py). A plant that no full push, no position
    with a rate and no state's own drift under a constant input takes out of range has none: the
    calling test is skipped (reported as skipped, with what was tried), never passed."""
    o = vectors()["overflow"]
    assert o is not None, "the vectors hold no overflow scenario (made with overflow=False)"
    assert "error" not in o, o.get("error")
    if "unreachable" in o:
        import pytest
        # the summary repeats the reason for each overflow test: its first sentence here, all of
        # what was tried once in the vectors' log ("pendtb: overflow scenario ...")
        reason = o["unreachable"]
        cut = reason.find(":", 30)
        if len(reason) > 240:
            reason = (reason[:cut] if 0 < cut <= 240 else reason[:240]) + \
                " (what was tried: the golden vectors' log line 'pendtb: overflow scenario')"
        pytest.skip(reason)
    return o


def core_ports():
    """The core's names (:class:`pendc.hil.plants.core_ports.CorePorts`: input, states, encoders), as
    the plant interface of the build under test gives them."""
    return vectors()["core_ports"]


def ports() -> tuple:
    """The core's output ports in golden-row order: the states, the encoder channels, then the
    converters' code ports."""
    return core_ports().outputs


def diff_text(got: tuple, want: tuple) -> str:
    """The ports where a sampled row differs from the golden one, named."""
    return "; ".join(f"{p}: rtl {a} golden {b}" for p, a, b in zip(ports(), got, want) if a != b)


def simulator() -> str:
    name = os.environ.get("PENDC_TB_SIM")
    if name:
        return name
    return "icarus" if "icarus" in cocotb.SIM_NAME.lower() else "verilator"


def profile() -> str:
    """"full" (long runs from reset), "quick" (Icarus: ~1.5 k model steps per second) or "ci"
    (quick, with shorter every-step windows on Icarus: the test suite's)."""
    p = os.environ.get("PENDC_TB_PROFILE")
    if p in ("full", "quick", "ci"):
        return p
    return "quick" if simulator() == "icarus" else "full"


def to_bits(value: int, width: int) -> int:
    return int(value) & ((1 << width) - 1)


class StepMismatch(AssertionError):
    pass


class CoreBench:
    """Drives the testbench top (the core plus testbench decoders), by the plant's port names."""

    def __init__(self, dut):
        self.dut = dut
        self.core = dut.core
        v = vectors()
        self.v = v
        self.ii = v["ii"]
        self.period = v["period_ns"]
        cp = v["core_ports"]
        self.input_h = getattr(dut, cp.input)
        self.u_width = v["ports"][cp.input]["width"]
        self.state_h = [getattr(dut, p) for p in cp.states]
        self.enc_h = [getattr(dut, p) for p in cp.channels]
        self.code_h = [getattr(dut, p) for p in cp.codes]
        self.count_h = [getattr(dut, f"cnt_{e.name}") for e in cp.encoders]
        self.clock = None

    async def start(self):
        """Clock (C++ GPI clock), synchronise to a falling edge, reset."""
        d = self.dut
        d.rst.value = 1
        d.step.value = 0
        self.input_h.value = 0
        self.clock = Clock(d.clk, self.period, unit="ns", impl="gpi")
        self.clock.start(start_high=False)
        await FallingEdge(d.clk)
        await self.reset()

    async def cycles(self, n: int):
        await Timer(n * self.period, unit="ns")

    async def reset(self, cycles: int = 3):
        """Synchronous reset for ``cycles`` clocks; returns at a boundary with step low."""
        d = self.dut
        d.rst.value = 1
        d.step.value = 0
        await self.cycles(cycles)
        d.rst.value = 0

    def sample(self) -> tuple:
        """States, channel levels and converter codes now, in golden-row order."""
        return (tuple(h.value.to_signed() for h in self.state_h) + tuple(int(h.value) for h in self.enc_h)
                + tuple(h.value.to_signed() for h in self.code_h))

    def counts(self) -> tuple:
        """The testbench decoders' x4 counts now, one per encoder."""
        return tuple(h.value.to_signed() for h in self.count_h)

    def overflow_terms(self) -> str:
        """The core's per-node overflow terms that are high now (for failure messages)."""
        try:
            high = [f"{w} ({node})" for w, node in self.v["ovf_wires"] if int(getattr(self.core, w).value)]
        except Exception as exc:           # a simulator without access to internal nets
            return f"; cannot read the core's overflow terms: {exc}"
        return "; core overflow terms high now: " + (", ".join(high) if high else "none")

    def set_u(self, u: int):
        """Drive the plant's input port with the integer ``u``."""
        self.input_h.value = to_bits(u, self.u_width)

    async def load_state(self, state: dict, overflow: bool):
        """Deposit a golden state (register -> (value, width)) at a boundary; one idle cycle."""
        self.dut.step.value = 0
        for name, (value, width) in state.items():
            getattr(self.core, name).value = to_bits(value, width)
        self.core.overflow_r.value = int(bool(overflow))
        await self.cycles(1)

    async def load_counts(self, counts):
        """After :meth:`load_state`: the testbench decoders hold the deposited lines as their last
        sample, ``counts`` (the decoded golden lines' counts at the deposited step) as their count,
        and no error (the deposit's jump of the lines is no quadrature step)."""
        cp = self.v["core_ports"]
        for e, c in zip(cp.encoders, counts):
            dec = getattr(self.dut, f"dec_{e.name}")
            dec.a_q.value = int(getattr(self.dut, e.channel_a).value)
            dec.b_q.value = int(getattr(self.dut, e.channel_b).value)
            dec.count_q.value = to_bits(int(c), 32)
            dec.err.value = 0
        await Timer(1, unit="ns")
        if tuple(self.counts()) != tuple(int(c) for c in counts) or int(self.dut.enc_err.value):
            raise StepMismatch(f"decoders not set: counts {self.counts()}, want {tuple(int(c) for c in counts)}, "
                               f"enc_err {int(self.dut.enc_err.value)}")
        await Timer(self.period - 1, unit="ns")

    async def run_every_step(self, u, rows, k0: int, label: str, ovf_from: int | None = None,
                             ovf_before: bool = False, on_step=None):
        """Run len(u) steps with step held high, comparing every port at every boundary.

        ``rows[j]`` is golden row k0+j (len(u)+1 rows). The core's sticky overflow must
        be low before row ``ovf_from`` and high from it (None: never, unless ``ovf_before``).
        ``on_step(j, c)`` (async) is awaited in every clock cycle c of step j if given."""
        d = self.dut
        n = len(u)
        expect = [tuple(int(x) for x in r) for r in rows]
        ii = self.ii
        step_ns = ii * self.period
        d.step.value = 1
        for j in range(n + 1):
            got = self.sample()
            if got != expect[j]:
                raise StepMismatch(f"{label}: first mismatch at step {k0 + j} (window row {j}): "
                                   + diff_text(got, expect[j]))
            ovf = int(d.overflow.value)
            want = ovf_before or (ovf_from is not None and j >= ovf_from)
            if ovf != int(want):
                raise StepMismatch(f"{label}: overflow is {ovf} at step {k0 + j}, golden says {int(want)}"
                                   f"{self.overflow_terms()}")
            if int(d.ready.value) != 1:
                raise StepMismatch(f"{label}: ready low at the boundary of step {k0 + j}")
            if j == n:
                break
            self.set_u(u[j])
            if on_step is not None and ii > 1:
                # on_step(j, c) in every cycle c of the step, 1 ns after the boundary's edge: a
                # scheduled core computes each node (and its overflow term) in one cycle only
                await Timer(1, unit="ns")
                for c in range(ii):
                    await on_step(j, c)
                    if c < ii - 1:
                        await Timer(self.period, unit="ns")
                await Timer(self.period - 1, unit="ns")
            else:
                await Timer(step_ns, unit="ns")
        d.step.value = 0

    async def run_chunks(self, u_chunks, chunk: int, check):
        """Step held high, u changed every ``chunk`` steps; ``check(i)`` at boundary i*chunk
        (i = 0..len(u_chunks)) may raise."""
        d = self.dut
        d.step.value = 1
        span = chunk * self.ii * self.period
        for i, u in enumerate(u_chunks):
            check(i)
            self.set_u(int(u))
            await Timer(span, unit="ns")
        check(len(u_chunks))
        d.step.value = 0
