"""Lines of generated Verilog a reviewer can read: long expressions and comments broken over
lines of at most :data:`LINE_LIMIT` characters.

Whitespace between tokens is free in Verilog, and the backend's expressions put a space
only around operators and after commas, so an expression may break at any of its
spaces; :func:`wrap` prefers the least nested one (an ``a | b | c`` chain breaks between
its terms, not inside one), and continuation lines are indented one step deeper.
"""

from __future__ import annotations

LINE_LIMIT = 110          # longest line the backend prints, where an unbreakable token allows it
STEP = "    "             # one indentation step
_OPEN, _CLOSE = "({[", ")}]"
_OPERATORS = frozenset({"|", "||", "&", "&&", "+", "-", "*", "?", ":", "==", "!=", "<", "<=", ">", ">="})


def _split_points(text: str) -> list:
    """``(position, depth)`` of every space of ``text``: its index and the brackets open there."""
    points, depth = [], 0
    for i, ch in enumerate(text):
        if ch in _OPEN:
            depth += 1
        elif ch in _CLOSE:
            depth -= 1
        elif ch == " ":
            points.append((i, depth))
    return points


def _is_operator_next(text: str, i: int) -> bool:
    """Whether the space at ``i`` is followed by a binary operator token (``| b``, ``? a``)."""
    j = text.find(" ", i + 1)
    token = text[i + 1:j if j > 0 else len(text)]
    return token in _OPERATORS


def wrap(head: str, expr: str, tail: str = "", indent: str = STEP, limit: int = LINE_LIMIT) -> list:
    """``indent + head + expr + tail`` as lines of at most ``limit`` characters where the
    expression's spaces allow it. A line breaks at its least nested space, before an operator
    where it can (so a continuation line starts with ``|``, ``?``, ``:`` ...), and a
    continuation line is indented one step, plus one column per bracket still open."""
    text = head + expr + tail
    lines, first, depth = [], True, 0
    while True:
        pad = indent if first else indent + STEP + " " * depth
        if len(pad) + len(text) <= limit:
            lines.append(pad + text)
            return lines
        room = limit - len(pad)
        floor = len(head.rstrip()) if first else 0      # never break inside the head (a declaration)
        # a line is never an operator alone
        points = [(i, d) for i, d in _split_points(text) if floor <= i <= room and text[:i].strip() not in _OPERATORS]
        if not points:                          # nothing to break at within the limit: the first space after it
            points = [(i, d) for i, d in _split_points(text) if i >= max(floor, 1)][:1]
            if not points:
                lines.append(pad + text)
                return lines
        least = min(d for _, d in points)
        best = [i for i, d in points if d == least]
        before_operator = [i for i in best if _is_operator_next(text, i)]
        cut = max(before_operator or best)
        lines.append(pad + text[:cut].rstrip())
        text = text[cut + 1:].lstrip()
        depth += least
        first = False


def comment(text: str, indent: str = STEP, limit: int = LINE_LIMIT) -> list:
    """``// text`` as lines of at most ``limit`` characters; continuation lines are indented
    inside the comment, so only the first line starts ``// <word>``."""
    words = text.split(" ")
    lines, line = [], f"{indent}// {words[0]}"
    for w in words[1:]:
        if len(line) + 1 + len(w) > limit:
            lines.append(line)
            line = f"{indent}//     {w}"
        else:
            line += f" {w}"
    lines.append(line)
    return lines


def declaration(kind: str, name: str, width: int, signed: bool, rhs: str | None = None,
                indent: str = STEP) -> list:
    """Lines declaring ``name``: ``wire`` (assigned where declared if ``rhs``), ``reg`` or
    ``localparam`` (which always spells its range, so its width is never the literal's)."""
    sign = "signed " if signed else ""
    rng = f"[{width - 1}:0] " if width > 1 or kind == "localparam" else ""
    word = {"wire": "wire ", "reg": "reg  ", "localparam": "localparam "}[kind]
    head = f"{word}{sign}{rng}{name}"
    if rhs is None:
        return [f"{indent}{head};"]
    return wrap(f"{head} = ", rhs, ";", indent)
