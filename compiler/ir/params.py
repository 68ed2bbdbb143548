"""The base of typed node parameters and the checks they share (see pendc.ir.kinds).

A kind's parameters are a frozen dataclass deriving from :class:`NodeParams`: typed
fields, a ``check`` run on construction, and a translation to and from the *legacy*
key/value form that ``make(...)``, ``node.param(key)``, ``node.with_params(...)`` and
the graph's text form use.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, dataclass, field, fields
from numbers import Real


class ParamError(ValueError):
    """A malformed parameter, before it is known which node carries it (``make`` adds the node)."""


def check_real(key: str, v, optional: bool = False) -> None:
    """ParamError unless ``v`` is a finite real number (not a bool; None if ``optional``)."""
    if optional and v is None:
        return
    if isinstance(v, bool) or not isinstance(v, Real) or not math.isfinite(v):
        raise ParamError(f"param '{key}' must be a finite real number, got {v!r}")


def check_int(key: str, v, lo: int, hi: int | None = None) -> None:
    """ParamError unless ``v`` is an integer (not a bool) in ``lo..hi`` (no upper bound if None)."""
    if isinstance(v, bool) or not isinstance(v, int) or v < lo or (hi is not None and v > hi):
        bound = f"{lo}..{hi}" if hi is not None else f">= {lo}"
        raise ParamError(f"param '{key}' must be an integer {bound}, got {v!r}")


def check_flag(key: str, v) -> None:
    """ParamError unless ``v`` is True or False."""
    if not isinstance(v, bool):
        raise ParamError(f"param '{key}' must be True or False, got {v!r}")


@dataclass(frozen=True)
class NodeParams:
    """Base of the typed params of one node kind (a frozen dataclass per kind).

    Fields without a default are required; a field defaulting to None is optional and
    left out of the legacy form (and the text form) while it is None. Subclasses check
    their values in ``check`` and may translate between the legacy key/value form and
    their fields in ``_decode``/``_encode``.

    Every kind may declare ``max_abs``, a capacity: the largest |value| the node will
    carry even if the training stimuli never reach it (an input's full scale, a turn
    counter); range analysis covers it."""

    max_abs: float | None = field(default=None, kw_only=True)

    def __post_init__(self):
        check_real("max_abs", self.max_abs, optional=True)
        self.check()

    def check(self) -> None:
        """Raise ParamError if a value is malformed (called on construction)."""

    # -- the legacy key/value form ------------------------------------------------------
    @classmethod
    def from_legacy(cls, values: dict) -> "NodeParams":
        """Build from legacy keys (``make``'s keyword arguments); typed values are accepted too."""
        values = cls._decode(dict(values))
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(values) - names)
        if unknown:
            raise ParamError(f"unknown param '{unknown[0]}' (expected {', '.join(sorted(names)) or 'none'})")
        for f in fields(cls):
            if f.name not in values and f.default is MISSING:
                raise ParamError(f"missing param '{f.name}'")
        return cls(**values)

    @classmethod
    def _decode(cls, values: dict) -> dict:
        return values

    def _encode(self) -> dict:
        """The kind's own fields in legacy form (``max_abs`` is added by ``legacy``)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name != "max_abs"
                and (f.default is MISSING or getattr(self, f.name) is not None)}

    def legacy(self) -> dict:
        """All params as legacy key -> value."""
        out = self._encode()
        if self.max_abs is not None:
            out["max_abs"] = self.max_abs
        return out

    def items(self) -> tuple:
        """The legacy ``(key, value)`` pairs in sorted key order (what the text form prints)."""
        return tuple(sorted(self.legacy().items()))

    def get(self, key: str, default=None):
        """One legacy value by key (``default`` if the key is absent)."""
        return self.legacy().get(key, default)

    def keys(self):
        """Legacy keys, so ``dict(node.params)`` gives the legacy form."""
        return [k for k, _ in self.items()]

    def __getitem__(self, key: str):
        return self.legacy()[key]

    def __iter__(self):
        # iterating yields (key, value) pairs like the tuple params used to
        return iter(self.items())

    def __len__(self) -> int:
        return len(self.legacy())

    def merged(self, **changes) -> "NodeParams":
        """A copy with some legacy keys (or typed fields) replaced."""
        return self.from_legacy({**self.legacy(), **changes})


@dataclass(frozen=True)
class NoParams(NodeParams):
    """Kinds without parameters (ADD, SUB, NEG, MUL, MUX, CAST)."""

