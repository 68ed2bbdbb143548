"""A plant file's ``[reference_formats]``: the fixed-point formats a published design of the
plant chose, for reports to set beside pendc's own.

A plant someone built before (a thesis, a vendor's core) may have printed a format for each
state register and some intermediates, and the largest value it simulated for some of them
(from which the sizing rule gives the format, a check of the rule against the published
figures). The file names the nodes as pendc's graph of the plant names them::

    [reference_formats]
    source = "where the figures are printed"
    x = { format = "FIX32_31" }
    ddx = { format = "FIX32_26", max = 18.39 }
"""

from __future__ import annotations

import re

from .table_reader import TableReader

FIX = re.compile(r"FIX(\d+)_(\d+)$")


def read_reference_formats(top: TableReader, nodes: set) -> tuple:
    """``(formats, source)``: node -> ``{"format": "FIX<w>_<f>", "max": ...}`` (``max`` where
    printed) and the figures' source; ``nodes`` are the names the file may give (its states,
    their rates and accelerations, intermediates and quantities)."""
    r = top.sub("reference_formats")
    if r is None:
        return {}, ""
    out = {}
    for name in r.table:
        if name == "source":
            continue
        if name not in nodes:
            r.fail(f"'{name}' is not a state, rate, acceleration, intermediate or quantity of the plant", name)
        row = r.sub(name)
        row.only(("format", "max"))
        fmt = row.string("format", required=True)
        m = FIX.match(fmt)
        if not m or not 0 <= int(m.group(2)) <= int(m.group(1)) or int(m.group(1)) == 0:
            row.fail(f"'{fmt}' is not a format FIX<width>_<fraction bits>", "format")
        entry = {"format": fmt}
        top_value = row.number("max", positive=True)
        if top_value is not None:
            entry["max"] = top_value
        out[name] = entry
    return out, r.string("source", "")
