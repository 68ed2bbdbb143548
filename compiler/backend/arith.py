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
class Block:
    """Declarations the core prints together under one comment: an IR node's value and its
    helper wires and registers (``node`` set), or a helper section of the core.

    ``items`` are ``(kind, name)`` in declaration order, kind one of ``"wire"`` (declared and
    assigned where it stands), ``"constant"`` (a localparam), ``"reg"`` (loaded by an always
    block further down), ``"net"`` (declared only: driven by an instance) and ``"instance"``
    (``name`` is the instance: module, parameters, name and ports, see :meth:`Netlist.instance`). ``early``: the block's wires are read before it in the
    text (a shared multiplier's operands and product), so they are declared ahead of every
    node and assigned in the block."""

    comments: tuple
    node: str | None = None
    items: list = field(default_factory=list)
    early: bool = False


@dataclass
class Netlist:
    """Flat lists the templates print: declarations, assignments, overflow terms.

    Every name in the core's namespace goes through the netlist: node values are *claimed*
    up front (:meth:`claim`, ``n_<node>``), every helper wire or register takes a :meth:`fresh`
    name (its wanted name, or that name with the first free ``_<k>`` suffix), so a helper of
    node ``p`` (``n_p_x``) can never collide with the value of a node named ``p_x``.

    Declarations also fall into :class:`Block` s (:meth:`begin`), so that the core declares
    each wire where it is assigned, under the comment of the IR node it belongs to."""

    decls: list = field(default_factory=list)      # (name, width, signed) of every wire and constant
    assigns: list = field(default_factory=list)    # (lhs, rhs)
    overflow: list = field(default_factory=list)   # (wire, node name)
    taken: set = field(default_factory=set)
    blocks: list = field(default_factory=list)     # Block, in the order the core prints them
    block_of: dict = field(default_factory=dict)   # declared name -> its Block
    regs: dict = field(default_factory=dict)       # register name -> (width, signed)
    constants: set = field(default_factory=set)    # wires that are localparams
    _claimed: set = field(default_factory=set)     # claimed, not declared yet

    def begin(self, comments, node: str | None = None, early: bool = False) -> Block:
        """Start a block: what is declared from now on belongs to it."""
        block = Block(tuple(comments), node, early=early)
        self.blocks.append(block)
        return block

    def _place(self, kind: str, name: str) -> None:
        if not self.blocks:
            self.begin(())
        self.blocks[-1].items.append((kind, name))
        if kind != "instance":
            self.block_of[name] = self.blocks[-1]

    def claim(self, name: str) -> str:
        """Reserve ``name`` exactly (a node's value, a port, a name the template prints)."""
        if name in self.taken:
            raise ValueError(f"Verilog name {name} is claimed twice")
        self.taken.add(name)
        self._claimed.add(name)
        return name

    def fresh(self, name: str, claim: bool = False) -> str:
        """``name``, or ``name_<k>`` with the smallest k >= 1 not taken yet; now taken (and
        claimed, for a wire declared later with ``own=True``, if ``claim``)."""
        candidate, k = name, 0
        while candidate in self.taken:
            k += 1
            candidate = f"{name}_{k}"
        self.taken.add(candidate)
        if claim:
            self._claimed.add(candidate)
        return candidate

    def wire(self, name: str, width: int, rhs: str, signed: bool = True, own: bool = False,
             constant: bool = False) -> str:
        """Declare and assign a wire; returns its name. ``own``: ``name`` was claimed for this
        wire (a node's value), otherwise the wire gets a fresh name derived from ``name``.
        ``constant``: ``rhs`` is a literal and the name a localparam."""
        if own:
            if name not in self._claimed:
                raise ValueError(f"Verilog name {name} was not claimed (or is declared twice)")
            self._claimed.discard(name)
        else:
            name = self.fresh(name)
        self.decls.append((name, width, signed))
        self.assigns.append((name, rhs))
        if constant:
            self.constants.add(name)
        self._place("constant" if constant else "wire", name)
        return name

    def net(self, name: str, width: int, signed: bool = False) -> str:
        """Declare a wire another module drives (a table ROM's word); returns its fresh name."""
        name = self.fresh(name)
        self.decls.append((name, width, signed))
        self._place("net", name)
        return name

    def reg(self, name: str, width: int, signed: bool, fresh: bool = True) -> str:
        """Declare a register (loaded by an always block of the core) in the current block;
        ``fresh``: take a fresh name from ``name`` (else ``name`` is already taken for it)."""
        name = self.fresh(name) if fresh else name
        if not fresh:
            self._claimed.discard(name)
        self.regs[name] = (width, signed)
        self._place("reg", name)
        return name

    def instance(self, module: str, parameters: str, name: str, ports: str) -> None:
        """A module instance printed in the current block: ``module #(parameters) name (ports);``
        (``parameters`` and ``ports`` the comma-separated connections; no ``#()`` if empty)."""
        self._place("instance", (module, parameters, name, ports))


def signed_width(lo: int, hi: int) -> int:
    """Bits of the narrowest two's-complement number holding every integer in ``lo..hi``."""
    return 1 + max(lo.bit_length() if lo >= 0 else (-lo - 1).bit_length(),
                   hi.bit_length() if hi >= 0 else (-hi - 1).bit_length())


def operand_width(fmt: QFormat) -> int:
    """Bits of ``fmt``'s values as a signed number (an unsigned value needs a zero sign bit)."""
    return fmt.width + (0 if fmt.signed else 1)


def wrap_signed(value: int, width: int) -> int:
    """``value`` modulo 2**width, as a two's-complement number of ``width`` bits."""
    value &= (1 << width) - 1
    return value - (1 << width) if value >> (width - 1) else value


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
               rounding: Rounding, overflow: Overflow, node: str, signed: bool = True,
               result: str | None = None) -> str:
    """Fit the exact value ``exact`` (``width`` bits, two's complement if ``signed``, else
    unsigned; ``frac`` fraction bits) into ``out``.

    Returns the name of a wire of ``out.width`` bits: ``result`` if given (a claimed name),
    else a fresh name from ``base``; helper wires take fresh names from ``base``. Registers
    the overflow wire, if the value can overflow at all, under ``node``.
    """
    if not signed:      # a zero sign bit: every step below reads the value as signed
        exact = net.wire(f"{base}_z", width + 1, f"{{1'b0, {exact}}}")
        width += 1

    def done(rhs: str) -> str:
        if result is not None:
            return net.wire(result, out.width, rhs, out.signed, own=True)
        return net.wire(base, out.width, rhs, out.signed)

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
            return done(extend(s, s_w, True, w))
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
        return done(f"{ovf} ? ({sign} ? {lo} : {hi}) : {low}")
    return done(low)
