"""The types the translator gives the kernels' values, and how C spells them.

A value is a scalar (``BOOL`` < ``INT`` < ``FLOAT``: numba's int64, float64 and bool, joined
upward where a name takes several), an :class:`ArrayType` or a :class:`TupleType` of scalars.
"""

from __future__ import annotations

from dataclasses import dataclass

BOOL, INT, FLOAT = "b", "i", "f"
C_TYPE = {BOOL: "_Bool", INT: "int64_t", FLOAT: "double"}
ORDER = (BOOL, INT, FLOAT)
DTYPES = {"int64": INT, "float64": FLOAT, "bool_": BOOL, "bool": BOOL}


class Untranslatable(Exception):
    """The source leaves the subset this translator knows; the kernel runs on numba instead."""


@dataclass(frozen=True)
class ArrayType:
    """A C-contiguous array argument or local: element type and number of dimensions."""
    elem: str
    ndim: int


@dataclass(frozen=True)
class TupleType:
    """A tuple of scalars (a C struct: ``e[i]`` when all are of one type, else ``e0``, ``e1``...)."""
    elems: tuple

    @property
    def uniform(self) -> bool:
        return len(set(self.elems)) == 1

    @property
    def c_name(self) -> str:
        return f"tup_{self.elems[0]}{len(self.elems)}" if self.uniform else "tup_" + "".join(self.elems)

    def c_typedef(self) -> str:
        if self.uniform:
            return f"typedef struct {{ {C_TYPE[self.elems[0]]} e[{len(self.elems)}]; }} {self.c_name};"
        fields = " ".join(f"{C_TYPE[t]} e{i};" for i, t in enumerate(self.elems))
        return f"typedef struct {{ {fields} }} {self.c_name};"


def join(a, b):
    if a is None or b is None:
        return b if a is None else a
    if isinstance(a, TupleType) or isinstance(b, TupleType):
        if not (isinstance(a, TupleType) and isinstance(b, TupleType) and len(a.elems) == len(b.elems)):
            raise Untranslatable("a name holds a tuple and another value")
        return TupleType(tuple(join(x, y) for x, y in zip(a.elems, b.elems)))
    if isinstance(a, ArrayType) or isinstance(b, ArrayType):
        if a != b:
            raise Untranslatable("a name holds an array and another value")
        return a
    return ORDER[max(ORDER.index(a), ORDER.index(b))]


def arithmetic(t):
    return INT if t == BOOL else t


def py_name(n: str) -> str:
    return "py_" + n
