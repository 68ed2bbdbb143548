"""The lockstep Verilog harness around a generated core, and the process that speaks to it.

One harness for every use of the core in a simulator outside cocotb: the HIL plants
(:mod:`pendc.hil.plants.rtl_plant`) and the testbench's standalone Verilator runs (``tb/vbinary.py``).
It instantiates the core with its ``step`` input held high (one model step every ``ii`` clock
cycles, as the bus wrapper's lockstep bursts run it) and reads one request per line from
standard input:

    0 <input integer> <n steps>     hold the input for n steps, then answer
    1 0 0                           reset (core, encoder counts), then answer
    2 <i> <integer>                 deposit the integer into state register i of the harness'
                                    list (see :func:`harness_source`), then answer

and answers each with one line of integers: the reported states (the output ports' integers,
in :class:`~pendc.hil.plants.core_ports.CorePorts` order), one ×4 count since reset per encoder
(decoded from the channel lines at every step exactly as :func:`pendc.hil.plants.plant.x4_count_delta`
does), the channel levels, the sticky ``overflow`` flag and ``lost`` (a step in which both
channels of an encoder changed). The simulation waits for stdin without advancing time, so
the exchange is lockstep. Every name comes from the plant interface; none is spelled here.
"""

from __future__ import annotations

import re
import subprocess
from dataclasses import dataclass
from pathlib import Path

from ...errors import PendcError
from .core_ports import CorePorts, core_instance
from .rtl_build import VERILATOR_MAKE_VARS, build_cached, find_tool

TOP = "pendc_hil_harness"
PERIOD_NS = 10
HARNESS_FORMAT = 6       # bump when the harness text changes shape


def answer_width(ports: CorePorts) -> int:
    """Integers per answer line: states, one count per encoder, channel levels, overflow, lost."""
    return len(ports.states) + len(ports.encoders) + len(ports.channels) + 2


def harness_source(ports: CorePorts, formats: dict, ii: int, deposit: tuple = ()) -> str:
    """The Verilog-2005 harness around the core (``formats``: report.json's "ports").

    ``deposit``: ``(core register, width)`` pairs a ``2 i value`` request writes into (register
    i, by a hierarchical assignment between clock edges, as a testbench deposits a state)."""
    uw = formats[ports.input]["width"]
    enc = list(enumerate(ports.encoders))
    loads = "".join(f"                    {i}: core.{reg} = h_arg[{w - 1}:0];\n" for i, (reg, w) in enumerate(deposit))
    shown = [*ports.states] + [f"h_cnt{i}" for i, _ in enc] + [*ports.channels] + ["overflow", "h_lost"]
    fmt = " ".join(["%0d"] * len(shown))

    def restart(pad):
        return "".join(f"{pad}h_prev{i} = h_gray({e.channel_a}, {e.channel_b});\n" for i, e in enc)

    counting = "".join(
        f"            h_d{i} = h_gray({e.channel_a}, {e.channel_b}) - h_prev{i};\n"
        f"            if (h_d{i} == 2'd1) h_cnt{i} = h_cnt{i} + 1;\n"
        f"            if (h_d{i} == 2'd3) h_cnt{i} = h_cnt{i} - 1;\n"
        f"            if (h_d{i} == 2'd2) h_lost = 1;\n" for i, e in enc) + restart("            ")
    regs = "".join(f"    reg signed [63:0] h_cnt{i};\n    reg [1:0] h_prev{i}, h_d{i};\n" for i, _ in enc)
    zero = "".join(f"            h_cnt{i} = 0;\n" for i, _ in enc)
    return f"""// pendc HIL harness (pendc.hil.plants.rtl_harness, format {HARNESS_FORMAT}): lockstep over stdin/stdout.
`timescale 1ns/1ps
module {TOP};
    reg clk = 1'b0;
    reg rst = 1'b1;
    reg step = 1'b0;
{core_instance(ports, formats)}

    always #{PERIOD_NS / 2:g} clk = ~clk;

    // x4 decoding: Gray index of (A, B) along increasing position (A leads)
    function [1:0] h_gray;
        input a, b;
        h_gray = (a == 1'b0 && b == 1'b0) ? 2'd0 : (a == 1'b1 && b == 1'b0) ? 2'd1 :
                 (a == 1'b1 && b == 1'b1) ? 2'd2 : 2'd3;
    endfunction

    integer h_got, h_n, h_lost, h_kind;
    reg h_counting = 1'b0;
    reg [63:0] h_span;
    reg signed [63:0] h_val, h_arg;
{regs}
    task h_answer;
        begin
            $display("{fmt}", {", ".join(shown)});
            $fflush(32'h8000_0001);
        end
    endtask

    task h_reset;
        begin
            h_counting = 1'b0;
            step = 1'b0;
            rst = 1'b1;
            repeat (3) @(negedge clk);
            #1;                                  // 1 ns after a falling edge: far from every rising edge
            rst = 1'b0;
{zero}            h_lost = 0;
{restart("            ")}            h_counting = 1'b1;
        end
    endtask

    // the channel lines change only when a step's state update lands (a rising edge), so
    // sampling them at every falling edge sees each change exactly once
    always @(negedge clk) begin
        if (h_counting) begin
{counting}        end
    end

    initial begin
        h_reset;
        h_answer;
        while (1) begin
            h_kind = -1;
            h_got = $fscanf(32'h8000_0000, "%d %d %d", h_kind, h_val, h_arg);
            if (h_got < 1) $finish;              // end of input: the host closed the pipe
            h_n = h_arg[31:0];
            if (h_got != 3 || h_kind < 0 || h_kind > 2 || (h_kind == 0 && (h_arg < 1 || h_arg > 64'sh7fffffff))
                    || (h_kind == 2 && (h_val < 0 || h_val >= {len(deposit)}))) begin
                $display("ERROR bad request");
                $fflush(32'h8000_0001);
                $finish;
            end
            if (h_kind == 1) begin
                h_reset;
            end else if (h_kind == 2) begin
                // as a testbench deposits a state: step low, the register written between edges,
                // one idle clock cycle (nothing but table reads moves without step)
                step = 1'b0;
                h_counting = 1'b0;
                case (h_val)
{loads}                    default: ;
                endcase
                @(negedge clk);
                #1;
{restart("                ")}                h_counting = 1'b1;    // a deposited encoder phase is no movement
            end else begin
                {ports.input} = h_val[{uw - 1}:0];
                step = 1'b1;
                h_span = h_n;
                h_span = h_span * {ii * PERIOD_NS};
                #(h_span);
            end
            h_answer;
        end
    end
endmodule
"""


