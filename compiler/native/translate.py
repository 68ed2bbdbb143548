"""The generated kernel modules' Python, translated to C with numba's semantics.

The kernels pendc prints (:mod:`pendc.ir.kernel_module`, :mod:`pendc.ir.kernel_parts`) are a
small subset of Python: assignments of int64/float64/bool scalars, arithmetic, comparisons,
``if``/``for range``/``while``, array loads and stores, ``min``/``max``/``abs``/``int``/``float``,
``math`` functions, local ``np.zeros`` arrays and calls of other functions of the module. This
module types that subset as numba does (a variable's type is the join of its assignments:
bool < int64 < float64) and prints C whose every operation gives numba's bits: int64 arithmetic
wraps (compiled with ``-fwrapv``, left shifts done unsigned), ``>>`` is arithmetic, ``//`` and
``%`` are Python's floor forms, ``**`` by an integer is numba's square-and-multiply, ``max(a, b)``
is ``b if b > a else a``, and no floating-point contraction or reassociation is allowed.

Anything outside the subset raises :class:`Untranslatable`; the caller then uses numba.
"""

from __future__ import annotations

import ast
import threading
from dataclasses import dataclass


BOOL, INT, FLOAT = "b", "i", "f"
C_TYPE = {BOOL: "_Bool", INT: "int64_t", FLOAT: "double"}
_ORDER = (BOOL, INT, FLOAT)
DTYPES = {"int64": INT, "float64": FLOAT, "bool_": BOOL, "bool": BOOL}

# math functions numba maps to libm: (C name, result type)
_MATH = {name: (name, FLOAT) for name in (
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "asinh", "acosh",
    "atanh", "exp", "expm1", "log1p", "log10", "log2", "sqrt", "fabs", "copysign", "hypot", "pow",
    "fmod", "erf", "erfc")}
_MATH.update({"floor": ("floor", INT), "ceil": ("ceil", INT), "trunc": ("trunc", INT),
              "isfinite": ("isfinite", BOOL), "isnan": ("isnan", BOOL), "isinf": ("isinf", BOOL)})
_MATH_CONST = {"pi": "3.141592653589793", "e": "2.718281828459045", "tau": "6.283185307179586",
               "inf": "__builtin_inf()", "nan": "__builtin_nan(\"\")"}
_BINARY = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.BitOr: "|", ast.BitAnd: "&", ast.BitXor: "^"}
_COMPARE = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "==", ast.NotEq: "!="}



# CPython 3.11's AST conversion keeps its recursion depth in shared state: two threads parsing
# at once (kernels first called side by side) can fail with "AST constructor recursion depth
# mismatch", so parsing is one thread at a time
PARSE_LOCK = threading.Lock()


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


def _join(a, b):
    if a is None or b is None:
        return b if a is None else a
    if isinstance(a, TupleType) or isinstance(b, TupleType):
        if not (isinstance(a, TupleType) and isinstance(b, TupleType) and len(a.elems) == len(b.elems)):
            raise Untranslatable("a name holds a tuple and another value")
        return TupleType(tuple(_join(x, y) for x, y in zip(a.elems, b.elems)))
    if isinstance(a, ArrayType) or isinstance(b, ArrayType):
        if a != b:
            raise Untranslatable("a name holds an array and another value")
        return a
    return _ORDER[max(_ORDER.index(a), _ORDER.index(b))]


def _arith(t):
    return INT if t == BOOL else t


def _name(n: str) -> str:
    return "py_" + n


class Module:
    """The functions of one kernel module (and of the part modules it loads by their source)."""

    def __init__(self, source: str):
        self.funcs: dict = {}
        self.numpy_errors: set = set()     # id() of the functions compiled with error_model="numpy"
        self._read(source)
        self.emitted: dict = {}
        self.order: list = []
        self.tuples: dict = {}            # C name -> TupleType, for the typedefs

    def _read(self, source: str, alias: dict | None = None):
        with PARSE_LOCK:
            tree = ast.parse(source)
        for node in tree.body:
            if isinstance(node, ast.FunctionDef):
                name = (alias or {}).get(node.name, node.name)
                self.funcs[name] = node
                if _numpy_errors(node):
                    self.numpy_errors.add(id(node))
            elif isinstance(node, (ast.Import, ast.ImportFrom)):
                continue
            elif isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant):
                continue
            elif _is_part_load(node):
                # name = _load_part("<module source>", "prefix").part: a function of another module
                self._read(node.value.value.args[0].value, {node.value.attr: node.targets[0].id})
            else:
                raise Untranslatable(f"module-level statement at line {node.lineno}")

    def function(self, name: str, args: tuple) -> "Function":
        """The C function for ``name`` called with argument types ``args`` (emitted once)."""
        key = (name, args)
        if key not in self.emitted:
            if name not in self.funcs:
                raise Untranslatable(f"call of unknown function {name}")
            fn = Function(self, self.funcs[name], args, f"f{len(self.emitted)}_{name}")
            self.emitted[key] = fn
            self.order.append(fn)          # after its callees: they were typed while it was
            for t in list(fn.types.values()) + [fn.returns]:
                if isinstance(t, TupleType):
                    self.tuples[t.c_name] = t
        return self.emitted[key]


