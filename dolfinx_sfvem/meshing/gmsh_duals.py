"""Polygon meshes made from gmsh triangle meshes: the triangles themselves, or the dual of a
Frontal-Delaunay mesh (Voronoi-like polygons), e.g. of a region bounded by straight sides.

Each call runs its own gmsh session (:func:`~dolfinx_sfvem.meshing.gmsh_io.gmsh_session`).
"""
from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import numpy.typing as npt

from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.meshing.dual import dual_polygons
from dolfinx_sfvem.meshing.gmsh_io import gmsh_session, model_cells, write_gmsh
from dolfinx_sfvem.meshing.grids import n_segments
from dolfinx_sfvem.meshing.polygon_sets import PolygonSet


#: gmsh geometry builder: ``build(gmsh, h)`` -> {region tag: surface tags}
GmshBuilder = Callable[[object, float], Mapping[int, Sequence[int]]]


def gmsh_triangles(build: GmshBuilder, h: float, keep_gmsh: str | os.PathLike | None = None) -> PolygonSet:
    """A gmsh triangle mesh of size ``h``, one polygon per triangle.

    ``build(gmsh, h)`` creates the geometry in a fresh gmsh model (synchronised) and
    returns ``{region tag: surface tags}``; the triangles are Frontal-Delaunay
    (``Mesh.Algorithm`` 6) with ``Mesh.MeshSizeMax = h``. With ``keep_gmsh``, the model is
    also written to ``<keep_gmsh>.geo`` and ``<keep_gmsh>.msh`` (:func:`write_gmsh`).
    """
    with gmsh_session() as gmsh:
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        for tag, surfaces in build(gmsh, h).items():
            gmsh.model.addPhysicalGroup(2, list(surfaces), tag)
        gmsh.model.mesh.generate(2)
        if keep_gmsh is not None:
            write_gmsh(gmsh, keep_gmsh)
        points, _, flat, tags = model_cells(gmsh, None)
    return PolygonSet(points, list(flat.reshape(-1, 3)), tags)


def dual_of_gmsh(build: GmshBuilder, h: float, keep_gmsh: str | os.PathLike | None = None) -> PolygonSet:
    """Dual polygons (:func:`dual_polygons`) of the gmsh triangle mesh :func:`gmsh_triangles`
    (same arguments)."""
    triangles = gmsh_triangles(build, h, keep_gmsh)
    return dual_polygons(triangles.points, np.asarray(triangles.polygons), triangles.tags)


def straight_region(loops: Sequence[npt.ArrayLike], tag: int) -> GmshBuilder:
    """gmsh builder (see :func:`dual_of_gmsh`) of one region bounded by straight sides.

    ``loops[0]`` is the outer boundary, the others holes; each is a closed polyline of
    corner points (n_i, 2). Every side is a transfinite line of ``n_segments(length, h)``
    equal segments, so the boundary nodes are predictable: they coincide with
    :func:`axis_nodes` grids on the same sides.
    """
    def build(gmsh, h: float) -> dict[int, list[int]]:
        curve_loops = []
        for loop in loops:
            corners = np.asarray(loop, dtype=np.float64)
            pts = [gmsh.model.geo.addPoint(x, y, 0.0, h) for x, y in corners]
            lines = [gmsh.model.geo.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
            lengths = np.linalg.norm(np.roll(corners, -1, axis=0) - corners, axis=1)
            for line, length in zip(lines, lengths):
                gmsh.model.geo.mesh.setTransfiniteCurve(line, n_segments(length, h) + 1)
            curve_loops.append(gmsh.model.geo.addCurveLoop(lines))
        surface = gmsh.model.geo.addPlaneSurface(curve_loops)
        gmsh.model.geo.synchronize()
        return {tag: [surface]}

    return build


def polygon_rectangle(Lx: float, Ly: float, h: float, origin: Sequence[float] = (0.0, 0.0),
                      tag: int = 0) -> PolygonMesh:
    """Voronoi-like polygons (mostly 5-8 vertices) on a rectangle.

    The dual (:func:`dual_polygons`) of a gmsh Frontal-Delaunay triangle mesh of size ``h``
    whose sides carry ``round(L/h)`` equal segments. The rectangle's corners and all
    boundary triangle vertices are polygon vertices.

    Parameters
    ----------
    Lx, Ly : float
        Side lengths.
    h : float
        Triangle size (the polygons are about ``h`` across).
    origin : (2,) float
        Lower-left corner.
    tag : int
        Region tag of every polygon.
    """
    x0, y0 = origin
    corners = np.array([[x0, y0], [x0 + Lx, y0], [x0 + Lx, y0 + Ly], [x0, y0 + Ly]])
    return dual_of_gmsh(straight_region([corners], tag), h).to_mesh()
