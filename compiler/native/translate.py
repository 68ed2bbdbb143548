"""The generated kernel modules' Python, typed as numba types it (printed as C by :mod:`pendc.native.emit`).

The kernels pendc prints (:mod:`pendc.ir.kernel_module`, :mod:`pendc.ir.kernel_parts`) are a
small subset of Python: assignments of int64/float64/bool scalars, arithmetic, comparisons,
``if``/``for range``/``while``, array loads and stores, ``min``/``max``/``abs``/``int``/``float``,
``math`` functions, local ``np.zeros`` arrays and calls of other functions of the module. This
module types that subset as numba does (a variable's type is the join of its assignments:
bool < int64 < float64); the C printed from it gives numba's bits in every operation: int64 arithmetic
wraps (compiled with ``-fwrapv``, left shifts done unsigned), ``>>`` is arithmetic, ``//`` and
``%`` are Python's floor forms, ``**`` by an integer is numba's square-and-multiply, ``max(a, b)``
is ``b if b > a else a``, and no floating-point contraction or reassociation is allowed.

Anything outside the subset raises :class:`Untranslatable`; the caller then uses numba.
"""

from __future__ import annotations

import ast

from .syntax import (COMPARE, MATH, MATH_CONST, call_name, constant_index, counters, is_part_load, is_shape,
                     numpy_errors, parse)
from .types import BOOL, DTYPES, FLOAT, INT, ArrayType, TupleType, Untranslatable, arithmetic, join


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
        tree = parse(source)
        for node in tree.body:
            if isinstance(node, ast.FunctionDef):
                name = (alias or {}).get(node.name, node.name)
                self.funcs[name] = node
                if numpy_errors(node):
                    self.numpy_errors.add(id(node))
            elif isinstance(node, (ast.Import, ast.ImportFrom)):
                continue
            elif isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant):
                continue
            elif is_part_load(node):
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


class Function:
    """One Python function typed for one tuple of argument types, and its C text."""

    def __init__(self, module: Module, fdef: ast.FunctionDef, args: tuple, cname: str):
        self.module, self.fdef, self.cname = module, fdef, cname
        names = [a.arg for a in fdef.args.args]
        if len(names) != len(args) or fdef.args.vararg or fdef.args.kwarg or fdef.args.kwonlyargs:
            raise Untranslatable(f"{fdef.name}: {len(args)} arguments for {len(names)} parameters")
        self.params = dict(zip(names, args))
        self.types = dict(self.params)
        self.counters = counters(fdef)
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
                        and call_name(s.iter) == "range" and not s.orelse and 1 <= len(s.iter.args) <= 3):
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
                self.returns = join(self.returns, t)
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
            if isinstance(t, ArrayType) or isinstance(own, ArrayType) or join(own, t) != own:
                raise Untranslatable(f"parameter {name} rebound to another type")
            return
        if t is None:
            raise Untranslatable(f"{name} bound to a value of no type")
        self.types[name] = join(self.types.get(name), t)

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
            if is_shape(e):
                return INT
            arr = self.type_of(e.value)
            if isinstance(arr, TupleType):
                if constant_index(e.slice) is None and (not arr.uniform or self.type_of(e.slice) not in (INT, BOOL)):
                    raise Untranslatable("a tuple of mixed types indexed by a variable")
                index = constant_index(e.slice)
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
            if isinstance(e.value, ast.Name) and e.value.id == "math" and e.attr in MATH_CONST:
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
            return None if t is None else arithmetic(t)
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
                return arithmetic(join(a, b))
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
            if any(type(o) not in COMPARE for o in e.ops):
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
            return join(self._scalar(self.type_of(e.body)), self._scalar(self.type_of(e.orelse)))
        if isinstance(e, ast.Call):
            return self._call_type(e)
        raise Untranslatable(f"expression {type(e).__name__}")

    def _call_type(self, e):
        if e.keywords:
            raise Untranslatable("keyword arguments")
        name = call_name(e)
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
            return None if ts[0] is None else arithmetic(ts[0])
        if name in ("max", "min"):
            if len(ts) != 2:
                raise Untranslatable(f"{name} of {len(ts)} arguments")
            return None if None in ts else join(*ts)
        if name.startswith("math."):
            if name[5:] not in MATH:
                raise Untranslatable(f"{name}")
            return MATH[name[5:]][1]
        if name in self.module.funcs:
            if None in ts:
                return None
            return self.module.function(name, tuple(ts)).returns
        raise Untranslatable(f"call of {name}")
