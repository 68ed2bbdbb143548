"""``pendc build``: the whole HDL output of one compiled model, and its report.json."""

from __future__ import annotations

from pathlib import Path

from ..errors import PendcError
from ..ir.graph import Graph
from ..ir.nodes import Kind
from ..model.interface import require_interface
from .emit import build_id, dumps_json, render_core, status_nodes, write_tree
from .wrapper import BUSES, render_wrapper


def port_formats(graph: Graph) -> dict:
    """The core's data ports (the plant's input, reported states and converter codes) and their formats."""
    iface = require_interface(graph)
    ports = {iface.input.name: graph[iface.input.name].qformat}
    ports.update({p: graph.output(p).qformat for p in iface.outputs})
    ports.update({s.code_port: graph.output(s.code_port).qformat for s in iface.sensors
                  if s.is_adc and s.code_port in dict(graph.outputs)})
    return {p: {"signed": f.signed, "width": f.width, "frac": f.frac} for p, f in ports.items()}


def build_request(target: str, preset: str | None = None, ii: int | None = None, dsp: int | None = None) -> dict:
    """The request ``pendc build`` records in report.json: the target, and the schedule options
    that were given. Whatever emits a build's files passes this, so its report.json is the one
    ``pendc build --check`` compares."""
    request = {"target": target, "preset": preset, "ii": ii, "dsp": dsp}
    return {k: v for k, v in request.items() if v is not None}


def schedule_of(graph: Graph, request: dict | None = None):
    """The schedule a build request asks for: ``{"target", "preset", "ii", "dsp"}`` (all optional;
    none: the default preset). Deterministic, so a report.json's request rebuilds the same core."""
    from ..passes.qformats import MULT_SHAPES
    from ..passes.schedule import schedule_for
    req = dict(request or {})
    target = req.get("target") or "ecp5-85k"
    preset = req.get("preset")
    if preset is None and req.get("ii") is None:
        from ..passes.schedule import DEFAULT_PRESET
        preset = DEFAULT_PRESET
    return schedule_for(graph, MULT_SHAPES[target], ii=req.get("ii"), dsp=req.get("dsp"), preset=preset,
                        target=target)


def build_hdl(graph: Graph, resources: dict, source: str = "", bus: str = "raptor",
              request: dict | None = None, debug_status: bool = False) -> dict:
    """All output files, ``report.json`` included, as ``{filename: text}``; ``request``: the
    schedule options (see :func:`schedule_of`). ``debug_status``: the debug build, with a
    sticky overflow bit per node readable over the bus (OVERFLOW_STATUS_k registers)."""
    schedule = schedule_of(graph, request)
    view, files = render_core(graph, source, schedule=schedule, debug_status=debug_status)
    if schedule.units:      # shared multipliers: the blocks the units need, and one per product without a unit
        from ..passes.qformats import MULT_SHAPES
        from ..passes.share import scheduled_blocks
        resources = dict(resources, dsp_scheduled=scheduled_blocks(graph, schedule, MULT_SHAPES[schedule.target]))
    ident = build_id(files)
    status = status_nodes(view) if debug_status else ()
    wrapper_files, regmap = render_wrapper(view, port_formats(graph), ident, bus, status_nodes=status)
    files.update(wrapper_files)
    report = {
        "top": view.module,
        "wrapper": regmap["module"],
        "bus": bus,
        "dt": dict(graph.info).get("dt", 1e-6),
        "ii": view.ii,
        "build_id": f"0x{ident:08x}",
        "source": source,
        "ports": port_formats(graph),
        "files": sorted(files) + ["report.json"],
        "qformats": {n.name: str(n.qformat) for n in graph.nodes if n.kind is not Kind.CONST},
        "overflow_nodes": sorted({node for _, node in view.net.overflow}),
        "resources": resources,
        "schedule": dict(schedule.to_json(), request=dict(request or {})),
        "registers": regmap["registers"],
    }
    if debug_status:
        report.update(debug_status=True, overflow_status_nodes=list(status))
    files["report.json"] = dumps_json(report)
    return files


def write_hdl(out_dir, files: dict) -> None:
    write_tree(out_dir, files)


def differences(out_dir, files: dict) -> list:
    """Names of files that differ between ``out_dir`` and ``files`` (missing and extra included).

    Raises :class:`PendcError` naming ``out_dir`` if it is missing or not a folder."""
    out = Path(out_dir)
    if not out.is_dir():   # "every file differs" would hide the real problem
        raise PendcError(f"{out}: folder does not exist" if not out.exists()
                         else f"{out}: is not a folder")
    present = {p.name for p in out.iterdir() if p.is_file()}
    diff = sorted(present ^ set(files))
    for name in sorted(present & set(files)):
        if (out / name).read_text(encoding="utf-8") != files[name]:
            diff.append(name)
    return diff


__all__ = ["BUSES", "build_hdl", "write_hdl", "differences", "port_formats", "schedule_of"]
