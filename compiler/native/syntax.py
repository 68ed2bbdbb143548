"""The Python subset the translator reads: its vocabulary and the questions asked of its syntax
tree (which names only count, which indices are literals, which functions raise on a division).
"""

from __future__ import annotations

import ast
import threading

from .types import BOOL, FLOAT, INT, Untranslatable

# math functions numba maps to libm: (C name, result type)
MATH = {name: (name, FLOAT) for name in (
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "asinh", "acosh",
    "atanh", "exp", "expm1", "log1p", "log10", "log2", "sqrt", "fabs", "copysign", "hypot", "pow",
    "fmod", "erf", "erfc")}
MATH.update({"floor": ("floor", INT), "ceil": ("ceil", INT), "trunc": ("trunc", INT),
             "isfinite": ("isfinite", BOOL), "isnan": ("isnan", BOOL), "isinf": ("isinf", BOOL)})
MATH_CONST = {"pi": "3.141592653589793", "e": "2.718281828459045", "tau": "6.283185307179586",
              "inf": "__builtin_inf()", "nan": "__builtin_nan(\"\")"}
BINARY = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.BitOr: "|", ast.BitAnd: "&", ast.BitXor: "^"}
COMPARE = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "==", ast.NotEq: "!="}

# CPython 3.11's AST conversion keeps its recursion depth in shared state: two threads parsing
# at once (kernels first called side by side) can fail with "AST constructor recursion depth
# mismatch", so parsing is one thread at a time
PARSE_LOCK = threading.Lock()


def parse(source: str) -> ast.Module:
    """The syntax tree of ``source`` (one thread at a time: see PARSE_LOCK)."""
    with PARSE_LOCK:
        return ast.parse(source)


def is_part_load(node) -> bool:
    return (isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name)
            and isinstance(node.value, ast.Attribute) and isinstance(node.value.value, ast.Call)
            and len(node.value.value.args) >= 1 and isinstance(node.value.value.args[0], ast.Constant)
            and isinstance(node.value.value.args[0].value, str))


def call_name(e) -> str:
    f = e.func
    if isinstance(f, ast.Name):
        return f.id
    if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name):
        return f"{f.value.id}.{f.attr}"
    raise Untranslatable("call of an expression")


def counters(fdef) -> set:
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
            start = 0 if len(args) == 1 else constant_index(args[0]) if args else None
            step = 1 if len(args) < 3 else constant_index(args[2])
            if start is not None and start >= 0 and step is not None and step > 0:
                counting.add(node.target.id)
        for t in targets:
            bound[t.id] = bound.get(t.id, 0) + 1
    return {name for name in counting if bound[name] == 1}


def constant_index(e):
    """The integer a subscript's index is when it is a literal (negative ones too), else None."""
    if isinstance(e, ast.Constant) and isinstance(e.value, int) and not isinstance(e.value, bool):
        return e.value
    if isinstance(e, ast.UnaryOp) and isinstance(e.op, ast.USub):
        inner = constant_index(e.operand)
        return None if inner is None else -inner
    return None


def function_def(source: str, name: str):
    for node in parse(source).body:
        if isinstance(node, ast.FunctionDef) and node.name == name:
            return node
    raise Untranslatable(f"no function {name}")


def signature(source: str, name: str) -> tuple:
    """(number of parameters, literal default values of the last ones) of the function ``name``."""
    node = function_def(source, name)
    if not all(isinstance(d, ast.Constant) for d in node.args.defaults):
        raise Untranslatable(f"{name}: a default that is not a literal")
    return len(node.args.args), tuple(d.value for d in node.args.defaults)


def numpy_errors(fdef) -> bool:
    """Whether the function's decorator asks numba for error_model="numpy"."""
    return any(isinstance(d, ast.Call) and any(k.arg == "error_model" and isinstance(k.value, ast.Constant)
                                               and k.value.value == "numpy" for k in d.keywords)
               for d in fdef.decorator_list)


def is_shape(e) -> bool:
    return (isinstance(e.value, ast.Attribute) and e.value.attr == "shape"
            and isinstance(e.value.value, ast.Name) and isinstance(e.slice, ast.Constant))