def _build_commands(simulator: str, work: Path, sources: list) -> tuple[list, Path]:
    if simulator == "verilator":
        obj = work / "obj_dir"
        cmd = [find_tool("verilator"), "--binary", "--timing", "-j", "2", "--top-module", TOP, "-Mdir", str(obj),
               "-o", TOP, "-O3", "--x-assign", "fast", "--x-initial", "fast", "--noassert", "-Wno-fatal",
               "-Wno-lint", "-Wno-STMTDLY", "-CFLAGS", "-fcoroutines", "-MAKEFLAGS", VERILATOR_MAKE_VARS]
        return [cmd + [str(s) for s in sources]], obj / TOP
    exe = work / f"{TOP}.vvp"
    return [[find_tool("iverilog"), "-g2005", "-s", TOP, "-o", str(exe)] + [str(s) for s in sources]], exe


def build_harness(files: dict, ports: CorePorts, formats: dict, ii: int, simulator: str,
                  deposit: tuple = ()) -> Path:
    """The simulator executable (Verilator binary or Icarus .vvp) for these HDL files ({name:
    text}), built once per design hash and cached."""
    return build_cached(simulator, files, {f"{TOP}.v": harness_source(ports, formats, ii, deposit)}, simulator,
                        lambda folder, sources: _build_commands(simulator, folder, sources),
                        f"{simulator} harness")


@dataclass(frozen=True)
class HarnessAnswer:
    """One answer line, split: state integers, counts per encoder, channel levels, flags."""

    states: tuple
    counts: tuple
    levels: tuple
    overflow: bool
    lost: bool


class HarnessLink:
    """A running harness executable (``simulator``: "verilator" runs it, "icarus" through vvp):
    :meth:`request` sends one request line and returns the parsed answer."""

    def __init__(self, executable: Path, simulator: str, ports: CorePorts):
        self.executable, self.simulator, self.ports = Path(executable), simulator, ports
        self._pattern = re.compile(r"-?\d+( -?\d+){%d}" % (answer_width(ports) - 1))
        cmd = [str(self.executable)] if simulator == "verilator" else [find_tool("vvp"), "-n", str(self.executable)]
        self._proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                      text=True, bufsize=1,
                                      cwd=self.executable.parent)   # the tables' .mem files are there (rtl_build)

    @property
    def alive(self) -> bool:
        """Whether the simulator process still runs."""
        return self._proc is not None and self._proc.poll() is None

    def answer(self) -> HarnessAnswer:
        """The next answer line (a simulator's own banner lines are skipped)."""
        line = self._proc.stdout.readline()
        while line and not (self._pattern.fullmatch(line.strip()) or line.startswith("ERROR")):
            line = self._proc.stdout.readline()
        if not line or line.startswith("ERROR"):
            raise PendcError(f"the {self.simulator} harness stopped answering ({line.strip() or 'no output'})")
        v = [int(x) for x in line.split()]
        s, e, c = len(self.ports.states), len(self.ports.encoders), len(self.ports.channels)
        return HarnessAnswer(states=tuple(v[:s]), counts=tuple(v[s:s + e]), levels=tuple(v[s + e:s + e + c]),
                             overflow=bool(v[s + e + c]), lost=bool(v[s + e + c + 1]))

    def request(self, text: str) -> HarnessAnswer:
        """Send one request line; its answer."""
        try:
            self._proc.stdin.write(text + "\n")
            self._proc.stdin.flush()
        except (BrokenPipeError, OSError):
            raise PendcError(f"the {self.simulator} harness has exited") from None
        return self.answer()

    def close(self) -> None:
        """End the simulator process (closing its input ends it)."""
        if self.alive:
            self._proc.stdin.close()
            try:
                self._proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
        self._proc = None
