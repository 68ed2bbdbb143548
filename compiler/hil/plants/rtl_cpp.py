"""The generated Verilog as a stepping plant under a plain C++ Verilator harness (no ``--timing``).

Same request/answer line protocol and the same integers as :mod:`pendc.hil.plants.rtl_plant`'s Verilog
harness, whose clock schedule it reproduces edge for edge:

* reset: ``step`` low, ``rst`` high for three clock cycles (three rising edges), then ``rst``
  low; the encoder counts and ``lost`` clear and the channel levels at that moment are the
  decoder's starting point;
* ``0 u n``: ``u`` applied and ``step`` held high (it stays high until the next reset) for
  ``n * ii`` clock cycles; after every falling edge the four channel lines are decoded like
  :func:`pendc.hil.plants.plant.x4_count_delta` (Gray index difference mod 4: +1, -1, or 2 = lost);
* ``2 i v``: ``step`` low, the integer ``v`` written into state register ``i`` (made public
  through a Verilator configuration file, so the core's text is unchanged), one idle cycle;
* each answer: the reported states, one count per encoder, the channel levels, ``overflow`` and
  ``lost`` (as :mod:`pendc.hil.plants.rtl_harness` answers), flushed at once.

The C++ ``main`` toggles ``clk`` and calls ``eval()`` itself, which runs several hundred
times faster than the event-driven ``--timing`` harness. Each design (core files + main) is
built once and cached under its hash, next to the Verilog harnesses.
"""

from __future__ import annotations

from pathlib import Path

from ...errors import PendcError
from ...model.plant import PlantModel
from .core_ports import CorePorts
from .rtl_build import RUNTIME_OPT, VERILATOR_MAKE_VARS, find_tool, build_cached
from .rtl_plant import RtlPlant

EXECUTABLE = "pendc_hil_cpp"
MAIN_FORMAT = 5          # bump when the C++ main changes shape
MAX_PORT_WIDTH = 64      # every port must fit one C++ integer (Verilator's QData)
# -O2 rather than verilated.mk's -Os: about 15 % more steps per second on this core, where
# the core's own clocked logic takes over 80 % of the time
MAKE_VARS = f"{VERILATOR_MAKE_VARS} OPT_FAST=-O2 {RUNTIME_OPT}"


# C++ shared by every harness around a Verilated core (also bench/core_step_loop.py): a signed port's
# value, and whether the model exposes its clock edge detector (Verilator 5's name for it)
CPP_PORT_HELPERS = """static inline long long sext(uint64_t v, int width) {
    if (width >= 64) return (long long)v;
    const uint64_t sign = 1ULL << (width - 1);
    v &= (sign << 1) - 1;
    return (long long)((v ^ sign) - sign);
}

template <typename R, typename = void> struct HasClkPrev : std::false_type {};
template <typename R>
struct HasClkPrev<R, std::void_t<decltype(std::declval<R&>().__Vtrigprevexpr___TOP__clk__0)>> : std::true_type {};
"""


def cpp_int_type(width: int) -> str:
    """Verilator's C++ container for a port of ``width`` bits."""
    return "CData" if width <= 8 else "SData" if width <= 16 else "IData" if width <= 32 else "QData"


def config_source(module: str, deposit: tuple) -> str:
    """Verilator configuration making the deposit registers of core ``module`` writable from C++
    (and only them)."""
    return "`verilator_config\n" + "".join(f'public_flat_rw -module "{module}" -var "{reg}"\n' for reg, _ in deposit)


