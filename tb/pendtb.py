"""Host side of the cocotb regression: the HDL under test, golden vectors, simulator runs.

The runner (``tb/run.py``, ``tests/test_sim.py``) calls :func:`prepare` once: it emits the
HDL of the default model (or uses the repository's ``hdl_out/`` when ``pendc build
--check`` says it is current), writes the testbench top ``tb_pendulum_core`` and
computes every golden expectation the cocotb modules need into one pickle. The
simulators then only compare: the cocotb modules (``test_core.py``, ``test_bus.py``)
load that file (path in ``$PENDC_TB_VECTORS``) inside the simulator process.

Golden data come from :class:`pendc.golden.GoldenModel` (the numba kernel) and, for
runs that start from a state reached deep inside a stimulus, from the same kernel resumed
from that state (:class:`pendc.golden.GoldenStepper`), cross-checked by the reference
:class:`pendc.ir.interpret.FixedInterpreter` on a copy of the graph whose registers and
FSMs reset to that state (the first steps of every such window, and the overflow scenario).
"""

from __future__ import annotations

import json
import pickle
import time
from dataclasses import dataclass, field
from pathlib import Path

from pendc.backend.hdl import port_formats  # noqa: F401  (re-exported)
from tbconfig import *  # noqa: F401,F403  (the constants, re-exported for the cocotb modules)
from tbconfig import LONG_CHUNKS, REPO, TB_TOP, TEST_VECTORS, verilog_files
from golden_vectors import *  # noqa: F401,F403
from golden_vectors import make_vectors
from simulators import *  # noqa: F401,F403


def model_and_build(model_path=None, request: dict | None = None):
    """The model and its compiled build, with the arithmetic ``pendc build`` takes for the
    schedule ``request``'s preset (the step-time presets build the short chain)."""
    from pendc import load_model
    from pendc.caching.build_cache import compile_cached
    from pendc.passes.pipeline import options_from_model, preset_options
    model = load_model(model_path)
    return model, compile_cached(model, options_from_model(model, **preset_options((request or {}).get("preset"))))


def source_name(model) -> str:
    """The model's name in the files, as ``pendc build`` writes it: its fingerprint and the
    pendc version, never its path."""
    from pendc.model.modelfile import build_source
    return build_source(model)




def recorded_request(build, request: dict | None = None) -> dict:
    """The request ``pendc build`` with ``request``'s options records for ``build``."""
    from pendc.backend.hdl import build_request
    return build_request(**{"target": build.options.target, **(request or {})})


def emit_hdl(model, build, out_dir: Path, bus: str = "raptor", request: dict | None = None) -> dict:
    """Write what ``pendc build --bus BUS -o OUT_DIR`` writes; returns report.json.

    Falls back to the core alone (and a minimal report.json) if the bus wrapper
    backend cannot be imported."""
    from pendc.backend.emit import dumps_json, render_core, write_tree
    source = source_name(model)
    try:
        from pendc.backend.hdl import build_hdl
    except ImportError:
        build_hdl = None
    if build_hdl is not None:
        files = build_hdl(build.graph, build.resources.to_json(), source=source, bus=bus,
                          request=recorded_request(build, request))
    else:
        view, files = render_core(build.graph, source)
        files["report.json"] = dumps_json({"top": view.module, "wrapper": None, "bus": None, "ii": view.ii,
                                           "dt": 1e-6, "ports": port_formats(build.graph),
                                           "files": sorted(files) + ["report.json"], "registers": []})
    write_tree(out_dir, files)
    return json.loads(files["report.json"])


def emit_debug_hdl(model, build, out_dir: Path, bus: str = "raptor", request: dict | None = None) -> dict:
    """Write the debug build (core with ``overflow_status``, OVERFLOW_STATUS_k registers) of
    ``model`` for ``bus`` into ``out_dir``, as ``pendc build --debug-status`` does; returns its
    report.json (``overflow_status_nodes``: the bit order)."""
    from pendc.backend.emit import write_tree
    from pendc.backend.hdl import build_hdl
    files = build_hdl(build.graph, build.resources.to_json(), source=source_name(model), bus=bus,
                      request=recorded_request(build, request), debug_status=True)
    write_tree(out_dir, files)
    return json.loads(files["report.json"])


