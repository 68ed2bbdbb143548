"""C text of one typed function (:class:`pendc.native.translate.Function`).

Every Python name ``name`` prints as ``py_name`` (no clash with C keywords or libm); an array
``arr`` travels as ``py_arr`` with its extents ``py_arr_n0``, ``py_arr_n1``... (C-contiguous, so no
strides). :func:`translate` is the entry: a module's function typed for its arguments, and every
function it calls, printed after the prelude and the tuple types.
"""

from __future__ import annotations

import ast
import math

from .prelude import PRELUDE
from .syntax import BINARY, COMPARE, MATH, MATH_CONST, call_name, constant_index, is_shape
from .translate import Module
from .types import BOOL, C_TYPE, FLOAT, INT, ArrayType, TupleType, Untranslatable, py_name


def c_params(name: str, t) -> list:
    """The C parameters one Python parameter of type ``t`` becomes."""
    if isinstance(t, ArrayType):
        return [f"{C_TYPE[t.elem]}* {py_name(name)}"] + [f"int64_t {py_name(name)}_n{d}" for d in range(t.ndim)]
    return [f"{c_type(t)} {py_name(name)}"]


def c_type(t) -> str:
    """The C type of a scalar or tuple."""
    return t.c_name if isinstance(t, TupleType) else C_TYPE[t]


def c_args(name: str, t) -> list:
    """The C arguments that pass the Python name ``name`` of type ``t`` on to a callee."""
    if isinstance(t, ArrayType):
        return [py_name(name)] + [f"{py_name(name)}_n{d}" for d in range(t.ndim)]
    return [py_name(name)]


# statements of a called function that is inlined into its caller (see FunctionPrinter.text)
INLINE_LINES = 200