def main_source(core: CorePorts, ports: dict, ii: int, deposit: tuple = ()) -> str:
    """The C++ ``main`` around Verilator's model of the core ``core`` names (ports: report.json's
    "ports"); ``deposit``: ``(core register, width)`` pairs a ``2 i v`` request writes."""
    CORE = core.module
    too_wide = [p for p in (core.input,) + core.states if ports[p]["width"] > MAX_PORT_WIDTH]
    if too_wide:
        raise PendcError(f"the C++ Verilator plant handles ports of up to {MAX_PORT_WIDTH} bits; "
                         f"{', '.join(too_wide)} is wider (use --plant golden)")
    uw = ports[core.input]["width"]
    wide = [reg for reg, w in deposit if w > MAX_PORT_WIDTH]
    if wide:
        raise PendcError(f"the C++ Verilator plant deposits registers of up to {MAX_PORT_WIDTH} bits; "
                         f"{', '.join(wide)} is wider")
    loads = "".join(f"        case {i}: core->rootp->{CORE}__DOT__{reg} = ({cpp_int_type(w)})((uint64_t)v & "
                    f"{hex((1 << w) - 1)}ULL); break;\n" for i, (reg, w) in enumerate(deposit))
    value = {p: (f"sext(core->{p}, {ports[p]['width']})" if ports[p]["signed"]
                 else f"(long long)(uint64_t)core->{p}") for p in core.states}
    enc = list(enumerate(core.encoders))
    counters = "".join(f"    long long cnt{i} = 0;\n    int prev{i} = 0;\n" for i, _ in enc)

    def restart(pad):
        return "".join(f"{pad}prev{i} = gray(core->{e.channel_a}, core->{e.channel_b});\n" for i, e in enc)
    count = "".join(f"        {{ const int g = gray(core->{e.channel_a}, core->{e.channel_b}), d = (g - prev{i}) & 3;\n"
                    f"          cnt{i} += (d == 1) - (d == 3); if (d == 2) lost = 1; prev{i} = g; }}\n"
                    for i, e in enc)
    zero = "".join(f"        cnt{i} = 0;\n" for i, _ in enc)
    shown = ([value[p] for p in core.states] + [f"cnt{i}" for i, _ in enc]
             + [f"(long long)core->{c}" for c in core.channels] + ["(long long)core->overflow", "(long long)lost"])
    fmt = " ".join(["%lld"] * len(shown))
    return f"""// pendc HIL plant (pendc.hil.plants.rtl_cpp, format {MAIN_FORMAT}): lockstep over stdin/stdout.
#include "V{CORE}.h"
#include "V{CORE}___024root.h"
#include "verilated.h"
#include <cstdint>
#include <cstdio>
#include <memory>
#include <type_traits>
#include <utility>

// a signed port's bits, sign-extended from its width (Verilator zeroes the unused bits)
{CPP_PORT_HELPERS}
template <typename M, typename R>
static inline void fall(M* core, R* root) {{
    if constexpr (HasClkPrev<R>::value) root->__Vtrigprevexpr___TOP__clk__0 = 0;
    else core->eval();
}}

// Gray index of the channel levels (A, B) along increasing position (A leads)
static inline int gray(int a, int b) {{ return a ? (b ? 2 : 1) : (b ? 3 : 0); }}

struct Harness {{
    std::unique_ptr<VerilatedContext> ctx;
    std::unique_ptr<V{CORE}> core;
{counters}    int lost = 0;

    Harness() : ctx(new VerilatedContext), core(new V{CORE}(ctx.get())) {{
        core->clk = 0;
        core->rst = 1;
        core->step = 0;
        core->{core.input} = 0;
        core->eval();
    }}

    // A falling edge triggers nothing in the core, yet eval() re-runs every input-dependent
    // combinational path (Verilator's "ico" region) on each call. Where the model exposes its
    // edge detector's previous clock value, the falling edge only resets that value (the next
    // rising edge is then seen as one, exactly as after an eval() at clk = 0); else eval().
    void cycle() {{
        core->clk = 1;
        core->eval();
        core->clk = 0;
        fall(core.get(), core->rootp);
    }}

    // after a falling edge: the channel lines change only when a step's update lands
    void count() {{
{count}    }}

    void reset() {{
        core->step = 0;
        core->rst = 1;
        for (int i = 0; i < 3; ++i) cycle();
        core->rst = 0;
{zero}        lost = 0;
{restart("        ")}    }}

    void run(long long u, long long n) {{
        core->{core.input} = ({cpp_int_type(uw)})((uint64_t)u & {hex((1 << uw) - 1)}ULL);
        core->step = 1;
        core->eval();
        for (long long c = n * {ii}LL; c > 0; --c) {{
            cycle();
            count();
        }}
    }}

    // as a testbench deposits a state: step low, the register written between edges, one idle cycle
    void deposit(long long i, long long v) {{
        core->step = 0;
        switch (i) {{
{loads}        default: break;
        }}
        core->eval();
        cycle();
        // a deposited encoder phase is no movement
{restart("        ")}    }}

    void answer() {{
        std::printf("{fmt}\\n", {", ".join(shown)});
        std::fflush(stdout);
    }}
}};

int main(int argc, char** argv) {{
    Harness h;
    h.ctx->commandArgs(argc, argv);
    h.reset();
    h.answer();
    for (;;) {{
        long long kind = -1, u = 0, n = 0;
        const int got = std::scanf("%lld %lld %lld", &kind, &u, &n);
        if (got < 1) break;                    // end of input: the host closed the pipe
        if (got != 3 || kind < 0 || kind > 2 || (kind == 0 && (n < 1 || n > 0x7fffffffLL))
                || (kind == 2 && (u < 0 || u >= {len(deposit)}))) {{
            std::printf("ERROR bad request\\n");
            std::fflush(stdout);
            return 1;
        }}
        if (kind == 1) h.reset();
        else if (kind == 2) h.deposit(u, n);
        else h.run(u, n);
        h.answer();
    }}
    h.core->final();
    return 0;
}}
"""


