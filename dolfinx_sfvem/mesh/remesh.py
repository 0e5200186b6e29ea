"""Triangle meshes of the geometry of a polygon mesh, for the P2 FEM reference.

:func:`triangulate` extracts every region's boundary loops (outer loops and holes) from a
:class:`~dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh` and meshes the regions again with gmsh at a
requested size ``h``: every polygon-mesh vertex on an outer boundary or a region
interface becomes a gmsh point, every boundary/interface edge a gmsh line shared by the
regions on both sides. The triangle mesh therefore has the same regions, follows the
interfaces exactly and has a vertex at every named point of a benchmark (load point,
gap points), which are polygon vertices on boundaries.

Consequence: boundary and interface segments are never longer than the polygon mesh's
edges there (for the dual meshes of :mod:`~dolfinx_sfvem.meshing.dual` about half the
polygon size); only the interior follows ``h``.

:func:`matched_triangulation` picks ``h`` so that the P2 unknowns match the SFVEM
unknowns of the polygon mesh (comparisons at matched DOFs).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from dolfinx_sfvem.discretizations.node_keys import sfvem_unknowns
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.mesh.csr import edge_key
from dolfinx_sfvem.meshing.gmsh_io import gmsh_session, model_cells
from dolfinx_sfvem.mesh.polygon import point_location, signed_area


class TriangleMesh(NamedTuple):
    """A tagged triangle mesh.

    Attributes
    ----------
    points : (n, 2) float64
    triangles : (m, 3) int64
        Vertex indices into ``points`` (gmsh's orientation).
    tags : (m,) int32
        Region tag of every triangle.
    """

    points: np.ndarray
    triangles: np.ndarray
    tags: np.ndarray


Loop = np.ndarray  #: closed loop of point indices (k,), region on the left


def _boundary_edges(mesh: PolygonMesh, tag: int) -> tuple[np.ndarray, np.ndarray]:
    """Sides (a -> b) of the polygons of region ``tag`` with no polygon of the region across:
    its boundary, oriented with the region on the left."""
    sides = mesh.sides
    outside = (sides.neighbour < 0) | (mesh.tags[sides.neighbour] != tag)
    keep = (mesh.tags[sides.polygon] == tag) & outside
    return sides.start[keep], sides.end[keep]


def _chain(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> list[Loop]:
    """Closed loops of the directed edges a[i] -> b[i].

    Where a region touches itself at a vertex (two outgoing edges), the edge arriving from
    ``p`` continues along the outgoing edge reached first turning clockwise from the
    direction back to ``p``: the one bounding the same sector of the region.
    """
    outgoing: dict[int, list[int]] = {}
    for e, start in enumerate(a.tolist()):
        outgoing.setdefault(start, []).append(e)
    used = np.zeros(a.size, dtype=bool)
    loops = []
    for first in range(a.size):
        if used[first]:
            continue
        loop, e = [], first
        while not used[e]:
            used[e] = True
            loop.append(int(a[e]))
            v = int(b[e])
            candidates = [k for k in outgoing[v] if not used[k]] or outgoing[v]
            back = points[a[e]] - points[v]
            clockwise = [(np.arctan2(back[1], back[0]) - np.arctan2(*(points[b[k]] - points[v])[::-1]))
                         % (2 * np.pi) for k in candidates]
            e = candidates[int(np.argmin(clockwise))]
        loops.append(np.array(loop, dtype=np.int64))
    return loops


def region_loops(mesh: PolygonMesh) -> dict[int, list[tuple[Loop, list[Loop]]]]:
    """Boundary loops of every region: ``{tag: [(outer loop, [hole loops]), ...]}``.

    One entry per connected piece of the region. Outer loops are counter-clockwise, holes
    clockwise (region on the left of both); each hole belongs to the smallest outer loop
    that contains it.
    """
    out = {}
    for tag in np.unique(mesh.tags).tolist():
        loops = _chain(mesh.points, *_boundary_edges(mesh, tag))
        area = np.array([signed_area(mesh.points[loop]) for loop in loops])
        outer = [k for k in np.argsort(area) if area[k] > 0]
        pieces = {k: (loops[k], []) for k in outer}
        for k in np.flatnonzero(area < 0):
            inside = [o for o in outer if any(point_location(mesh.points[v], mesh.points[loops[o]], mesh.tol) == 1
                                               for v in loops[k])]
            if not inside:
                raise ValueError(f"region {tag}: hole through points {loops[k][:4].tolist()}... lies in no outer "
                                 f"boundary")
            pieces[inside[0]][1].append(loops[k])
        out[int(tag)] = list(pieces.values())
    return out


def triangulate(mesh: PolygonMesh, h: float) -> TriangleMesh:
    """Triangle mesh (gmsh Frontal-Delaunay, size ``h``) of the regions of a polygon mesh.

    Parameters
    ----------
    mesh
        Polygon mesh with region tags.
    h
        Target triangle size in the interior (``Mesh.MeshSizeMax``); boundary and interface
        segments are the polygon mesh's edges, split where longer than ``h``.

    Returns
    -------
    TriangleMesh
        Same regions and tags; every boundary/interface vertex of ``mesh`` is a vertex, at
        exactly its coordinates.
    """
    if not (np.isfinite(h) and h > 0):
        raise ValueError(f"mesh size h must be a positive number, got {h}")
    regions = region_loops(mesh)
    with gmsh_session() as gmsh:
        for name, value in (("Mesh.Algorithm", 6), ("Mesh.MeshSizeMax", h), ("Mesh.MeshSizeFromPoints", 0),
                            ("Mesh.MeshSizeExtendFromBoundary", 0), ("Mesh.MeshSizeFromCurvature", 0)):
            gmsh.option.setNumber(name, value)
        geo = gmsh.model.geo
        point_tag: dict[int, int] = {}
        line_tag: dict[tuple[int, int], int] = {}

        def line(a: int, b: int) -> int:
            for v in (a, b):
                if v not in point_tag:
                    x, y = mesh.points[v]
                    point_tag[v] = geo.addPoint(x, y, 0.0, h)
            if (b, a) in line_tag:
                return -line_tag[(b, a)]
            if (a, b) not in line_tag:
                line_tag[(a, b)] = geo.addLine(point_tag[a], point_tag[b])
            return line_tag[(a, b)]

        def curve_loop(loop: Loop) -> int:
            return geo.addCurveLoop([line(a, b) for a, b in zip(loop, np.roll(loop, -1))])

        groups = {}
        for group, (tag, pieces) in enumerate(regions.items(), start=1):
            groups[group] = tag
            surfaces = [geo.addPlaneSurface([curve_loop(outer)] + [curve_loop(hole) for hole in holes])
                        for outer, holes in pieces]
            geo.synchronize()
            gmsh.model.addPhysicalGroup(2, surfaces, group)
        gmsh.model.mesh.generate(2)
        points, offsets, flat, group_of_cell = model_cells(gmsh, None)
    if np.any(np.diff(offsets) != 3):
        raise RuntimeError("gmsh returned non-triangular cells")
    tags = np.array([groups[g] for g in group_of_cell.tolist()], dtype=np.int32)
    return TriangleMesh(points, flat.reshape(-1, 3), tags)


def p2_unknowns(triangles: np.ndarray) -> int:
    """Number of P2 displacement unknowns, 2 (vertices + edges), of a triangle mesh (m, 3)."""
    edges = edge_key(triangles, np.roll(triangles, -1, axis=1), int(triangles.max(initial=-1)) + 1)
    return 2 * (np.unique(triangles).size + np.unique(edges).size)


def matched_triangulation(mesh: PolygonMesh, target: int | None = None, *, rtol: float = 0.05,
                          max_meshes: int = 6) -> tuple[float, TriangleMesh]:
    """The triangulation whose P2 unknowns match ``target`` (default: the SFVEM unknowns of ``mesh``).

    Rule: start from the size of equilateral triangles that would give ``target`` P2
    unknowns without boundary refinement (about 4 per triangle: ``h0 = sqrt(4 A / (target
    sqrt(3)/4))``, A the area), then correct ``h <- h sqrt(N(h) / target)`` until the
    count ``N(h)`` is within ``rtol`` of the target or ``max_meshes`` meshes were made;
    the closest mesh wins. The boundary refinement (polygon edges kept) adds unknowns
    that do not scale with ``h``; the correction absorbs it.

    Returns
    -------
    h : float
        The chosen mesh size.
    TriangleMesh
    """
    target = sfvem_unknowns(mesh) if target is None else int(target)
    h = float(np.sqrt(4 * mesh.areas.sum() / (target * np.sqrt(3) / 4)))
    best = None
    for _ in range(max_meshes):
        tri = triangulate(mesh, h)
        n = p2_unknowns(tri.triangles)
        if best is None or abs(np.log(n / target)) < abs(np.log(best[2] / target)):
            best = (h, tri, n)
        if abs(n - target) <= rtol * target:
            break
        h *= np.sqrt(n / target)
    return best[0], best[1]
