"""One visitor protocol over node kinds: every printer and evaluator handles every kind.

Subclass :class:`NodeVisitor` and define one method per :class:`~pendc.ir.nodes.Kind`,
named ``visit_<kind name in lower case>`` (``visit_const``, ``visit_gain``,
``visit_register``, ``visit_compare``, ...; :func:`method_name` spells it). The check
runs when the class is *defined*, so a kind added to ``Kind`` without a method in some
printer fails at import with a message listing every missing method::

    class Printer(NodeVisitor):
        def visit_const(self, node, *args): ...
        ...                                  # one per kind

    Printer().visit(node, *args)             # -> Printer.visit_<node.kind>(node, *args)

``python -m pendc.ir.visitor_audit`` imports the compiler with the check collecting
instead of raising and lists every visitor that lacks a method, all at once (after
adding a kind: the list of printers to extend).

A visitor that handles some kinds elsewhere says so explicitly with ``elsewhere``
(``class Eval(NodeVisitor, elsewhere=(Kind.CONST, ...))``): those kinds need no method
and ``visit`` refuses them. A base class holding shared code for several visitors
passes ``abstract=True`` and is not checked; its concrete subclasses are.
"""

from __future__ import annotations

from typing import ClassVar

from .nodes import Kind, Node


def method_name(kind: Kind) -> str:
    """The visitor method that handles ``kind``: ``visit_`` + the member name in lower case."""
    return f"visit_{kind.name.lower()}"


class NodeVisitor:
    """Base class of per-kind printers and evaluators, complete by construction (see module doc)."""

    _dispatch: dict = {}
    _elsewhere: frozenset = frozenset()
    # the audit (pendc.ir.visitor_audit) turns strictness off to collect every gap in one run
    strict: ClassVar[bool] = True
    incomplete: ClassVar[list] = []      # (class, missing method names) found while not strict

    def __init_subclass__(cls, abstract: bool = False, elsewhere=(), **kwargs):
        super().__init_subclass__(**kwargs)
        # kinds declared elsewhere by a base stay elsewhere in its subclasses
        cls._elsewhere = frozenset(elsewhere).union(*(getattr(b, "_elsewhere", frozenset()) for b in cls.__mro__[1:]))
        if abstract:
            return
        missing = [method_name(k) for k in Kind
                   if k not in cls._elsewhere and not callable(getattr(cls, method_name(k), None))]
        if missing and NodeVisitor.strict:
            raise TypeError(f"{cls.__module__}.{cls.__qualname__} does not handle every node kind: "
                            f"define {', '.join(missing)}")
        if missing:
            NodeVisitor.incomplete.append((cls, tuple(missing)))
        cls._dispatch = {k: getattr(cls, method_name(k)) for k in Kind
                         if k not in cls._elsewhere and callable(getattr(cls, method_name(k), None))}

    def visit(self, node: Node, *args, **kwargs):
        """Call the method for ``node``'s kind with ``node`` and the extra arguments."""
        try:
            method = self._dispatch[node.kind]
        except KeyError:
            raise ValueError(f"{type(self).__qualname__} does not visit {node.kind.value} node '{node.name}' "
                             f"(handled elsewhere)") from None
        return method(self, node, *args, **kwargs)

    def handles(self, kind: Kind) -> bool:
        """True if ``visit`` accepts nodes of ``kind`` (False for kinds declared ``elsewhere``)."""
        return kind in self._dispatch
