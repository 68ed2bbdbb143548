"""Typed access to one table of a plant file, with errors that name ``file: key``.

:mod:`pendc.model.plantfile` reads every table through a :class:`TableReader`: each getter
checks the value's type (a string, a finite number, a whole number, a [low, high] pair, a
list of names, a vector of expressions) and raises a one-line
:class:`~pendc.errors.PendcError` naming the file and the dotted key when it is wrong.
"""

from __future__ import annotations

import math

from ..errors import PendcError
from .definition import Param


class TableReader:
    """Typed access to one table of the file, with errors that name ``file: key``."""

    def __init__(self, source: str, path: str, table):
        self.source, self.path = source, path
        if not isinstance(table, dict):
            self.fail(f"must be a table, got {kind_of(table)}")
        self.table = table

    def where(self, key: str = "") -> str:
        key = f"{self.path}.{key}" if key and self.path else (key or self.path)
        return f"{self.source}: {key}" if self.source and key else (self.source or key)

    def fail(self, why: str, key: str = ""):
        raise PendcError(f"{self.where(key)}: {why}")

    def only(self, allowed):
        extra = [k for k in self.table if k not in allowed]
        if extra:
            self.fail(f"unknown key '{extra[0]}' (allowed: {', '.join(allowed)})")

    def text(self, key, default=None, required=False) -> str:
        if key not in self.table:
            if required:
                self.fail("is missing", key)
            return default
        v = self.table[key]
        if isinstance(v, bool) or not isinstance(v, (str, int, float)):
            self.fail(f"must be a string, got {kind_of(v)}", key)
        return str(v) if isinstance(v, str) else repr(v)

    def string(self, key, default="", required=False) -> str:
        if key not in self.table:
            if required:
                self.fail("is missing", key)
            return default
        v = self.table[key]
        if not isinstance(v, str):
            self.fail(f"must be a string, got {kind_of(v)}", key)
        return v

    def number(self, key, default=None, required=False, positive=False) -> float | None:
        if key not in self.table:
            if required:
                self.fail("is missing", key)
            return default
        v = self.table[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            self.fail(f"must be a finite number, got {v!r}", key)
        if positive and v <= 0:
            self.fail(f"must be positive, got {v!r}", key)
        return float(v)

    def integer(self, key, default=None, required=False) -> int | None:
        if key not in self.table:
            if required:
                self.fail("is missing", key)
            return default
        v = self.table[key]
        if isinstance(v, bool) or not isinstance(v, int) or v <= 0:
            self.fail(f"must be a positive whole number, got {v!r}", key)
        return v

    def names(self, key) -> tuple:
        v = self.table.get(key, [])
        if not isinstance(v, list) or not all(isinstance(n, str) for n in v):
            self.fail("must be a list of names", key)
        return tuple(v)

    def pair(self, key, required=False):
        if key not in self.table:
            if required:
                self.fail("is missing: give [low, high]", key)
            return None
        v = self.table[key]
        if (not isinstance(v, list) or len(v) != 2 or any(isinstance(x, bool) or not isinstance(x, (int, float))
                                                         or not math.isfinite(x) for x in v) or not v[0] < v[1]):
            self.fail(f"must be [low, high] with low < high, got {v!r}", key)
        return float(v[0]), float(v[1])

    def sub(self, key, required=False) -> "TableReader | None":
        if key not in self.table:
            if required:
                self.fail("is missing", key)
            return None
        return TableReader(self.source, f"{self.path}.{key}" if self.path else key, self.table[key])


def kind_of(v) -> str:
    return {bool: "a boolean", str: "a string", int: "a number", float: "a number", list: "a list",
            dict: "a table"}.get(type(v), type(v).__name__)


# Verilog-2005 keywords (IEEE 1364-2005 Annex B) and SystemVerilog's common ones, which a
# Verilator or a vendor tool reading the core as SystemVerilog reserves too; and the ports every
# core has. A name that becomes a Verilog identifier (the core, the input, a state, a sensor)
# must be none of them: `module module (` and a state named `step` built Verilog that did not
# parse, or a traceback (round I).
VERILOG_WORDS = frozenset("""
always and assign automatic begin buf bufif0 bufif1 case casex casez cell cmos config deassign default
defparam design disable edge else end endcase endconfig endfunction endgenerate endmodule endprimitive
endspecify endtable endtask event for force forever fork function generate genvar highz0 highz1 if
ifnone incdir include initial inout input instance integer join large liblist library localparam
macromodule medium module nand negedge nmos nor noshowcancelled not notif0 notif1 or output parameter
pmos posedge primitive pull0 pull1 pulldown pullup pulsestyle_onevent pulsestyle_ondetect rcmos real
realtime reg release repeat rnmos rpmos rtran rtranif0 rtranif1 scalared showcancelled signed small
specify specparam strong0 strong1 supply0 supply1 table task time tran tranif0 tranif1 tri tri0 tri1
triand trior trireg unsigned use uwire vectored wait wand weak0 weak1 while wire wor xnor xor
bit byte logic int shortint longint string class struct union enum typedef interface package
""".split())
CORE_PORTS = frozenset(("clk", "rst", "step", "ready", "overflow"))


def check_identifier(r: TableReader, name: str, what: str, hdl: bool = False):
    """A valid name; ``hdl``: one that becomes a Verilog identifier of the core."""
    if not name.isidentifier() or name.startswith("_"):
        r.fail(f"'{name}' is not a valid {what} name (letters, digits and _, not starting with a digit or _)")
    if hdl and name.lower() in VERILOG_WORDS:
        r.fail(f"'{name}' is a Verilog keyword and cannot name a {what} (it names a port or module of the core)")
    if hdl and name in CORE_PORTS:
        r.fail(f"'{name}' is a port every core has ({', '.join(sorted(CORE_PORTS))}): choose another {what} name")


def read_param(r: TableReader, name: str, positive_default: bool) -> Param:
    check_identifier(r, name, "parameter")
    p = r.sub(name)
    p.only(("unit", "meaning", "default", "bounds", "value", "optional"))
    unit = p.string("unit", required=True)
    meaning = p.string("meaning", required=True)
    bounds = p.pair("bounds")
    value = p.number("value")
    default = p.number("default", value)
    if bounds is None:
        lo, hi = (0.0, math.inf) if positive_default else (-math.inf, math.inf)
    else:
        lo, hi = bounds
    if default is None:
        default = lo if math.isfinite(lo) else 0.0
    if not lo <= default <= hi:
        p.fail(f"default {default:g} is outside bounds [{lo:g}, {hi:g}]")
    optional = p.table.get("optional", False)
    if not isinstance(optional, bool):
        p.fail("must be true or false", "optional")
    return Param(name, unit, default, lo, hi, meaning, optional, positive=bounds is None and positive_default)


def read_period(r: TableReader):
    period = r.table.get("period")
    if period is None:
        return None
    if period == "none":
        return "none"
    return r.number("period", positive=True)


def read_vector(r: TableReader, key: str, required=False) -> tuple:
    if key not in r.table:
        if required:
            r.fail("is missing", key)
        return ()
    v = r.table[key]
    if not isinstance(v, list) or not 2 <= len(v) <= 3 or not all(
            isinstance(x, (str, int, float)) and not isinstance(x, bool) for x in v):
        r.fail("must be a list of 2 or 3 expressions (the last component points up)", key)
    return tuple(x if isinstance(x, str) else repr(x) for x in v)
