"""The immutable IR node record and ``make``, its constructor.

The kinds, their exact-result rules and their typed parameters are in
:mod:`pendc.ir.kinds` (re-exported here, where callers have always imported them from).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from .kinds import (ANY_STATE, ARITY, COMPARE_OPS, SOURCE_KINDS, CompareParams, ConstParams, FsmParams,
                    GainParams, InputParams, Kind, LutParams, RegisterParams, SliceParams, Transition)
from .params import NodeParams, NoParams, ParamError
from .qformat import Overflow, QFormat, Rounding

__all__ = ["ANY_STATE", "ARITY", "COMPARE_OPS", "SOURCE_KINDS", "CompareParams", "ConstParams", "FsmParams",
           "GainParams", "GraphError", "InputParams", "Kind", "LutParams", "Node", "NodeParams", "NoParams",
           "ParamError", "RegisterParams", "SliceParams", "Transition", "make"]


class GraphError(ValueError):
    """A structural defect in an IR graph or node (the verifier's findings, a malformed param, a bad rewrite)."""


@dataclass(frozen=True)
class Node:
    """One IR node. ``inputs`` are node names; ``params`` is the kind's typed params object
    (a legacy tuple or dict of (key, value) pairs given here is converted); ``qformat`` is
    None until the Q-format pass has run. ``meaning`` says what the value is physically."""

    name: str
    kind: Kind
    inputs: tuple = ()
    params: NodeParams = NoParams()
    qformat: QFormat | None = None
    rounding: Rounding = Rounding.NEAREST
    overflow: Overflow = Overflow.WRAP
    meaning: str = field(default="", compare=False)

    def __post_init__(self):
        cls = self.kind.params_class
        if type(self.params) is cls:
            return
        try:
            if isinstance(self.params, NodeParams):
                raise ParamError(f"params are {type(self.params).__name__}, a {self.kind.name} needs {cls.__name__}")
            params = cls.from_legacy(dict(self.params))
        except (ParamError, TypeError) as exc:
            raise GraphError(f"{self.kind.value} node '{self.name}': {exc}") from None
        object.__setattr__(self, "params", params)

    def param(self, key: str, default=None):
        """Compatibility: one param in its legacy form (prefer the typed ``params.<field>``)."""
        return self.params.get(key, default)

    def with_params(self, **changes) -> "Node":
        """A copy with some params replaced or added (legacy keys or typed field values)."""
        try:
            params = self.params.merged(**changes)
        except (ParamError, TypeError) as exc:
            raise GraphError(f"{self.kind.value} node '{self.name}': {exc}") from None
        return replace(self, params=params)

    def typed(self, fmt: QFormat) -> "Node":
        """A copy in Q-format ``fmt``."""
        return replace(self, qformat=fmt)


def make(name: str, kind: Kind, inputs=(), meaning: str = "", qformat: QFormat | None = None,
         rounding: Rounding = Rounding.NEAREST, overflow: Overflow = Overflow.WRAP,
         params: NodeParams | None = None, **legacy) -> Node:
    """Build a node from typed ``params`` (e.g. ``GainParams(0.5)``) or from legacy keyword
    params (``value=0.5``); a missing or malformed param raises GraphError naming the node."""
    if params is not None and legacy:
        raise GraphError(f"{kind.value} node '{name}': give typed params or keyword params, not both")
    return Node(name=name, kind=kind, inputs=tuple(inputs), params=params if params is not None else legacy,
                qformat=qformat, rounding=rounding, overflow=overflow, meaning=meaning)