class FunctionPrinter:
    def __init__(self, fn):
        self.fn = fn
        self.lines: list = []
        self.loops = 0

    def text(self, callee: bool = False) -> str:
        """The C function; ``callee`` (a function the entry calls) is inlined where it is short."""
        fn = self.fn
        params = [p for name, t in fn.params.items() for p in c_params(name, t)]
        ret = c_type(fn.returns) if fn.returns else "void"
        self.block(fn.fdef.body, 1)
        # GCC -O2 kept a plant's derivatives (called four times a step by RK4) out of line: inlined,
        # the simulators' kernels ran a quarter faster, with the same numbers (-ffp-contract=off).
        # A long one stays a call: the double pendulum's, inlined, compiled in 5.6 s instead of 1.
        short = callee and len(self.lines) <= INLINE_LINES
        head = [f"static {'inline __attribute__((always_inline)) ' if short else ''}{ret} {fn.cname}"
                f"({', '.join(params) or 'void'}) {{"]
        for name, t in sorted(fn.types.items()):
            if name not in fn.params and not isinstance(t, ArrayType):
                head.append(f"    {c_type(t)} {py_name(name)} = {{0}};")
        return "\n".join(head + self.lines + ["}"])

    def block(self, body, depth):
        for s in body:
            self.stmt(s, depth)

    def stmt(self, s, depth):
        pad = "    " * depth
        out = self.lines.append
        if isinstance(s, ast.Assign):
            target = s.targets[0]
            t = self.fn.type_of(s.value)
            if isinstance(t, ArrayType):
                if not (isinstance(target, ast.Name) and isinstance(s.value, ast.Call)):
                    raise Untranslatable("array assigned other than from np.zeros")
                n, var = self.expr(s.value.args[0]), py_name(target.id)
                out(f"{pad}{C_TYPE[t.elem]} {var}[{n}]; int64_t {var}_n0 = {n};")
                out(f"{pad}memset({var}, 0, sizeof({var}));")
                return
            if isinstance(target, ast.Tuple):
                out(f"{pad}{{ const {t.c_name} unpacked = {self.expr(s.value)};")
                for i, x in enumerate(target.elts):
                    out(f"{pad}  {py_name(x.id)} = {_element('unpacked', t, i)};")
                out(f"{pad}}}")
                return
            want = self.fn.types.get(target.id) if isinstance(target, ast.Name) else None
            out(f"{pad}{self.expr(target)} = {self.expr(s.value, want)};")
        elif isinstance(s, ast.AugAssign):
            value = ast.BinOp(left=s.target, op=s.op, right=s.value)
            out(f"{pad}{self.expr(s.target)} = {self.expr(value)};")
        elif isinstance(s, ast.For):
            self.loop(s, pad, depth)
        elif isinstance(s, ast.While):
            out(f"{pad}while ({self.expr(s.test)}) {{")
            self.block(s.body, depth + 1)
            out(f"{pad}}}")
        elif isinstance(s, ast.If):
            out(f"{pad}if ({self.expr(s.test)}) {{")
            self.block(s.body, depth + 1)
            if s.orelse:
                out(f"{pad}}} else {{")
                self.block(s.orelse, depth + 1)
            out(f"{pad}}}")
        elif isinstance(s, ast.Return):
            out(f"{pad}return;" if s.value is None else f"{pad}return {self.expr(s.value, self.fn.returns)};")
        elif isinstance(s, ast.Expr):
            if not isinstance(s.value, ast.Constant):
                out(f"{pad}{self.expr(s.value)};")
        elif isinstance(s, ast.Break):
            out(f"{pad}break;")
        elif isinstance(s, ast.Continue):
            out(f"{pad}continue;")
        elif not isinstance(s, ast.Pass):
            raise Untranslatable(f"statement {type(s).__name__}")

    def loop(self, s, pad, depth):
        # Python evaluates the range once and the body cannot change the count: a hidden counter
        args = [self.expr(a) for a in s.iter.args]
        lo, hi, step = ("0", args[0], "1") if len(args) == 1 else (args[0], args[1], "1") if len(args) == 2 else args
        if len(args) == 3:
            node = s.iter.args[2]
            literal = node.value if isinstance(node, ast.Constant) else (
                -node.operand.value if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub)
                and isinstance(node.operand, ast.Constant) else None)
            if not isinstance(literal, int) or literal == 0:
                raise Untranslatable("range with a step that is not a non-zero literal")
            cmp = "<" if literal > 0 else ">"
        else:
            cmp = "<"
        i = self.loops
        self.loops += 1
        self.lines.append(f"{pad}{{ const int64_t hi{i} = {hi};")
        self.lines.append(f"{pad}for (int64_t i{i} = {lo}; i{i} {cmp} hi{i}; i{i} += {step}) {{")
        self.lines.append(f"{pad}    {py_name(s.target.id)} = i{i};")
        self.block(s.body, depth + 1)
        self.lines.append(f"{pad}}} }}")

    # ---------------------------------------------------------------- expressions
    def expr(self, e, want=None) -> str:
        """C of the expression ``e``; a tuple display is built as the tuple type ``want`` when
        given (a variable's or a return's joined type), else as its own."""
        fn = self.fn
        if isinstance(e, ast.Tuple):
            t = want if isinstance(want, TupleType) else fn.type_of(e)
            items = ", ".join(f"({C_TYPE[et]})({self.expr(x)})" for x, et in zip(e.elts, t.elems))
            return f"(({t.c_name}){{{{{items}}}}})" if t.uniform else f"(({t.c_name}){{{items}}})"
        if isinstance(e, ast.Constant):
            v = e.value
            if isinstance(v, bool):
                return "1" if v else "0"
            if isinstance(v, int):
                return "INT64_MIN" if v == -(1 << 63) else f"INT64_C({v})"
            if v != v:
                return MATH_CONST["nan"]
            if v in (float("inf"), float("-inf")):
                return MATH_CONST["inf"] if v > 0 else f"(-{MATH_CONST['inf']})"
            return repr(float(v))
        if isinstance(e, ast.Name):
            return py_name(e.id)
        if isinstance(e, ast.Subscript):
            if is_shape(e):
                return f"{py_name(e.value.value.id)}_n{e.slice.value}"
            return self.subscript(e)
        if isinstance(e, ast.Attribute):
            return MATH_CONST[e.attr]
        if isinstance(e, ast.UnaryOp):
            x = self.expr(e.operand)
            if isinstance(e.op, ast.USub):
                return f"(-{x})" if fn.type_of(e.operand) == FLOAT else f"((int64_t)(0 - (uint64_t)({x})))"
            if isinstance(e.op, ast.Not):
                return f"(!({x}))"
            if isinstance(e.op, ast.Invert):
                return f"(~({x}))"
            return f"(+{x})"
        if isinstance(e, ast.BinOp):
            return self.binop(e)
        if isinstance(e, ast.BoolOp):
            joiner = " && " if isinstance(e.op, ast.And) else " || "
            return "(" + joiner.join(f"({self.expr(v)})" for v in e.values) + ")"
        if isinstance(e, ast.Compare):
            terms, left = [], e.left
            for op, right in zip(e.ops, e.comparators):
                terms.append(f"(({self.expr(left)}) {COMPARE[type(op)]} ({self.expr(right)}))")
                left = right
            return terms[0] if len(terms) == 1 else "(" + " && ".join(terms) + ")"
        if isinstance(e, ast.IfExp):
            t = C_TYPE[fn.type_of(e)]
            return f"(({self.expr(e.test)}) ? ({t})({self.expr(e.body)}) : ({t})({self.expr(e.orelse)}))"
        if isinstance(e, ast.Call):
            return self.call(e)
        raise Untranslatable(f"expression {type(e).__name__}")

    def subscript(self, e) -> str:
        t = self.fn.type_of(e.value)
        if isinstance(t, TupleType):
            index = constant_index(e.slice)
            if index is None:
                return f"({self.expr(e.value)}).e[wrap_i({self.expr(e.slice)}, {len(t.elems)})]"
            return _element(f"({self.expr(e.value)})", t, index % len(t.elems))
        arr = py_name(e.value.id)
        idx = e.slice.elts if isinstance(e.slice, ast.Tuple) else [e.slice]
        parts = [self.index(x, f"{arr}_n{d}") for d, x in enumerate(idx)]
        flat = parts[0]
        for d, p in enumerate(parts[1:], start=1):
            flat = f"({flat}) * {arr}_n{d} + {p}"
        return f"{arr}[{flat}]"

    def index(self, x, extent: str) -> str:
        # numba wraps a negative index around, as Python does; a literal or a counting loop's
        # variable cannot be negative (and a plain index lets the compiler vectorise the loop)
        if isinstance(x, ast.Constant) and isinstance(x.value, int) and x.value >= 0:
            return str(x.value)
        if isinstance(x, ast.Name) and x.id in self.fn.counters:
            return self.expr(x)
        return f"wrap_i({self.expr(x)}, {extent})"

    def binop(self, e) -> str:
        fn = self.fn
        a, b = self.expr(e.left), self.expr(e.right)
        ta, tb, t = fn.type_of(e.left), fn.type_of(e.right), fn.type_of(e)
        op = type(e.op)
        if op is ast.LShift:
            return f"shl_i({a}, {b})"
        if op is ast.RShift:
            return f"((int64_t)({a}) >> ({b}))"
        checked = "_checked" if fn.raises else ""
        if op is ast.Div:
            return f"div_checked({a}, {b})" if fn.raises else f"((double)({a}) / (double)({b}))"
        if op is ast.FloorDiv:
            return f"floordiv_{t}{checked}({a}, {b})"
        if op is ast.Mod:
            return f"mod_{t}{checked}({a}, {b})"
        if op is ast.Pow:
            if t == INT:
                return f"ipow_i({a}, {b}, {int(fn.raises)})"
            if tb in (INT, BOOL):
                return f"ipow_f((double)({a}), {b})"
            return f"pow_f((double)({a}), (double)({b}))"
        if op is ast.Mult and BOOL in (ta, tb) and ta != tb:
            # x * (a comparison): a select, as LLVM makes of numba's multiply by a zero-extended
            # bool (gcc keeps the multiply); exact for int64, and for a float literal whose
            # product with 0 is known (+0.0 or -0.0)
            (flag, other), t_other = ((a, e.right), tb) if ta == BOOL else ((b, e.left), ta)
            value = b if ta == BOOL else a
            if t_other == INT:
                return f"(({flag}) ? ({value}) : INT64_C(0))"
            literal = _float_literal(other)
            if literal is not None and literal == literal and abs(literal) != float("inf"):
                zero = "0.0" if math.copysign(1.0, literal) > 0 else "(-0.0)"
                return f"(({flag}) ? ({value}) : {zero})"
        if t == INT and BOOL in (ta, tb) and op in (ast.Add, ast.Sub, ast.Mult):
            a, b = f"(int64_t)({a})", f"(int64_t)({b})"
        return f"(({a}) {BINARY[op]} ({b}))"

    def call(self, e) -> str:
        fn = self.fn
        name = call_name(e)
        args = [self.expr(a) for a in e.args]
        t = fn.type_of(e)
        if name == "int":
            return f"((int64_t)({args[0]}))"
        if name == "float":
            return f"((double)({args[0]}))"
        if name == "abs":
            return f"fabs({args[0]})" if t == FLOAT else f"abs_i({args[0]})"
        if name in ("max", "min"):
            return f"{name}_{t}(({C_TYPE[t]})({args[0]}), ({C_TYPE[t]})({args[1]}))"
        if name.startswith("math."):
            cname, rt = MATH[name[5:]]
            inner = f"{cname}({', '.join(f'(double)({a})' for a in args)})"
            return f"((int64_t){inner})" if rt == INT else f"((_Bool){inner})" if rt == BOOL else inner
        if name in fn.module.funcs:
            types = tuple(fn.type_of(a) for a in e.args)
            callee = fn.module.function(name, types)
            flat = []
            for a, ty in zip(e.args, types):
                if isinstance(ty, ArrayType):
                    if not isinstance(a, ast.Name):
                        raise Untranslatable("an array argument that is not a name")
                    flat += c_args(a.id, ty)
                else:
                    flat.append(self.expr(a, ty))
            return f"{callee.cname}({', '.join(flat)})"
        raise Untranslatable(f"call of {name}")


def _element(value: str, t, i: int) -> str:
    """Element ``i`` of the tuple ``value`` of type ``t``."""
    return f"{value}.e[{i}]" if t.uniform else f"{value}.e{i}"


def _float_literal(e):
    """The value of a float literal (or its negation), else None."""
    if isinstance(e, ast.Constant) and isinstance(e.value, float):
        return e.value
    if isinstance(e, ast.UnaryOp) and isinstance(e.op, ast.USub):
        inner = _float_literal(e.operand)
        return None if inner is None else -inner
    return None


def translate(source: str, entry: str, args: tuple) -> tuple:
    """(C text of ``entry`` of the module ``source`` typed for ``args``, and of every function it
    calls, callees first; its typed :class:`~pendc.native.translate.Function`)."""
    module = Module(source)
    fn = module.function(entry, tuple(args))
    chunks = [FunctionPrinter(f).text(callee=f is not fn) for f in module.order]    # printing may add tuple types
    typedefs = "".join(t.c_typedef() + "\n" for _, t in sorted(module.tuples.items()))
    return PRELUDE + typedefs + "\n" + "\n\n".join(chunks) + "\n", fn