def repo_hdl_current(model=None, build=None) -> bool:
    """True if the repository's hdl_out/ is what ``pendc build`` emits now (the check of
    ``pendc build --check``, done in-process on an already compiled model)."""
    out = REPO / "hdl_out"
    if not (out / "report.json").is_file():
        return False
    try:
        from pendc.backend.hdl import build_hdl, differences
    except ImportError:
        return False
    if model is None or build is None:
        model, build = model_and_build()
    files = build_hdl(build.graph, build.resources.to_json(), source=source_name(model), bus="raptor",
                      request=recorded_request(build))
    return not differences(out, files)




def core_ports_of(build):
    """The core's module and port names (:class:`pendc.hil.plants.core_ports.CorePorts`) from the
    plant interface the build's graph carries."""
    from pendc.hil.plants.core_ports import CorePorts
    return CorePorts.of_graph(build.graph)


def tb_top_source(ports: dict, core) -> str:
    """The cocotb toplevel of the core tests: the core plus the testbench's own x4 decoders.

    ``ports``: report.json's "ports"; ``core``: the core's names (:func:`core_ports_of`). The
    converters' code ports are passed through as they are. One decoder per encoder, its count on ``cnt_<encoder>``. The decoders count every edge of A and
    B (up when A leads); their counts include a change of the lines in the current cycle, so at
    a step boundary they already count the state just written. ``enc_err`` is sticky on a
    change of both lines of an encoder at once (not a quadrature step)."""
    from pendc.hil.plants.core_ports import instance_line, verilog_decl
    lines = [
        "// Testbench top for the cocotb regression (tb/pendtb.py); not part of the design.",
        "`default_nettype none",
        f"module {TB_TOP} (",
        "    input  wire clk,", "    input  wire rst,", "    input  wire step,", "    output wire ready,",
        f"    input  wire {verilog_decl(ports[core.input])} {core.input},",
    ]
    lines += [f"    output wire {verilog_decl(ports[p])} {p}," for p in core.states]
    lines += [f"    output wire {p}," for p in core.channels]
    lines += [f"    output wire {verilog_decl(ports[p])} {p}," for p in core.codes]
    lines += ["    output wire overflow,"]
    lines += [f"    output wire signed [31:0] cnt_{e.name}," for e in core.encoders]
    lines += ["    output wire enc_err", ");"]
    lines.append("    " + instance_line(core))
    errs = [f"err_{e.name}" for e in core.encoders]
    if errs:
        lines += [f"    wire {', '.join(errs)};", f"    assign enc_err = {' | '.join(errs)};"]
    else:
        lines.append("    assign enc_err = 1'b0;")
    lines += [f"    tb_x4_decoder dec_{e.name} (.clk(clk), .rst(rst), .a({e.channel_a}), .b({e.channel_b}), "
              f".count(cnt_{e.name}), .err(err_{e.name}));" for e in core.encoders]
    lines += ["endmodule", "",
              "module tb_x4_decoder (input wire clk, input wire rst, input wire a, input wire b,",
              "                      output wire signed [31:0] count, output reg err);",
              "    reg a_q, b_q;",
              "    reg signed [31:0] count_q;",
              "    wire moved = (a ^ a_q) ^ (b ^ b_q);        // exactly one line changed",
              "    wire both = (a ^ a_q) & (b ^ b_q);",
              "    wire up = a ^ b_q;                         // new A differs from old B: A leads",
              "    assign count = moved ? (up ? count_q + 32'sd1 : count_q - 32'sd1) : count_q;",
              "    always @(posedge clk) begin",
              "        a_q <= a;",
              "        b_q <= b;",
              "        if (rst) begin",
              "            count_q <= 32'sd0;",
              "            err <= 1'b0;",
              "        end else begin",
              "            count_q <= count;",
              "            if (both) err <= 1'b1;",
              "        end",
              "    end",
              "endmodule", "`default_nettype wire", ""]
    return "\n".join(lines)


# ---------------------------------------------------------------- golden vectors


@dataclass
class Prepared:
    """What the simulators need: HDL folders per bus, their report.json, the testbench top and
    the golden vector file (after :func:`add_vectors`)."""

    work: Path
    hdl: dict                     # bus -> folder with the emitted HDL
    report: dict                  # bus -> report.json
    tb_top: Path
    vectors: Path
    repo_hdl: bool = False
    timings: dict = field(default_factory=dict)
    build: object = None          # pendc BuildResult the HDL came from


