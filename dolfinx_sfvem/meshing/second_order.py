"""Curved (degree-2) cell meshes from straight ones: the nodes of a quadratic geometry placed at
the straight cells' edge midpoints (and face and cell centres), then moved by a map of the user's,
e.g. onto a sphere, or by a smooth warp of the interior (gmsh's ``setOrder(2)`` does the same for
its models: :func:`~dolfinx_sfvem.meshes.read_gmsh` reads it).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from dolfinx_sfvem import _compat
from dolfinx_sfvem.mesh.cell_mesh import CellMesh, reference_nodes, vertices_first
from dolfinx_sfvem.meshing.polygon_sets import length_tolerance

#: a map of node coordinates (n, gdim) -> new coordinates (n, gdim)
Placement = Callable[[np.ndarray], np.ndarray]


def second_order(mesh: CellMesh, place: Placement | None = None) -> CellMesh:
    """The degree-2 :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh` of the cells of a degree-1 ``mesh``.

    Every node of the quadratic geometry (:func:`~dolfinx_sfvem.mesh.cell_mesh.reference_nodes`) is
    first the image of its reference position under the cell's degree-1 map (a vertex, an edge's
    midpoint, a face's or the cell's centre: nodes shared by cells are merged by position), then
    ``place(x)`` of all of them, vertices included (None: left there, a straight mesh of degree 2).

    Parameters
    ----------
    mesh
        A mesh of degree-1 geometry, any cell type.
    place
        Node coordinates (n, gdim) -> their positions (n, gdim).

    Returns
    -------
    CellMesh
        Its ``points`` are the vertices (moved by ``place``), its ``cells`` the same cells; regions
        and named boundaries kept (ValueError naming a cell that ``place`` inverts).
    """
    if mesh.geometry_degree != 1:
        raise ValueError(f"second_order: the mesh has geometry of degree {mesh.geometry_degree} already")
    cell = mesh.cell_type
    n_vertices = mesh.cells.shape[1]
    linear = np.asarray(_compat.lagrange_element(cell, 1).tabulate(0, reference_nodes(cell, 2)))[0, :, :, 0]
    x = np.einsum("pk,ckd->cpd", linear, mesh.points[mesh.cells]).reshape(-1, mesh.gdim)     # (n_cells * k, gdim)
    key = np.round((x - x.min(axis=0, initial=0.0)) / length_tolerance(mesh.points)).astype(np.int64)
    _, first, nodes = np.unique(key, axis=0, return_index=True, return_inverse=True)
    points, nodes, _, _ = vertices_first(x[first], nodes.reshape(mesh.n_cells, -1), n_vertices)
    if place is not None:
        points = np.asarray(place(points), dtype=np.float64).reshape(points.shape)
    vertex = np.zeros(mesh.n_points, dtype=np.int64)         # the new index of every vertex of ``mesh``
    vertex[mesh.cells] = nodes[:, :n_vertices]
    return CellMesh(points, nodes, mesh.tags, cell, mesh.region_names,
                    {name: vertex[facets] for name, facets in mesh.boundary_names.items()})
