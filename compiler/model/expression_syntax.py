"""Reading a plant-file expression into a checked Python syntax tree, without running it.

The first half of :mod:`pendc.model.expressions`: the text is parsed by :mod:`ast` (which only
parses), measured against the limits below, and every node is checked against the grammar's
whitelist before anything else sees it. :mod:`pendc.model.expressions` then builds the sympy
objects from the tree. The grammar and the reasons for each limit are in its docstring.
"""

from __future__ import annotations

import ast

import sympy as sp

from ..errors import PendcError

# A plant expression is a line or two; 20000 characters is far beyond any honest one and keeps
# parsing and building (roughly linear in the text) well under a second.
MAX_TEXT = 20000
# sympy and the builder below recurse once per level; 200 levels is deep for a person to write
# and far below Python's recursion limit. Checked on the ast before any sympy object exists.
MAX_DEPTH = 200
# Bounds every number so exact integer arithmetic stays small (1e300 is about 1000 bits) and
# every value still fits a double when the model is compiled.
MAX_MAGNITUDE = 1e300
# Bounds numeric exponents so sympy never builds a huge exact power (9**99999) or expands one.
MAX_EXPONENT = 1000

# sympy compares Min/Max arguments pairwise with assumption queries when building them and
# again on every subs/diff: 16 arguments take about a second, 128 over a minute.
MAX_MINMAX_ARGS = 16

CONSTANTS = {"pi": sp.pi}     # names every expression knows, unless ``symbols`` redefines them

# name -> (sympy function, fewest arguments, most arguments or None for no limit)
FUNCTIONS = {
    "sin": (sp.sin, 1, 1), "cos": (sp.cos, 1, 1), "tan": (sp.tan, 1, 1),
    "asin": (sp.asin, 1, 1), "acos": (sp.acos, 1, 1), "atan": (sp.atan, 1, 1),
    "atan2": (sp.atan2, 2, 2),
    "sinh": (sp.sinh, 1, 1), "cosh": (sp.cosh, 1, 1), "tanh": (sp.tanh, 1, 1),
    "exp": (sp.exp, 1, 1), "log": (sp.log, 1, 1), "sqrt": (sp.sqrt, 1, 1),
    "Abs": (sp.Abs, 1, 1), "abs": (sp.Abs, 1, 1),
    "sign": (sp.sign, 1, 1), "sgn": (sp.sign, 1, 1),
    "Min": (sp.Min, 2, None), "min": (sp.Min, 2, None),
    "Max": (sp.Max, 2, None), "max": (sp.Max, 2, None),
    "floor": (sp.floor, 1, 1), "ceiling": (sp.ceiling, 1, 1),
}
_SPECIAL = ("Piecewise", "where")
_ALL_FUNCTIONS = ", ".join(sorted([*FUNCTIONS, *_SPECIAL], key=str.lower))

_BINOPS = (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.BitXor)   # BitXor only if '^' slips by
_COMPARE = {ast.Lt: sp.Lt, ast.LtE: sp.Le, ast.Gt: sp.Gt, ast.GtE: sp.Ge}
_ALLOWED_NODES = (ast.Expression, ast.Constant, ast.Name, ast.Load, ast.UnaryOp, ast.UAdd,
                  ast.USub, ast.Not, ast.BinOp, *_BINOPS, ast.BoolOp, ast.And, ast.Or,
                  ast.Compare, *_COMPARE, ast.Call, ast.Tuple)
_REFUSED = {
    ast.Attribute: "attribute access is not allowed",
    ast.Subscript: "subscripts (x[...]) are not allowed", ast.Slice: "slices are not allowed",
    ast.Lambda: "lambda is not allowed",
    ast.JoinedStr: "f-strings are not allowed", ast.FormattedValue: "f-strings are not allowed",
    ast.Starred: "starred arguments (*x) are not allowed",
    ast.NamedExpr: "assignment (:=) is not allowed",
    ast.IfExp: "'a if c else b' is not allowed; use where(c, a, b)",
    ast.List: "lists are not allowed", ast.Dict: "dicts are not allowed",
    ast.Set: "sets are not allowed", ast.Await: "await is not allowed",
    ast.Yield: "yield is not allowed", ast.YieldFrom: "yield is not allowed",
    ast.Eq: "'==' is not allowed (it compares floats exactly); use < > <= >=",
    ast.NotEq: "'!=' is not allowed (it compares floats exactly); use < > <= >=",
    ast.Mod: "'%' is not allowed", ast.FloorDiv: "'//' is not allowed; use floor(a/b)",
    ast.MatMult: "'@' is not allowed", ast.LShift: "'<<' is not allowed",
    ast.RShift: "'>>' is not allowed", ast.BitOr: "'|' is not allowed; use 'or' in a condition",
    ast.BitAnd: "'&' is not allowed; use 'and' in a condition",
    ast.Invert: "'~' is not allowed; use 'not' in a condition",
    **{kind: "comprehensions are not allowed"
       for kind in (ast.ListComp, ast.SetComp, ast.DictComp, ast.GeneratorExp)},
    **{kind: f"'{op}' is not allowed; use < > <= >="
       for kind, op in ((ast.Is, "is"), (ast.IsNot, "is not"), (ast.In, "in"),
                        (ast.NotIn, "not in"))},
}
_NOT_FINITE = (sp.zoo, sp.nan, sp.oo, -sp.oo)


