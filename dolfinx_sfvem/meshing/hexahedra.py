"""Hexahedral meshes without gmsh: tensor-product box grids, quadrilateral meshes extruded into
hexahedra, and the split of hexahedra into tetrahedra.

Hexahedra are in DOLFINx's vertex order (tensor-product order: vertex ``i + 2 j + 4 k`` at the
local corner ``(i, j, k)``); tetrahedra are right-handed (positive signed volume).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Literal

import numpy as np

from dolfinx_sfvem.mesh.cell_mesh import CellMesh, jacobian_determinants
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh

#: the cell types a structured grid can be made of
GridCell = Literal["hexahedron", "tetrahedron"]

#: Kuhn's split of the unit cube (tensor-product corners) into 6 tetrahedra around the diagonal
#: 0-7: every face is cut by the diagonal through its corner of smallest index, so that
#: neighbouring cubes of a structured grid cut their common face alike (a conforming mesh)
KUHN_TETRAHEDRA = np.array([[0, 1, 3, 7], [0, 1, 5, 7], [0, 4, 5, 7],
                            [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 6, 7]], dtype=np.int64)


def tetrahedron_volumes(points: np.ndarray, tetrahedra: np.ndarray) -> np.ndarray:
    """Signed volumes (m,) of tetrahedra (m, 4) of ``points`` (n, 3): positive when right-handed."""
    p = points[tetrahedra]
    return np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6.0


def right_handed(points: np.ndarray, tetrahedra: np.ndarray) -> np.ndarray:
    """The tetrahedra with the last two vertices swapped where the signed volume is negative."""
    tetrahedra = np.array(tetrahedra, dtype=np.int64)
    negative = tetrahedron_volumes(points, tetrahedra) < 0
    tetrahedra[negative, 2:] = tetrahedra[negative, 3:1:-1]
    return tetrahedra


def split_hexahedra(points: np.ndarray, hexahedra: np.ndarray, tags: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each hexahedron (DOLFINx order) split into the 6 tetrahedra of :data:`KUHN_TETRAHEDRA`,
    right-handed, tags repeated. Conforming on grids whose hexahedra all have the same orientation
    of their local axes (structured grids, extruded quad grids)."""
    tetrahedra = hexahedra[:, KUHN_TETRAHEDRA].reshape(-1, 4)
    return right_handed(points, tetrahedra), np.repeat(tags, len(KUHN_TETRAHEDRA))


def box_grid(xs: np.ndarray, ys: np.ndarray, zs: np.ndarray,
             tag_of: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
             region_names: Mapping[str, int], cell: GridCell = "hexahedron") -> CellMesh:
    """Tensor-product grid on the lines ``xs`` x ``ys`` x ``zs`` (each increasing).

    ``tag_of(cx, cy, cz)`` gives the region tag of every grid cell from its centre; cells with a
    negative tag are left out (and points no cell uses). ``cell = "tetrahedron"`` splits every
    hexahedron into 6 (:func:`split_hexahedra`).
    """
    axes = [np.asarray(a, dtype=np.float64) for a in (xs, ys, zs)]
    if any(a.ndim != 1 or a.size < 2 or np.any(np.diff(a) <= 0) for a in axes):
        raise ValueError("box_grid: the grid lines must be increasing 1D arrays of at least 2 values")
    shape = [a.size for a in axes]
    X = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    index = np.arange(X.shape[0]).reshape(shape)
    corners = [index[i:shape[0] - 1 + i, j:shape[1] - 1 + j, k:shape[2] - 1 + k].ravel()
               for k in (0, 1) for j in (0, 1) for i in (0, 1)]       # tensor-product order i + 2 j + 4 k
    hexahedra = np.stack(corners, axis=1)
    centres = np.meshgrid(*(0.5 * (a[:-1] + a[1:]) for a in axes), indexing="ij")
    tags = np.asarray(tag_of(*(c.ravel() for c in centres)), dtype=np.int64)
    keep = tags >= 0
    return _cell_mesh(X, hexahedra[keep], tags[keep], region_names, cell)


def _cell_mesh(points: np.ndarray, hexahedra: np.ndarray, tags: np.ndarray, region_names: Mapping[str, int],
               cell: GridCell) -> CellMesh:
    """CellMesh of the hexahedra (or their tetrahedra), unused points dropped."""
    if cell not in ("hexahedron", "tetrahedron"):
        raise ValueError(f"cell must be 'hexahedron' or 'tetrahedron', got {cell!r}")
    used, renumbered = np.unique(hexahedra, return_inverse=True)
    points, hexahedra = points[used], renumbered.reshape(hexahedra.shape).astype(np.int64)
    if cell == "tetrahedron":
        hexahedra, tags = split_hexahedra(points, hexahedra, tags)
    return CellMesh(points, hexahedra, tags, cell, dict(region_names))


def extruded_points(mesh2d: PolygonMesh, depth: float, layers: int, caller: str) -> np.ndarray:
    """The points of ``mesh2d`` at z = level * depth / layers, level = 0 .. layers: point
    ``p + n_points * level`` above point ``p``, (n_points * (layers + 1), 3). ValueError (naming
    ``caller``) for a depth that is not a number > 0 or a layer count that is not an integer >= 1."""
    if not (isinstance(depth, (int, float, np.floating)) and np.isfinite(depth) and depth > 0):
        raise ValueError(f"{caller}: depth must be a number > 0, got {depth!r}")
    if not (isinstance(layers, (int, np.integer)) and layers >= 1):
        raise ValueError(f"{caller}: layers must be an integer >= 1, got {layers!r}")
    n = mesh2d.points.shape[0]
    return np.concatenate([np.column_stack([mesh2d.points, np.full(n, z)])
                           for z in np.linspace(0.0, float(depth), layers + 1)])


def extrude(mesh2d: PolygonMesh, depth: float, layers: int) -> CellMesh:
    """Hexahedra from a mesh of convex quadrilaterals: every quadrilateral swept from z = 0 to z = ``depth``
    in ``layers`` equal layers.

    The polygons' tags and the mesh's ``region_names`` are kept (cell ``c + n_quads * layer``
    comes from polygon ``c``); point ``p + n_points * level`` is point ``p`` at z = level *
    depth / layers (points no polygon uses are dropped, the others keep their order).
    Parallelograms give parallelepipeds, other quadrilaterals trilinear (non-affine) hexahedra with
    planar faces, which Q2 takes too. The hexahedra are
    right-handed (the polygons are counter-clockwise in x-y, z points up).

    Parameters
    ----------
    mesh2d : PolygonMesh
        Conforming mesh of strictly convex quadrilaterals: every polygon has 4 vertices and no
        hanging node.
    depth : float > 0
        Thickness in z.
    layers : int >= 1
        Number of cell layers.

    Raises
    ------
    ValueError
        Naming the first polygon that is not a quadrilateral or not strictly convex, the hanging
        nodes, or a bad depth or layer count.
    """
    points = extruded_points(mesh2d, depth, layers, "extrude")
    sizes = np.diff(mesh2d.offsets)
    if np.any(sizes != 4):
        first = int(np.flatnonzero(sizes != 4)[0])
        raise ValueError(f"extrude: polygon {first} has {sizes[first]} vertices; only quadrilaterals extrude "
                         "into hexahedra (a quad with a hanging node is a pentagon)")
    if mesh2d.hanging_nodes.size:
        raise ValueError(f"extrude: the mesh has {mesh2d.hanging_nodes.size} hanging node(s) (e.g. point "
                         f"{int(mesh2d.hanging_nodes[0])}); hexahedra must be conforming")
    quads = mesh2d.vertices.reshape(-1, 4)                      # counter-clockwise
    corners = mesh2d.points[quads]
    det = jacobian_determinants(corners[:, [0, 1, 3, 2]], "quadrilateral")     # > 0 at the corners iff convex
    bad = np.flatnonzero(det.min(axis=1) <= mesh2d.tol * np.abs(det).max(axis=1))
    if bad.size:
        raise ValueError(f"extrude: polygon {int(bad[0])} is not strictly convex (the Jacobian determinant of "
                         f"its bilinear map is {det[bad[0]].min():.3g} at a corner): no valid hexahedron")
    n = mesh2d.points.shape[0]
    face = quads[:, [0, 1, 3, 2]]                               # DOLFINx's quadrilateral order
    hexahedra = np.concatenate([np.hstack([face + k * n, face + (k + 1) * n]) for k in range(layers)])
    tags = np.tile(np.asarray(mesh2d.tags, dtype=np.int64), layers)
    return _cell_mesh(points, hexahedra, tags, mesh2d.region_names, "hexahedron")