def _is_part_load(node) -> bool:
    return (isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name)
            and isinstance(node.value, ast.Attribute) and isinstance(node.value.value, ast.Call)
            and len(node.value.value.args) >= 1 and isinstance(node.value.value.args[0], ast.Constant)
            and isinstance(node.value.value.args[0].value, str))


class Function:
    """One Python function typed for one tuple of argument types, and its C text."""

    def __init__(self, module: Module, fdef: ast.FunctionDef, args: tuple, cname: str):
        self.module, self.fdef, self.cname = module, fdef, cname
        names = [a.arg for a in fdef.args.args]
        if len(names) != len(args) or fdef.args.vararg or fdef.args.kwarg or fdef.args.kwonlyargs:
            raise Untranslatable(f"{fdef.name}: {len(args)} arguments for {len(names)} parameters")
        self.params = dict(zip(names, args))
        self.types = dict(self.params)
        self.counters = _counters(fdef)
        self.returns = None
        for _ in range(8):      # types only widen, so this reaches the fixed point
            before = (dict(self.types), self.returns)
            self._infer(fdef.body)
            if before == (self.types, self.returns):
                break
        else:
            raise Untranslatable(f"{fdef.name}: types do not settle")

    # ---------------------------------------------------------------- typing
    def _infer(self, body):
        for s in body:
            if isinstance(s, ast.Assign):
                if len(s.targets) != 1:
                    raise Untranslatable("chained assignment")
                target = s.targets[0]
                if isinstance(target, ast.Name):
                    self._bind(target.id, self.type_of(s.value))
                elif isinstance(target, ast.Tuple):
                    t = self.type_of(s.value)
                    if t is None:
                        continue
                    if not (isinstance(t, TupleType) and len(t.elems) == len(target.elts)
                            and all(isinstance(x, ast.Name) for x in target.elts)):
                        raise Untranslatable("unpacking other than names from a tuple of as many")
                    for x, et in zip(target.elts, t.elems):
                        self._bind(x.id, et)
                elif isinstance(target, ast.Subscript):
                    if isinstance(self.type_of(target.value), TupleType):
                        raise Untranslatable("assignment to a tuple's element")
                    self.type_of(target)
                    self.type_of(s.value)
                else:
                    raise Untranslatable(f"assignment to {type(target).__name__}")
            elif isinstance(s, ast.AugAssign):
                if not isinstance(s.target, (ast.Name, ast.Subscript)):
                    raise Untranslatable("augmented assignment target")
                t = self.type_of(ast.BinOp(left=s.target, op=s.op, right=s.value))
                if isinstance(s.target, ast.Name):
                    self._bind(s.target.id, t)
            elif isinstance(s, ast.For):
                if not (isinstance(s.target, ast.Name) and isinstance(s.iter, ast.Call)
                        and _call_name(s.iter) == "range" and not s.orelse and 1 <= len(s.iter.args) <= 3):
                    raise Untranslatable("a loop other than for ... in range(...)")
                for a in s.iter.args:
                    if self.type_of(a) not in (INT, BOOL):
                        raise Untranslatable("range of a non-integer")
                self._bind(s.target.id, INT)
                self._infer(s.body)
            elif isinstance(s, ast.While):
                if s.orelse:
                    raise Untranslatable("while ... else")
                self.type_of(s.test)
                self._infer(s.body)
            elif isinstance(s, ast.If):
                self.type_of(s.test)
                self._infer(s.body)
                self._infer(s.orelse)
            elif isinstance(s, ast.Return):
                t = None if s.value is None else self.type_of(s.value)
                if isinstance(t, ArrayType):
                    raise Untranslatable("returns an array")
                self.returns = _join(self.returns, t)
            elif isinstance(s, ast.Expr):
                if not isinstance(s.value, ast.Constant):
                    self.type_of(s.value)
            elif not isinstance(s, (ast.Pass, ast.Break, ast.Continue)):
                raise Untranslatable(f"statement {type(s).__name__}")

    @staticmethod
    def _scalar(t):
        """``t``, which an operator or a conditional takes only as a scalar (numba would add
        tuples, compare them element by element, or pick one of two)."""
        if isinstance(t, (ArrayType, TupleType)):
            raise Untranslatable("an operator or conditional on an array or tuple")
        return t

    @property
    def raises(self) -> bool:
        """Whether a division by zero raises (numba's default error model), as the prelude's
        checked helpers report it."""
        return id(self.fdef) not in self.module.numpy_errors

    def _bind(self, name, t):
        if name in self.params and self.params[name] != t:
            own = self.params[name]
            if isinstance(t, ArrayType) or isinstance(own, ArrayType) or _join(own, t) != own:
                raise Untranslatable(f"parameter {name} rebound to another type")
            return
        if t is None:
            raise Untranslatable(f"{name} bound to a value of no type")
        self.types[name] = _join(self.types.get(name), t)

    def type_of(self, e):
        if isinstance(e, ast.Constant):
            v = e.value
            if isinstance(v, bool):
                return BOOL
            if isinstance(v, int):
                if not -(1 << 63) <= v < (1 << 63):
                    raise Untranslatable("integer literal outside int64")
                return INT
            if isinstance(v, float):
                return FLOAT
            raise Untranslatable(f"literal {v!r}")
        if isinstance(e, ast.Name):
            if e.id not in self.types:
                return None         # assigned later in the body: the next round of typing knows it
            return self.types[e.id]
        if isinstance(e, ast.Subscript):
            if _is_shape(e):
                return INT
            arr = self.type_of(e.value)
            if isinstance(arr, TupleType):
                if _constant_index(e.slice) is None and (not arr.uniform or self.type_of(e.slice) not in (INT, BOOL)):
                    raise Untranslatable("a tuple of mixed types indexed by a variable")
                index = _constant_index(e.slice)
                if index is not None and not -len(arr.elems) <= index < len(arr.elems):
                    raise Untranslatable("tuple index out of range")
                return arr.elems[0] if index is None else arr.elems[index]
            if arr is None:
                return None
            if not isinstance(arr, ArrayType):
                raise Untranslatable("subscript of a non-array")
            idx = e.slice.elts if isinstance(e.slice, ast.Tuple) else [e.slice]
            if len(idx) != arr.ndim:
                raise Untranslatable("partial indexing")
            for i in idx:
                if isinstance(i, ast.Slice) or self.type_of(i) not in (INT, BOOL, None):
                    raise Untranslatable("a non-integer index")
            return arr.elem
        if isinstance(e, ast.Attribute):
            if isinstance(e.value, ast.Name) and e.value.id == "math" and e.attr in _MATH_CONST:
                return FLOAT
            raise Untranslatable(f"attribute {ast.unparse(e)}")
        if isinstance(e, ast.UnaryOp):
            t = self._scalar(self.type_of(e.operand))
            if isinstance(e.op, ast.Not):
                return BOOL
            if isinstance(e.op, ast.Invert):
                if t != INT:
                    raise Untranslatable("~ of a non-integer")
                return INT
            return None if t is None else _arith(t)
        if isinstance(e, ast.BinOp):
            a, b = self._scalar(self.type_of(e.left)), self._scalar(self.type_of(e.right))
            if a is None or b is None:
                return None
            if isinstance(a, ArrayType) or isinstance(b, ArrayType):
                raise Untranslatable("array arithmetic")
            op = type(e.op)
            if op is ast.Div:
                return FLOAT
            if op in (ast.LShift, ast.RShift):
                if FLOAT in (a, b):
                    raise Untranslatable("shift of a float")
                return INT
            if op in (ast.BitOr, ast.BitAnd, ast.BitXor):
                if FLOAT in (a, b):
                    raise Untranslatable("bitwise operator on a float")
                return BOOL if a == b == BOOL else INT
            if op is ast.Pow:
                return FLOAT if FLOAT in (a, b) else INT
            if op in (ast.Add, ast.Sub, ast.Mult, ast.FloorDiv, ast.Mod):
                return _arith(_join(a, b))
            raise Untranslatable(f"operator {op.__name__}")
        if isinstance(e, ast.BoolOp):
            ts = [self.type_of(v) for v in e.values]
            if any(t not in (BOOL, None) for t in ts):
                raise Untranslatable("and/or of non-booleans")
            return BOOL
        if isinstance(e, ast.Compare):
            for x in [e.left] + e.comparators:
                if isinstance(self.type_of(x), (ArrayType, TupleType)):
                    raise Untranslatable("comparison of arrays or tuples")
            if any(type(o) not in _COMPARE for o in e.ops):
                raise Untranslatable("comparison operator")
            return BOOL
        if isinstance(e, ast.Tuple):
            ts = tuple(self.type_of(x) for x in e.elts)
            if None in ts:
                return None
            if not ts or any(isinstance(t, (ArrayType, TupleType)) for t in ts):
                raise Untranslatable("a tuple of other than scalars")
            t = TupleType(ts)
            self.module.tuples[t.c_name] = t
            return t
        if isinstance(e, ast.IfExp):
            self._scalar(self.type_of(e.test))
            return _join(self._scalar(self.type_of(e.body)), self._scalar(self.type_of(e.orelse)))
        if isinstance(e, ast.Call):
            return self._call_type(e)
        raise Untranslatable(f"expression {type(e).__name__}")

    def _call_type(self, e):
        if e.keywords:
            raise Untranslatable("keyword arguments")
        name = _call_name(e)
        if name in ("np.zeros", "np.empty"):
            if len(e.args) != 2 or not (isinstance(e.args[1], ast.Attribute) and e.args[1].attr in DTYPES):
                raise Untranslatable("np.zeros without a dtype")
            if self.type_of(e.args[0]) != INT:
                raise Untranslatable("np.zeros of a size that is not an integer")
            return ArrayType(DTYPES[e.args[1].attr], 1)
        ts = [self.type_of(a) for a in e.args]
        if any(isinstance(t, (ArrayType, TupleType)) for t in ts) and name not in self.module.funcs:
            raise Untranslatable(f"{name} of an array or tuple")
        if name in ("int", "float"):
            if len(ts) != 1:
                raise Untranslatable(f"{name} with {len(ts)} arguments")
            return INT if name == "int" else FLOAT
        if name == "abs":
            return None if ts[0] is None else _arith(ts[0])
        if name in ("max", "min"):
            if len(ts) != 2:
                raise Untranslatable(f"{name} of {len(ts)} arguments")
            return None if None in ts else _join(*ts)
        if name.startswith("math."):
            if name[5:] not in _MATH:
                raise Untranslatable(f"{name}")
            return _MATH[name[5:]][1]
        if name in self.module.funcs:
            if None in ts:
                return None
            return self.module.function(name, tuple(ts)).returns
        raise Untranslatable(f"call of {name}")


def _call_name(e) -> str:
    f = e.func
    if isinstance(f, ast.Name):
        return f.id
    if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name):
        return f"{f.value.id}.{f.attr}"
    raise Untranslatable("call of an expression")


def _counters(fdef) -> set:
    """Names that only ever count up from a non-negative literal: the targets of
    ``for ... in range(...)`` loops starting at 0 or a positive literal with a positive step,
    assigned nowhere else in the function."""
    bound: dict = {}
    counting = set()
    for node in ast.walk(fdef):
        targets = []
        if isinstance(node, ast.Assign):
            targets = [t for t in ast.walk(node.targets[0]) if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AugAssign) and isinstance(node.target, ast.Name):
            targets = [node.target]
        elif isinstance(node, ast.For) and isinstance(node.target, ast.Name):
            targets = [node.target]
            args = node.iter.args if isinstance(node.iter, ast.Call) else []
            start = 0 if len(args) == 1 else _constant_index(args[0]) if args else None
            step = 1 if len(args) < 3 else _constant_index(args[2])
            if start is not None and start >= 0 and step is not None and step > 0:
                counting.add(node.target.id)
        for t in targets:
            bound[t.id] = bound.get(t.id, 0) + 1
    return {name for name in counting if bound[name] == 1}


def _constant_index(e):
    """The integer a subscript's index is when it is a literal (negative ones too), else None."""
    if isinstance(e, ast.Constant) and isinstance(e.value, int) and not isinstance(e.value, bool):
        return e.value
    if isinstance(e, ast.UnaryOp) and isinstance(e.op, ast.USub):
        inner = _constant_index(e.operand)
        return None if inner is None else -inner
    return None


def _function_def(source: str, name: str):
    with PARSE_LOCK:
        tree = ast.parse(source)
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.name == name:
            return node
    raise Untranslatable(f"no function {name}")


def defaults(source: str, name: str) -> tuple:
    """The literal default values of the function ``name``'s last parameters."""
    node = _function_def(source, name)
    if not all(isinstance(d, ast.Constant) for d in node.args.defaults):
        raise Untranslatable(f"{name}: a default that is not a literal")
    return tuple(d.value for d in node.args.defaults)


def arity(source: str, name: str) -> int:
    """The number of parameters of the function ``name``."""
    return len(_function_def(source, name).args.args)


def _numpy_errors(fdef) -> bool:
    """Whether the function's decorator asks numba for error_model="numpy"."""
    return any(isinstance(d, ast.Call) and any(k.arg == "error_model" and isinstance(k.value, ast.Constant)
                                               and k.value.value == "numpy" for k in d.keywords)
               for d in fdef.decorator_list)


def _is_shape(e) -> bool:
    return (isinstance(e.value, ast.Attribute) and e.value.attr == "shape"
            and isinstance(e.value.value, ast.Name) and isinstance(e.slice, ast.Constant))
