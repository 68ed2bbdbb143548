"""How Verilog-2005 spells the IR's fixed-point arithmetic.

Every helper appends sized wire declarations and continuous assignments to a
:class:`Netlist` and returns the name of the wire that holds the result, so no
expression ever relies on Verilog's context-dependent widths: operands are
extended explicitly, results are declared at exactly the width they need, and bits
that a rounding shift drops are collected in ``*_unused`` wires (Verilator's
default ``--unused-regexp``), which keeps ``verilator -Wall`` silent.
The semantics are those of :func:`pendc.ir.qformat.requantize`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..ir.qformat import Overflow, QFormat, Rounding


@dataclass
class Netlist:
    """Flat lists the templates print: declarations, assignments, overflow terms."""

    decls: list = field(default_factory=list)      # (name, width, signed)
    assigns: list = field(default_factory=list)    # (lhs, rhs)
    overflow: list = field(default_factory=list)   # (wire, node name)

    def wire(self, name: str, width: int, rhs: str, signed: bool = True) -> str:
        self.decls.append((name, width, signed))
        self.assigns.append((name, rhs))
        return name


def literal(value: int, width: int) -> str:
    """A sized signed decimal literal (Verilog has no negative literal: negate a positive one)."""
    return f"{width}'sd{value}" if value >= 0 else f"-{width}'sd{-value}"


def ulit(value: int, width: int) -> str:
    return f"{width}'d{value}"


def extend(sig: str, width: int, signed: bool, to: int) -> str:
    """``sig`` (``width`` bits) sign- or zero-extended to ``to`` bits, as an expression."""
    if to == width:
        return sig
    if to < width:
        raise ValueError(f"cannot extend {sig} from {width} to {to} bits")
    pad = f"{{{to - width}{{{bits(sig, width, width - 1)}}}}}" if signed else f"{to - width}'d0"
    return f"{{{pad}, {sig}}}"


def bits(sig: str, width: int, hi: int, lo: int | None = None) -> str:
    """Bits ``hi..lo`` of ``sig`` (``width`` bits); a 1-bit wire is a scalar and takes no select."""
    lo = hi if lo is None else lo
    if width == 1:
        return sig
    return f"{sig}[{hi}]" if hi == lo else f"{sig}[{hi}:{lo}]"


def aligned(sig: str, fmt: QFormat, frac: int, width: int) -> str:
    """``sig`` re-expressed with ``frac`` fraction bits (>= its own) in ``width`` bits."""
    k = frac - fmt.frac
    body = extend(sig, fmt.width, fmt.signed, width - k)
    return body if k == 0 else f"{{{body}, {k}'d0}}"


def requantize(net: Netlist, base: str, exact: str, width: int, frac: int, out: QFormat,
               rounding: Rounding, overflow: Overflow, node: str) -> str:
    """Fit the signed exact value ``exact`` (``width`` bits, ``frac`` fraction bits) into ``out``.

    Returns the name of a wire of ``out.width`` bits; registers the overflow wire, if the
    value can overflow at all, under ``node``.
    """
    sh = frac - out.frac
    if sh > 0:
        if rounding is Rounding.NEAREST:
            rw = max(width, sh) + 1          # holds the exact value plus half an LSB of the result
            r = net.wire(f"{base}_r", rw, f"{extend(exact, width, True, rw)} + {ulit(1 << (sh - 1), rw)}")
            src, src_w = r, rw
        else:
            src, src_w = exact, width
        if sh < src_w:
            net.wire(f"{base}_unused", sh, bits(src, src_w, sh - 1, 0), signed=False)
            s = net.wire(f"{base}_s", src_w - sh, bits(src, src_w, src_w - 1, sh))
            s_w = src_w - sh
        else:   # every bit but the sign is shifted out: the result is 0 or -1
            if src_w > 1:
                net.wire(f"{base}_unused", src_w - 1, bits(src, src_w, src_w - 2, 0), signed=False)
            s, s_w = net.wire(f"{base}_s", 1, bits(src, src_w, src_w - 1)), 1
    elif sh < 0:
        s = net.wire(f"{base}_s", width - sh, f"{{{exact}, {-sh}'d0}}")
        s_w = width - sh
    else:
        s, s_w = exact, width
    w = out.width
    sign = bits(s, s_w, s_w - 1)
    if out.signed:
        if s_w <= w:
            return net.wire(base, w, extend(s, s_w, True, w), out.signed)
        top = bits(s, s_w, s_w - 1, w - 1)
        out_of_range = f"~((&{top}) | ~(|{top}))"
    elif s_w <= w:       # an unsigned result only overflows when negative
        out_of_range = sign
    else:
        out_of_range = f"|{bits(s, s_w, s_w - 1, w)}"
    ovf = net.wire(f"{base}_ovf", 1, out_of_range, signed=False)
    net.overflow.append((ovf, node))
    low = bits(s, s_w, w - 1, 0) if s_w > w else extend(s, s_w, True, w)
    if overflow is Overflow.SATURATE:
        hi, lo = ulit(out.max_int & ((1 << w) - 1), w), ulit(out.min_int & ((1 << w) - 1), w)
        return net.wire(base, w, f"{ovf} ? ({sign} ? {lo} : {hi}) : {low}", out.signed)
    return net.wire(base, w, low, out.signed)