def prepare_hdl(work: Path, use_repo_hdl: bool = True, log=print, model_path=None,
                request: dict | None = None) -> Prepared:
    """HDL for both buses and the testbench top under ``work`` (no vectors yet): of the
    model file ``model_path`` (default model if None) with the schedule ``request``
    (``pendc build`` options: preset, ii, dsp; None: the default). The repository's
    hdl_out/ is used only for the default model and schedule, and only when current."""
    work = Path(work)
    work.mkdir(parents=True, exist_ok=True)
    timings = {}
    t0 = time.time()
    model, build = model_and_build(model_path, request)
    timings["compile"] = time.time() - t0
    t0 = time.time()
    hdl, reports = {}, {}
    repo = use_repo_hdl and model_path is None and not request and repo_hdl_current(model, build)
    if repo:
        reports["raptor"] = json.loads((REPO / "hdl_out" / "report.json").read_text())
        if reports["raptor"].get("bus") == "raptor":
            hdl["raptor"] = REPO / "hdl_out"
        else:
            repo = False
    for bus in ("raptor", "axi-lite"):
        if bus in hdl:
            continue
        out = work / f"hdl_{bus.replace('-', '')}"
        reports[bus] = emit_hdl(model, build, out, bus, request)
        hdl[bus] = out
    timings["emit"] = time.time() - t0
    tb_top = work / f"{TB_TOP}.v"
    tb_top.write_text(tb_top_source(reports["raptor"]["ports"], core_ports_of(build)))
    log(f"pendtb: HDL from {'the repository hdl_out/ (current) and ' + str(hdl['axi-lite']) if repo else work}")
    return Prepared(work=work, hdl=hdl, report=reports, tb_top=tb_top, vectors=work / "vectors.pickle",
                    repo_hdl=repo, timings=timings, build=build)


def add_vectors(prep: Prepared, log=print, **options) -> Prepared:
    """Compute the golden vectors for a prepared HDL folder (prep.vectors); ``options`` go to
    :func:`golden_vectors.make_vectors` (``stimuli_names``, ``window``, ``long_chunks``: a shorter run)."""
    t0 = time.time()
    vec = make_vectors(prep.build, prep.report["raptor"], log=log, **options)
    vec["hdl"] = {b: str(p) for b, p in prep.hdl.items()}
    vec["reports"] = prep.report
    with open(prep.vectors, "wb") as fh:
        pickle.dump(vec, fh, protocol=pickle.HIGHEST_PROTOCOL)
    prep.timings["vectors"] = time.time() - t0
    log(f"pendtb: golden vectors {prep.vectors} ({prep.timings['vectors']:.1f} s)")
    return prep


def vector_options(testcase: str | None) -> dict:
    """The :func:`golden_vectors.make_vectors` options that compute what the cocotb tests
    ``testcase`` selects (comma-separated names, matched as cocotb's runner matches them: the
    end of ``module.test``) read of the vectors (:data:`tbconfig.TEST_VECTORS`), and no more;
    every test when ``testcase`` is None or selects none of them."""
    names = [n.strip() for n in (testcase or "").split(",") if n.strip()]
    picked = [need for test, need in TEST_VECTORS.items() if any(test.endswith(n) for n in names)]
    if not picked:
        return {}
    windows = {s for need in picked for s in need.get("windows", ())}
    long = {s for need in picked for s in need.get("long", ())}
    return {"stimuli_names": tuple(sorted(windows)), "long_chunks": {s: LONG_CHUNKS[s] for s in sorted(long)},
            "overflow": any(need.get("overflow") for need in picked), "bus": any(need.get("bus") for need in picked)}


def prepare(work: Path, use_repo_hdl: bool = True, log=print, model_path=None, request: dict | None = None,
            testcase: str | None = None) -> Prepared:
    """HDL for both buses, the testbench top and the golden vectors, under ``work`` (only what
    the cocotb tests ``testcase`` read, when given: :func:`vector_options`)."""
    return add_vectors(prepare_hdl(work, use_repo_hdl, log, model_path, request), log, **vector_options(testcase))


# ---------------------------------------------------------------- simulators
