"""The generated Verilog as a stepping plant, under Verilator or Icarus, in lockstep over pipes.

A small Verilog harness instantiates ``pendulum_core`` with its ``step`` input held high
(one model step every ``ii`` clock cycles, as the bus wrapper's lockstep bursts run it) and
reads one request per line from standard input:

    0 <u integer> <n steps>     hold u for n steps, then answer
    1 0 0                       reset (core, encoder counts), then answer
    2 <i> <integer>             deposit the integer into state register i of the harness'
                                list (see :func:`harness_source`), then answer

and answers each with one line: ``x dx theta dtheta`` (the output ports' integers),
``enc_x enc_theta`` (×4 counts since reset, decoded from the core's channel lines at every
step exactly as :func:`pendc.hil.plant.x4_count_delta` does), the four channel levels, the
sticky ``overflow`` flag and ``lost`` (a step in which both channels of an encoder changed).
The simulation waits for stdin without advancing time, so the exchange is lockstep.

Each design (the core's files and the harness) is built once and cached under its hash.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

from ..errors import PendcError
from ..model.plant import PlantModel
from .golden_plant import STATE_PORTS, build_for
from .plant import PlantState, check_step_request
from .rtl_build import VERILATOR_MAKE_VARS, find_tool, build_cached

SIMULATORS = ("verilator", "icarus")
_ANSWER = re.compile(r"-?\d+( -?\d+){11}")
TOP = "pendc_hil_harness"
PERIOD_NS = 10
HARNESS_FORMAT = 5       # bump when the harness text changes shape


def harness_source(ports: dict, ii: int, deposit: tuple = ()) -> str:
    """The Verilog-2005 harness around ``pendulum_core`` (ports: report.json's "ports").

    ``deposit``: ``(core register, width)`` pairs a ``2 i value`` request writes into (register
    i, by a hierarchical assignment between clock edges, as a testbench deposits a state)."""
    uw = ports["u"]["width"]
    loads = "".join(f"                    {i}: core.{reg} = arg[{w - 1}:0];\n" for i, (reg, w) in enumerate(deposit))
    decl = {p: f"{'signed ' if ports[p]['signed'] else ''}[{ports[p]['width'] - 1}:0]" for p in STATE_PORTS}
    return f"""// pendc HIL harness (pendc.hil.rtl_plant, format {HARNESS_FORMAT}): lockstep over stdin/stdout.
`timescale 1ns/1ps
module {TOP};
    reg clk = 1'b0;
    reg rst = 1'b1;
    reg step = 1'b0;
    reg signed [{uw - 1}:0] u = {uw}'sd0;
    wire ready, overflow;
{chr(10).join(f"    wire {decl[p]} {p};" for p in STATE_PORTS)}
    wire enc_x_a, enc_x_b, enc_theta_a, enc_theta_b;
    pendulum_core core (.clk(clk), .rst(rst), .step(step), .ready(ready), .u(u),
        .x(x), .dx(dx), .theta(theta), .dtheta(dtheta), .enc_x_a(enc_x_a), .enc_x_b(enc_x_b),
        .enc_theta_a(enc_theta_a), .enc_theta_b(enc_theta_b), .overflow(overflow));

    always #{PERIOD_NS / 2:g} clk = ~clk;

    // x4 decoding: Gray index of (A, B) along increasing position (A leads)
    function [1:0] gray;
        input a, b;
        gray = (a == 1'b0 && b == 1'b0) ? 2'd0 : (a == 1'b1 && b == 1'b0) ? 2'd1 :
               (a == 1'b1 && b == 1'b1) ? 2'd2 : 2'd3;
    endfunction

    integer got, n, lost, kind;
    reg counting = 1'b0;
    reg [63:0] span;
    reg signed [63:0] uval, arg, cnt_x, cnt_t;
    reg [1:0] px, pt, dxg, dtg;

    task answer;
        begin
            $display("%0d %0d %0d %0d %0d %0d %0d %0d %0d %0d %0d %0d", x, dx, theta, dtheta, cnt_x, cnt_t,
                     enc_x_a, enc_x_b, enc_theta_a, enc_theta_b, overflow, lost);
            $fflush(32'h8000_0001);
        end
    endtask

    task do_reset;
        begin
            counting = 1'b0;
            step = 1'b0;
            rst = 1'b1;
            repeat (3) @(negedge clk);
            #1;                                  // 1 ns after a falling edge: far from every rising edge
            rst = 1'b0;
            cnt_x = 0;
            cnt_t = 0;
            lost = 0;
            px = gray(enc_x_a, enc_x_b);
            pt = gray(enc_theta_a, enc_theta_b);
            counting = 1'b1;
        end
    endtask

    // the channel lines change only when a step's state update lands (a rising edge), so
    // sampling them at every falling edge sees each change exactly once
    always @(negedge clk) begin
        if (counting) begin
            dxg = gray(enc_x_a, enc_x_b) - px;
            dtg = gray(enc_theta_a, enc_theta_b) - pt;
            if (dxg == 2'd1) cnt_x = cnt_x + 1;
            if (dxg == 2'd3) cnt_x = cnt_x - 1;
            if (dtg == 2'd1) cnt_t = cnt_t + 1;
            if (dtg == 2'd3) cnt_t = cnt_t - 1;
            if (dxg == 2'd2 || dtg == 2'd2) lost = 1;
            px = gray(enc_x_a, enc_x_b);
            pt = gray(enc_theta_a, enc_theta_b);
        end
    end

    initial begin
        do_reset;
        answer;
        while (1) begin
            kind = -1;
            got = $fscanf(32'h8000_0000, "%d %d %d", kind, uval, arg);
            if (got < 1) $finish;                // end of input: the host closed the pipe
            n = arg[31:0];
            if (got != 3 || kind < 0 || kind > 2 || (kind == 0 && (arg < 1 || arg > 64'sh7fffffff))
                    || (kind == 2 && (uval < 0 || uval >= {len(deposit)}))) begin
                $display("ERROR bad request");
                $fflush(32'h8000_0001);
                $finish;
            end
            if (kind == 1) begin
                do_reset;
            end else if (kind == 2) begin
                // as a testbench deposits a state: step low, the register written between edges,
                // one idle clock cycle (nothing but table reads moves without step)
                step = 1'b0;
                counting = 1'b0;
                case (uval)
{loads}                    default: ;
                endcase
                @(negedge clk);
                #1;
                px = gray(enc_x_a, enc_x_b);         // a deposited encoder phase is no movement
                pt = gray(enc_theta_a, enc_theta_b);
                counting = 1'b1;
            end else begin
                u = uval[{uw - 1}:0];
                step = 1'b1;
                span = n;
                span = span * {ii * PERIOD_NS};
                #(span);
            end
            answer;
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


def build_harness(files: dict, ports: dict, ii: int, simulator: str, deposit: tuple = ()) -> Path:
    """The simulator executable (Verilator binary or Icarus .vvp) for these HDL files, built once
    per design hash and cached."""
    return build_cached(simulator, files, {f"{TOP}.v": harness_source(ports, ii, deposit)}, simulator,
                        lambda folder, sources: _build_commands(simulator, folder, sources),
                        f"{simulator} harness")


def deposit_registers(graph) -> tuple:
    """``(core register, width)`` of every state node (registers, then FSM states as in
    :class:`pendc.golden.GoldenStepper`'s state vector, same order), the registers a
    ``2 i value`` request writes: a golden state continues in the RTL from there."""
    from ..backend.viewmodel import sig
    from ..ir.nodes import Kind

    out = []
    for n in graph.nodes:
        if n.kind is Kind.REGISTER:
            out.append((sig(n.name), n.qformat.width))
        elif n.kind is Kind.FSM:
            out.append((f"{sig(n.name)}_state", max(1, (len(n.param("states")) - 1).bit_length())))
    return tuple(out)


class RtlPlant:
    """The generated core under ``simulator`` ("verilator" or "icarus"), stepped in lockstep.

    The same integers as :class:`~pendc.hil.golden_plant.GoldenPlant` for the same inputs and the
    same ``initial`` (x, dx, theta, dtheta: deposited into the core's state registers after every
    reset, as a testbench deposits a state; the encoders count from there). ``schedule``: the
    build request (``{"preset": "comb"}``, ``{"ii": 4}``...; None: ``pendc build``'s default), every
    schedule being bit-exact with the same golden model. The core's sticky overflow flag stops
    the run (``on_overflow="error"``) with the time; the golden model names the node. Call
    :meth:`close` (or use ``with``) to end the simulator process."""

    def __init__(self, model: PlantModel, simulator: str = "verilator", dt: float = 1e-6, build=None,
                 on_overflow: str = "error", bus: str = "raptor", initial: tuple | None = None,
                 schedule: dict | None = None):
        if simulator not in SIMULATORS:
            raise PendcError(f"unknown RTL simulator '{simulator}' (choose {', '.join(SIMULATORS)})")
        self.simulator = simulator
        files, report = self._prepare(model, dt, build, on_overflow, bus, initial, schedule)
        self._deposit_ok = True
        self.executable = build_harness(files, report["ports"], self.ii, simulator, self._deposit)
        self._proc = None
        self.overflow_at = None
        self.reset()

    def _prepare(self, model, dt, build, on_overflow, bus, initial, schedule) -> tuple[dict, dict]:
        """Everything but the executable: the build, the HDL files and their report.json."""
        import json

        from ..backend.hdl import build_hdl, port_formats
        from ..golden import register_integers
        from ..ir.nodes import Kind

        if on_overflow not in ("error", "mark"):
            raise PendcError(f"on_overflow must be error or mark, got {on_overflow!r}")
        self.build = build_for(model, dt, build)
        self.model, self.dt, self.on_overflow = model, float(dt), on_overflow
        graph = self.build.graph
        self.initial = None if initial is None else tuple(float(v) for v in initial)
        if self.initial is not None and len(self.initial) != len(STATE_PORTS):
            raise PendcError(f"initial state needs {len(STATE_PORTS)} values ({', '.join(STATE_PORTS)}), "
                             f"got {len(self.initial)}")
        self._deposit = deposit_registers(graph)
        self._state_names = [n.name for n in graph.nodes if n.kind in (Kind.REGISTER, Kind.FSM)]
        start = {} if self.initial is None else register_integers(graph, dict(zip(STATE_PORTS, self.initial)))
        self._initial_deposits = [(self._state_names.index(name), value) for name, value in start.items()]
        self.schedule_request = dict(schedule or {})
        files = build_hdl(graph, self.build.resources.to_json(), source=model.source, bus=bus,
                          request=self.schedule_request or None)
        report = json.loads(files["report.json"])
        self.ii = int(report["ii"])
        self.build_id = report["build_id"]
        self.ports = port_formats(graph)
        self._lsb = {p: 2.0 ** -report["ports"][p]["frac"] for p in STATE_PORTS}
        self._u_format = graph["u"].qformat
        return files, report

    def describe(self) -> dict:
        """Which core this plant runs: simulator, schedule request, ii and build id (for summary.json)."""
        return {"simulator": self.simulator, "schedule": self.schedule_request or {"preset": "default"},
                "ii": self.ii, "build_id": self.build_id}

    def _start(self):
        if self.simulator == "verilator":
            cmd = [str(self.executable)]
        else:
            cmd = [find_tool("vvp"), "-n", str(self.executable)]
        self._proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                      text=True, bufsize=1, cwd=self.executable.parent)

    def _answer(self) -> list:
        line = self._proc.stdout.readline()
        while line and not (_ANSWER.fullmatch(line.strip()) or line.startswith("ERROR")):
            line = self._proc.stdout.readline()     # a simulator's own banner lines
        if not line or line.startswith("ERROR"):
            raise PendcError(f"the {self.simulator} harness stopped answering ({line.strip() or 'no output'})")
        return [int(v) for v in line.split()]

    def _request(self, text: str) -> list:
        try:
            self._proc.stdin.write(text + "\n")
            self._proc.stdin.flush()
        except (BrokenPipeError, OSError):
            raise PendcError(f"the {self.simulator} harness has exited") from None
        return self._answer()

    def _state(self, v: list) -> PlantState:
        self.last = {"x": v[0], "dx": v[1], "theta": v[2], "dtheta": v[3], "enc_x_a": v[6], "enc_x_b": v[7],
                     "enc_theta_a": v[8], "enc_theta_b": v[9]}
        return PlantState(t=self._k * self.dt, x=v[0] * self._lsb["x"], dx=v[1] * self._lsb["dx"],
                          theta=v[2] * self._lsb["theta"], dtheta=v[3] * self._lsb["dtheta"],
                          enc_x=v[4], enc_theta=v[5])

    def raw(self) -> dict:
        """The output ports' integers after the last step (compare with GoldenPlant.raw())."""
        return dict(self.last)

    def reset(self) -> PlantState:
        self._k = 0
        self.overflow_at = None
        if self._proc is None or self._proc.poll() is not None:
            self._start()
            v = self._answer()
        else:
            v = self._request("1 0 0")
        for i, value in self._initial_deposits:
            v = self._request(f"2 {i} {value}")
        return self._state(v)

    def load(self, registers) -> PlantState:
        """Reset, then continue from a golden state: ``registers`` are the integers of every state
        node (:meth:`pendc.hil.golden_plant.GoldenPlant.registers`); time and encoder counts
        restart at zero, the overflow flag is clear."""
        values = [int(v) for v in registers]
        if len(values) != len(self._deposit):
            raise PendcError(f"a core state has {len(self._deposit)} registers, got {len(values)}")
        if not self._deposit_ok:
            raise PendcError("this plant was built without state loading (loadable=False)")
        self.reset()
        v = None
        for i, value in enumerate(values):
            v = self._request(f"2 {i} {value}")
        return self._state(v) if v is not None else self._state(self._request("1 0 0"))

    def step(self, u_volts: float, n_steps: int) -> PlantState:
        u, n = check_step_request(u_volts, n_steps)
        v = self._request(f"0 {self._u_format.from_float(u)} {n}")
        self._k += n
        if v[11]:
            raise PendcError(f"encoder channels A and B changed in the same step before t = {self._k * self.dt:.6g} s")
        if v[10] and self.overflow_at is None:
            self.overflow_at = self._k
            if self.on_overflow == "error":
                raise PendcError(f"the core's overflow flag rose before t = {self._k * self.dt:.6g} s "
                                 f"(the golden plant names the node)")
        return self._state(v)

    def close(self) -> None:
        """End the simulator process."""
        if self._proc is not None and self._proc.poll() is None:
            self._proc.stdin.close()
            try:
                self._proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
        self._proc = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass
