"""Render the view-model through the Jinja templates and write ``hdl_out/`` atomically.

Python prepares every string (ranges, literals, expressions); the templates only loop
and print. All files are written into a temporary folder beside the target and
swapped in, so a failed build never leaves a half-written ``hdl_out/``. Same typed
graph in, byte-identical files out.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from importlib import resources
from pathlib import Path

import jinja2

from ..atomic import make_public_dir
from ..errors import PendcError
from ..ir.graph import Graph
from . import verilog_text as vtext
from .arith import Block
from .tables_fsm import rom_module
from .viewmodel import CoreView, build_view

# the templates ship in the wheel as pendc/templates/ (pyproject package-data); in the source
# tree and its editable install they are the top-level templates/ folder
TEMPLATES = next((p for p in (Path(str(resources.files("pendc"))) / "templates",
                              Path(__file__).resolve().parents[2] / "templates") if p.is_dir()),
                 Path(__file__).resolve().parents[2] / "templates")
GENERATOR = "pendc"


def _env() -> jinja2.Environment:
    return jinja2.Environment(loader=jinja2.FileSystemLoader(str(TEMPLATES)), trim_blocks=True,
                              lstrip_blocks=True, keep_trailing_newline=True, undefined=jinja2.StrictUndefined,
                              autoescape=False)


def status_nodes(view: CoreView) -> list:
    """The nodes of the debug build's ``overflow_status`` vector: bit i is ``status_nodes[i]``
    (every node with an overflow term, sorted by name, as report.json's "overflow_nodes")."""
    return sorted({node for _, node in view.net.overflow})


def _status_bits(view: CoreView) -> list:
    """One sticky bit per overflowing node: the OR of the node's terms, each counted in the
    cycle that computes it (the gating of the core's single flag)."""
    multicycle = view.ii > 1
    terms: dict = {}
    for wire, node, stage in view.dp.overflow_stages():
        gate = view.dp.cycle_gate(stage) if multicycle else "step"
        terms.setdefault(node, []).append(f"({gate} & {wire})")
    return [{"index": i, "node": node, "hit": " | ".join(terms[node])} for i, node in enumerate(status_nodes(view))]


def _blocks(view: CoreView) -> tuple[list, list]:
    """``(ahead, blocks)``: the declarations printed before every node (wires read above the
    block that assigns them: the shared multipliers), and each block's lines in order (its
    comment, then every wire declared where it is assigned, its registers, its instances)."""
    net = view.net
    decls = {name: (width, signed) for name, width, signed in net.decls}
    rhs = dict(net.assigns)
    piped: dict = {}        # block -> pipeline registers copying one of its wires
    last = Block(("pipeline registers of values declared above",))   # for a source outside every block
    for name, width, signed, source, stage in view.dp.pipe_regs:
        piped.setdefault(id(net.block_of.get(source, last)), []).append((name, width, signed, source, stage))
    ahead, blocks = [], []
    for block in [*net.blocks, last]:
        lines = [ln for c in block.comments for ln in vtext.comment(c)]
        for kind, name in block.items:
            if kind == "instance":
                module, parameters, inst, ports = name
                lines += vtext.wrap(f"{module} #(", parameters, ")") if parameters else [vtext.STEP + module]
                lines += vtext.wrap(f"{inst} (", ports, ");", vtext.STEP * 2)
            elif kind == "reg":
                lines += vtext.declaration("reg", name, *net.regs[name])
            elif kind == "net":
                lines += vtext.declaration("wire", name, *decls[name])
            elif block.early:
                ahead += vtext.declaration("wire", name, *decls[name])
                lines += vtext.wrap(f"assign {name} = ", rhs[name], ";")
            else:
                lines += vtext.declaration("localparam" if kind == "constant" else "wire", name, *decls[name],
                                          rhs=rhs[name])
        for name, width, signed, source, stage in piped.get(id(block), []):
            lines += vtext.comment(f"{source} held for the later cycles (loaded at the end of cycle {stage})")
            lines += vtext.declaration("reg", name, width, signed)
        if block.items or block.node is not None or id(block) in piped:
            blocks.append({"lines": lines})
    return ahead, blocks


def _rule_lines(fsm: dict, indent: str) -> list:
    """The lines of each transition rule of an FSM's always block: its condition and next state."""
    return [vtext.wrap("if (" if i == 0 else "else if (", cond, ")", indent) + [f"{indent}{vtext.STEP}{fsm['state']} <= {nxt};"]
            for i, (cond, nxt) in enumerate(fsm["rules"])]


def core_context(view: CoreView, header: str, dt: float, debug_status: bool = False) -> dict:
    """What templates/core.v.j2 prints: every string and line made here."""
    pw = view.phase_width
    stages = {}
    for n, _, _, src, stage in view.dp.pipe_regs:
        stages.setdefault(stage, []).append({"name": n, "source": src})
    ahead, blocks = _blocks(view)
    multicycle = view.ii > 1
    deep = vtext.STEP * 3
    return {
        "header": header, "dt": repr(dt), "ii": view.ii, "module": view.module,
        "ports": [{"direction": d + (" " if d == "input" else ""), "signed": "signed " if s else "",
                   "range": f"[{w - 1}:0] " if w > 1 else "", "name": n} for d, n, w, s in view.ports],
        "multicycle": multicycle, "phase_msb": pw - 1, "phase_zero": f"{pw}'d0", "phase_one": f"{pw}'d1",
        "phase_last": f"{pw}'d{view.ii - 1}",
        "ahead": ahead, "blocks": blocks,
        "lut_regs": [{"name": n, "source": s, "en": e} for n, _, s, e in view.lut_regs],
        "state_regs": [{"name": n, "reset": reset, "next": nxt} for n, _, reset, nxt in view.registers],
        "fsms": [{"node": f["node"], "state": f["state"], "reset": f["reset"], "rules": _rule_lines(f, deep)} for f in view.fsms],
        "overflow_hit": vtext.wrap("wire overflow_hit = ", view.dp.overflow_hit(multicycle), ";"),
        "pipe_stages": [{"cond": f"phase == {pw}'d{c}", "regs": stages[c]} for c in sorted(stages)],
        "outputs": [{"port": p, "wire": w} for p, w in view.outputs],
        "status_bits": [dict(b, lines=vtext.wrap("if (", b["hit"], ")", deep)) for b in _status_bits(view)]
        if debug_status else [],
    }


def rom_files(view: CoreView, header: str, env: jinja2.Environment) -> dict:
    """The table ROM's files: its one parameterised module (none without tables) and each
    table's memory-initialisation file, which the instance in the core names."""
    if not view.roms:
        return {}
    name = rom_module(view.module)
    files = {f"{name}.v": env.get_template("table_rom.v.j2").render(header=header, module=view.module, name=name)}
    words = env.get_template("table_rom.mem.j2")
    for r in view.roms:
        about = (f"Table {r.table} of {view.module}, read by {name} {r.inst} ($readmemh): {len(r.words)} words "
                 f"of {r.data_width} bits, {r.layout}; one word a line, hexadecimal.")
        files[r.file] = words.render(header=header, comment=vtext.comment(about, indent=""), words=r.words)
    return files


def render_core(graph: Graph, source: str = "", module: str | None = None,
                schedule=None, debug_status: bool = False) -> tuple[CoreView, dict]:
    """The core's files as ``{filename: text}`` plus its view-model (``schedule``: see build_view).

    ``debug_status``: the debug build, whose core has one more output, ``overflow_status``:
    a sticky bit per node that can overflow (order: :func:`status_nodes`), set at the end of
    the step in which the node left its range, cleared by reset. Without it the files are
    those of the normal build, byte for byte."""
    view = build_view(graph, module, schedule)
    module = view.module
    dt = dict(graph.info).get("dt", 1e-6)
    header = f"Generated by {GENERATOR} from {source or 'a model'}; do not edit."
    env = _env()
    context = core_context(view, header, dt, debug_status)
    files = {f"{module}.v": env.get_template("core.v.j2").render(**context)}
    files.update(rom_files(view, header, env))
    return view, files


def build_id(files: dict) -> int:
    """32-bit identifier of a build: a hash of every emitted file."""
    h = hashlib.sha256()
    for name in sorted(files):
        h.update(name.encode() + b"\0" + files[name].encode())
    return int.from_bytes(h.digest()[:4], "big")


# what a build folder holds: a folder with anything else in it is the user's, not ours to replace
_BUILD_SUFFIXES = frozenset({".v", ".sv", ".vh", ".json", ".mem"})


def _refuse_foreign(out: Path, files: dict) -> None:
    """Raise unless ``out`` is absent, empty, or holds only files a build writes."""
    if not out.exists() and not out.is_symlink():
        return
    if out.is_symlink() or not out.is_dir():
        kind = "a symbolic link" if out.is_symlink() else "a file" if out.is_file() else "not a folder"
        raise PendcError(f"{out}: is {kind}; refusing to replace it with a folder of Verilog")
    suffixes = _BUILD_SUFFIXES | {Path(name).suffix for name in files}
    try:
        foreign = sorted(p.name for p in out.iterdir()
                         if p.is_symlink() or not p.is_file() or p.suffix not in suffixes)
    except OSError as exc:
        raise PendcError(f"{out}: cannot read the folder: {exc.strerror or exc}") from None
    if foreign:
        raise PendcError(f"{out}: holds {', '.join(foreign[:3])}{' ...' if len(foreign) > 3 else ''}, "
                         f"which a build does not write; refusing to replace the folder (give a new or empty one)")


def write_tree(out_dir: str | os.PathLike, files: dict) -> None:
    """Replace ``out_dir`` by exactly ``files`` (name -> text), via a temporary folder and renames.

    Refuses (:class:`PendcError` naming ``out_dir``) to replace a file, a symbolic link or a
    folder holding anything a build does not write; the new folder's mode follows the umask."""
    out = Path(out_dir)
    parent = out.parent if str(out.parent) else Path(".")
    _refuse_foreign(out, files)
    blocking = next((a for a in out.parents if a.exists() and not a.is_dir()), None)
    if blocking is not None:   # else mkdir's "File exists" would not say which
        raise PendcError(f"{out}: {blocking} is not a folder")
    tmp = old = None
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = make_public_dir(f".{out.name}.", parent)
        for name, text in sorted(files.items()):
            (tmp / name).write_text(text, encoding="utf-8", newline="\n")
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=parent))
            old.rmdir()
            os.replace(out, old)
        os.replace(tmp, out)
        tmp = None
        if old is not None:
            shutil.rmtree(old)
    except OSError as exc:
        if old is not None and old.exists() and not out.exists():
            os.replace(old, out)   # the swap failed half-way: the user's previous build comes back
        raise PendcError(f"{out}: cannot write the build folder: {exc.strerror or exc}") from None
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


def dumps_json(obj) -> str:
    return json.dumps(obj, indent=2, sort_keys=False) + "\n"