def _build_command(module: str, work: Path, sources: list) -> list:
    return [find_tool("verilator"), "--cc", "--exe", "--build", "-j", "2", "--top-module", module,
            "-Mdir", str(work / "obj_dir"), "-o", EXECUTABLE, "-O3", "--x-assign", "fast", "--x-initial", "fast",
            "--noassert", "-Wno-fatal", "-Wno-lint", "-MAKEFLAGS", MAKE_VARS] + [str(s) for s in sources]


def build_cpp_harness(files: dict, core: CorePorts, ports: dict, ii: int, deposit: tuple = ()) -> Path:
    """The Verilator C++ plant executable for these HDL files, built once per design hash and cached."""
    def commands_for(folder: Path, sources: list):
        return [_build_command(core.module, folder, sources)], folder / "obj_dir" / EXECUTABLE
    return build_cached("verilator-cpp", files, {"deposit.vlt": config_source(core.module, deposit),
                                                 "main.cpp": main_source(core, ports, ii, deposit)},
                        MAKE_VARS, commands_for, "C++ Verilator plant")


# the fastest bit-exact schedule under Verilator: one clock cycle per step evaluates the datapath
# once, where a pipelined schedule re-evaluates it every cycle (bench/bench_rtl_cpp.py measures both)
FASTEST_SCHEDULE = {"preset": "comb"}


class VerilatorCppPlant(RtlPlant):
    """The generated core under a plain C++ Verilator harness, stepped in lockstep.

    Behaves exactly like ``RtlPlant(model, "verilator")`` (same integers, same overflow and
    lost-count errors, ``initial``, :meth:`raw`, :meth:`close`, ``with``); only the executable
    differs. ``loadable``: build the harness with every state register writable, for
    :meth:`load` (``initial`` implies it; the default harness is faster). ``schedule`` defaults to :data:`FASTEST_SCHEDULE` (every schedule is bit-exact with
    the same golden model, so the fastest to simulate is the same plant)."""

    def __init__(self, model: PlantModel, dt: float = 1e-6, build=None, on_overflow: str = "error",
                 bus: str = "raptor", initial: tuple | None = None, schedule: dict | None = None,
                 loadable: bool = False):
        # "verilator": RtlPlant runs the executable itself and names the simulator in its errors
        self.simulator = "verilator"
        files, report = self._prepare(model, dt, build, on_overflow, bus, initial,
                                      FASTEST_SCHEDULE if schedule is None else schedule)
        # registers made writable from C++ cost speed: only when a state is to be loaded
        self._deposit_ok = loadable or initial is not None
        self.executable = build_cpp_harness(files, self.ports, report["ports"], self.ii,
                                            self._deposit if self._deposit_ok else ())
        self._link = None
        self.overflow_at = None
        self.reset()

    def describe(self) -> dict:
        """As :meth:`RtlPlant.describe`, with the harness named."""
        return dict(super().describe(), harness="C++ (verilator --cc, eval() loop)")
