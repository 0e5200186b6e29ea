"""Structured quadrilateral grids: axis nodes matching gmsh's transfinite lines, rectangles of
quads and a quad grid with a refined patch (hanging nodes)."""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.meshing.polygon_sets import PolygonSet, compact_points, glue, length_tolerance


def n_segments(length: float, h: float) -> int:
    """Number of equal segments of size about ``h`` on a straight line of ``length``."""
    return max(1, int(round(length / h)))


def axis_nodes(breaks: Sequence[float], h: float, refinement: int = 1) -> np.ndarray:
    """1D grid nodes: each interval between consecutive ``breaks`` split uniformly.

    Interval ``[a, b]`` gets ``refinement * n_segments(b - a, h)`` segments, i.e. exactly
    the nodes (``refinement = 1``) or a uniform ``refinement``-fold subdivision of the nodes
    that gmsh puts on a transfinite line of size ``h`` (see :func:`straight_region`).
    """
    pieces = [np.linspace(a, b, refinement * n_segments(b - a, h) + 1)[:-1]
              for a, b in zip(breaks[:-1], breaks[1:])]
    return np.concatenate(pieces + [np.asarray(breaks[-1:], dtype=np.float64)])


def quad_grid(xs: np.ndarray, ys: np.ndarray, tag: int,
               keep: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> PolygonSet:
    """Tensor-product quadrilaterals on grid lines ``xs`` x ``ys`` (both increasing).

    ``keep(cx, cy)`` selects cells by their centres (default: all); points of dropped
    cells are removed. Quads are counter-clockwise, tagged ``tag``.
    """
    nx, ny = xs.size - 1, ys.size - 1
    X, Y = np.meshgrid(xs, ys, indexing="xy")
    points = np.stack([X.ravel(), Y.ravel()], axis=1)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy")
    ll = (j * (nx + 1) + i).ravel()
    quads = np.stack([ll, ll + 1, ll + nx + 2, ll + nx + 1], axis=1)
    if keep is not None:
        cx, cy = np.meshgrid(0.5 * (xs[:-1] + xs[1:]), 0.5 * (ys[:-1] + ys[1:]), indexing="xy")
        quads = quads[np.asarray(keep(cx.ravel(), cy.ravel()), dtype=bool)]
    used_points, flat = compact_points(points, quads.ravel())
    return PolygonSet(used_points, list(flat.reshape(-1, 4)), np.full(len(quads), tag, dtype=np.int32))


def quad_rectangle(Lx: float, Ly: float, nx: int, ny: int, origin: Sequence[float] = (0.0, 0.0),
                   tag: int = 0) -> PolygonMesh:
    """Structured mesh of ``nx`` x ``ny`` equal quadrilaterals on a rectangle.

    Parameters
    ----------
    Lx, Ly : float
        Side lengths (same length unit as the coordinates).
    nx, ny : int
        Cells along x and y.
    origin : (2,) float
        Lower-left corner.
    tag : int
        Region tag of every quad.
    """
    x0, y0 = origin
    return quad_grid(x0 + np.linspace(0.0, Lx, nx + 1), y0 + np.linspace(0.0, Ly, ny + 1), tag).to_mesh()


def quads_with_hanging_nodes(Lx: float, Ly: float, n: int,
                             refine: Sequence[float] | None = None, tag: int = 0) -> PolygonMesh:
    """Quadrilaterals on ``[0, Lx] x [0, Ly]``, refined 2x inside a box: hanging nodes.

    The coarse grid has ``n`` x ``n`` cells; the cells inside ``refine = (x0, x1, y0, y1)``
    are replaced by 2 x 2 cells each. Every fine-grid point in the middle of a coarse edge
    on the box boundary becomes a hanging node of the coarse neighbour (the coarse quad
    turns into a pentagon or more).

    Parameters
    ----------
    Lx, Ly : float
        Rectangle size.
    n : int
        Coarse cells along each side.
    refine : (x0, x1, y0, y1), optional
        Refined box, its sides on coarse grid lines (default: the coarse lines nearest
        to the middle half of the rectangle).
    tag : int
        Region tag of every cell.
    """
    xs, ys = np.linspace(0.0, Lx, n + 1), np.linspace(0.0, Ly, n + 1)
    if refine is None:
        lo, hi = n // 4, n - n // 4
        refine = (xs[lo], xs[hi], ys[lo], ys[hi])
    x0, x1, y0, y1 = refine
    tol = length_tolerance(np.array([[0.0, 0.0], [Lx, Ly]]))
    if not all(np.abs(axis - c).min() <= tol for axis, c in ((xs, x0), (xs, x1), (ys, y0), (ys, y1))) \
            or not (x0 < x1 and y0 < y1):
        raise ValueError(f"refine box {tuple(refine)} must be non-empty with its sides on the coarse grid "
                         f"lines x = k*{Lx / n:g}, y = k*{Ly / n:g}")

    def inside(cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
        return (cx > x0) & (cx < x1) & (cy > y0) & (cy < y1)

    coarse = quad_grid(xs, ys, tag, lambda cx, cy: ~inside(cx, cy))
    fine = quad_grid(np.linspace(0.0, Lx, 2 * n + 1), np.linspace(0.0, Ly, 2 * n + 1), tag, inside)
    return glue(coarse, fine)