def _short(text: str, limit: int = 40) -> str:
    """``text`` on one line, cut to ``limit`` characters: messages quote user text."""
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


class _Source:
    """The text as Python sees it (``^`` made ``**``), and the way back to the user's columns."""

    def __init__(self, text: str, where: str):
        self.where = where
        self.lead = len(text) - len(text.lstrip())      # a leading blank is an IndentationError
        self.original = text.strip()
        # A textual swap is safe: a '^' inside a string literal only matters in text that is
        # refused anyway for holding a string.
        self.python = self.original.replace("^", "**")

    def column(self, lineno: int, char_index: int) -> int:
        """1-based column in the user's text of character ``char_index`` of line ``lineno``
        of the rewritten text."""
        lines = self.original.split("\n")
        line = lines[lineno - 1] if 1 <= lineno <= len(lines) else ""
        pos = col = 0
        while col < len(line) and pos + (2 if line[col] == "^" else 1) <= char_index:
            pos += 2 if line[col] == "^" else 1
            col += 1
        return col + 1 + (self.lead if lineno == 1 else 0)

    def node_column(self, node: ast.AST) -> int:
        line = self.python.split("\n")[node.lineno - 1]
        # col_offset counts UTF-8 bytes; the user counts characters.
        chars = len(line.encode("utf-8")[:node.col_offset].decode("utf-8", "replace"))
        return self.column(node.lineno, chars)

    def error(self, reason: str, node: ast.AST | None = None) -> PendcError:
        if node is not None and hasattr(node, "lineno"):
            text = ast.get_source_segment(self.python, node) or ast.unparse(node)
            line = f"line {node.lineno}, " if node.lineno > 1 else ""
            reason += f" (at {line}column {self.node_column(node)}: {_short(text)!r})"
        return PendcError(f"{self.where}: {reason}")


def _parse(text, where: str) -> tuple[_Source, ast.AST]:
    """The checked syntax tree of ``text``: length, syntax, depth and node whitelist."""
    if not isinstance(text, str):
        raise PendcError(f"{where}: expected an expression (a string) or a number, "
                         f"got {type(text).__name__}")
    if len(text) > MAX_TEXT:
        raise PendcError(f"{where}: expression is {len(text)} characters long; "
                         f"the limit is {MAX_TEXT}")
    src = _Source(text, where)
    if not src.python:
        raise PendcError(f"{where}: empty expression")
    try:
        tree = ast.parse(src.python, mode="eval")
    except SyntaxError as exc:
        line = f"line {exc.lineno}, " if exc.lineno and exc.lineno > 1 else ""
        col = src.column(exc.lineno or 1, (exc.offset or 1) - 1)
        raise PendcError(f"{where}: syntax error at {line}column {col}: "
                         f"{_short(exc.msg, 80)}") from None
    except (RecursionError, MemoryError):
        # CPython's parser gives up this way on absurd nesting such as 10000 unary minuses.
        raise PendcError(f"{where}: expression is nested too deeply to parse "
                         f"(the limit is {MAX_DEPTH} levels)") from None
    except ValueError as exc:
        raise PendcError(f"{where}: cannot parse expression ({_short(exc, 80)})") from None
    # Iterative, so the check itself cannot hit the recursion limit.
    stack = [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise PendcError(f"{where}: expression is nested more than {MAX_DEPTH} levels deep")
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))
    _validate(src, tree)
    return src, tree


def _validate(src: _Source, tree: ast.AST) -> None:
    """Refuse, before anything is built, every node outside the grammar (outermost first)."""
    stack, minmax_args = [(tree, None)], 0
    while stack:
        node, parent = stack.pop()
        kind = type(node)
        if kind in _REFUSED:    # an operator has no position of its own: show its expression
            raise src.error(_REFUSED[kind], node if hasattr(node, "lineno") else parent)
        if not isinstance(node, _ALLOWED_NODES):
            raise src.error(f"{kind.__name__} is not allowed", node)
        if isinstance(node, ast.Constant):
            value = node.value
            if isinstance(value, str):
                raise src.error("strings are not allowed", node)
            if value is not True and (isinstance(value, bool) or
                                      not isinstance(value, (int, float))):
                what = {bytes: "bytes are", complex: "complex numbers are"}.get(
                    type(value), f"{value!r} is")
                raise src.error(f"{what} not allowed", node)
        if isinstance(node, ast.Call):
            if node.keywords:
                raise src.error("keyword arguments are not allowed", node)
            if isinstance(node.func, ast.Name):
                if node.func.id not in FUNCTIONS and node.func.id not in _SPECIAL:
                    raise src.error(f"unknown function {_short(node.func.id)!r} "
                                    f"(allowed: {_ALL_FUNCTIONS})", node)
            elif not isinstance(node.func, ast.Attribute):   # an Attribute gets its own message
                raise src.error("only the named functions can be called", node)
            if isinstance(node.func, ast.Name) and node.func.id.lower() in ("min", "max"):
                minmax_args += len(node.args)
                if minmax_args > MAX_MINMAX_ARGS:
                    raise src.error(f"Min and Max take at most {MAX_MINMAX_ARGS} arguments in "
                                    f"all in one expression", node)
        stack.extend((child, node) for child in reversed(list(ast.iter_child_nodes(node))))
