"""A plant file's ``[drawing]`` laid out on a run: each point's place on the screen per frame.

The file names points as expressions of its coordinates and constants (2-D: along and up;
3-D: x, y and up) and the lines that join them. :func:`layout` evaluates them on the
positions a run recorded, projects 3-D points obliquely (y recedes up and to the right, at
half scale) and scales the whole run into a box of pixels with up on the screen's top, so
the page and the movie only draw what they are given: nothing here knows a plant.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..errors import PendcError
from ..model.expressions import parse_expression
from ..model.plant import PlantModel

RECEDE = 0.5                       # oblique projection: depth drawn at half scale ...
RECEDE_ANGLE = math.radians(35)    # ... up and to the right


@dataclass(frozen=True)
class Layout:
    """Screen places of a drawing over a run: ``points`` maps each point to its ``(px, py)``
    arrays (pixels, one entry per frame), ``lines`` the pairs of points to join, ``scale``
    pixels per unit of length and ``ground`` the screen height of the drawing's zero."""

    points: dict
    lines: tuple
    scale: float
    ground: float


def _project(vec: tuple) -> tuple:
    if len(vec) == 2:
        return vec
    x, y, z = vec
    return (x + RECEDE * math.cos(RECEDE_ANGLE) * y, z + RECEDE * math.sin(RECEDE_ANGLE) * y)


def world_points(model: PlantModel, columns: dict) -> dict:
    """Each drawing point's plane coordinates ``(along, up)`` per sample: ``columns`` maps the
    recorded positions' names to their samples (a position the drawing uses but the run did
    not record is a one-line error)."""
    drawing = model.definition.drawing
    if not drawing:
        raise PendcError(f"the plant file of '{model.interface.name}' declares no [drawing] "
                         "(points and the lines joining them): nothing to animate")
    values = model.parameter_values()
    coords = [c.name for c in model.definition.coordinates] + [s.name for s in model.definition.states]
    symbols = {n: sp.Symbol(n, real=True) for n in [*values, *coords]}
    n = len(next(iter(columns.values()))) if columns else 0
    out = {}
    for name, vec in drawing["points"].items():
        parts = []
        for i, text in enumerate(vec):
            expr = parse_expression(text, symbols, f"drawing.points.{name}[{i}]").subs(
                {symbols[k]: v for k, v in values.items()})
            missing = sorted(str(s) for s in expr.free_symbols if str(s) not in columns)
            if missing:
                raise PendcError(f"drawing point '{name}' uses {', '.join(missing)}, which the run does not record "
                                 f"(it has {', '.join(columns) or 'no positions'})")
            used = sorted(expr.free_symbols, key=str)
            f = sp.lambdify(used, expr, modules=["numpy"])
            parts.append(np.broadcast_to(np.asarray(f(*(columns[str(s)] for s in used)), float), (n,)))
        out[name] = _project(tuple(parts))
    return out


def layout(model: PlantModel, columns: dict, width: float, height: float, margin: float = 24.0) -> Layout:
    """The drawing of ``model`` over the recorded ``columns`` in a ``width`` x ``height`` pixel
    box: one scale for the whole run (so motion shows), centred, up on top."""
    world = world_points(model, columns)
    along = np.concatenate([p[0] for p in world.values()])
    up = np.concatenate([p[1] for p in world.values()])
    finite = np.isfinite(along) & np.isfinite(up)
    if not finite.any():
        raise PendcError("the drawing has no finite point in the run")
    lo_a, hi_a = float(along[finite].min()), float(along[finite].max())
    lo_u, hi_u = float(up[finite].min()), float(up[finite].max())
    span = max(hi_a - lo_a, hi_u - lo_u, 1e-9)
    scale = min((width - 2 * margin) / max(hi_a - lo_a, span * 1e-3), (height - 2 * margin) / max(hi_u - lo_u,
                                                                                                span * 1e-3))
    cx, cy = width / 2 - scale * (lo_a + hi_a) / 2, height / 2 + scale * (lo_u + hi_u) / 2
    points = {name: (cx + scale * a, cy - scale * u) for name, (a, u) in world.items()}
    return Layout(points=points, lines=tuple(drawing_lines(model)), scale=scale, ground=cy)


def drawing_lines(model: PlantModel) -> tuple:
    """The pairs of points the file joins."""
    return tuple(tuple(line) for line in model.definition.drawing.get("lines", ()))
