"""The nodes of the order-2 SFVEM on a polygon mesh: partition-independent keys, number of unknowns.

A polygon with N vertices carries 2N + 1 nodes (paper §4.1, χ¹–χ³): its vertices, its edge
midpoints and its mean. Over the mesh a vertex shared by polygons is one node, and so is the
midpoint of a shared edge (hanging nodes are ordinary vertices). The *key* of a node is

- the point index of a vertex, in [0, n_points);
- ``n_points + e`` for the midpoint of edge ``e`` (:meth:`PolygonMesh.edge_index
  <dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh.edge_index>`);
- ``n_points + n_edges + i`` for the mean of polygon ``i``.

Keys do not depend on the partition: checkpoints, the contact checks and the transfer of a
state to a refined mesh find nodes by key. Points no polygon uses have a key but no node.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from dolfinx_sfvem.mesh.csr import edge_key
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh


def midpoint_keys(mesh: PolygonMesh, a: npt.ArrayLike, b: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """Keys (n,) of the midpoint nodes of the edges between points ``a`` and ``b`` (n,), either direction."""
    return mesh.n_points + mesh.edge_index(a, b)


def mean_keys(mesh: PolygonMesh, polygons: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """Keys (n,) of the mean nodes of ``polygons`` (n,)."""
    return mesh.n_points + mesh.n_edges + np.asarray(polygons, dtype=np.int64)


def lagrange_midpoint_keys(n_points: int, a: npt.ArrayLike, b: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """Keys (n,) of the Lagrange FEM's edge nodes between points ``a`` and ``b`` (n,) of its mesh of
    ``n_points`` points: ``n_points + edge_key(a, b)`` (its vertex nodes' keys are their points;
    :meth:`~dolfinx_sfvem.discretizations.fem.LagrangeDiscretization.midpoint_keys`)."""
    return n_points + edge_key(np.asarray(a, dtype=np.int64), np.asarray(b, dtype=np.int64), n_points)


def n_keys(mesh: PolygonMesh) -> int:
    """Size of the key range: n_points + n_edges + n_polygons."""
    return mesh.n_points + mesh.n_edges + mesh.n_polygons


def sfvem_unknowns(mesh: PolygonMesh) -> int:
    """Number of SFVEM displacement unknowns on ``mesh``: 2 x (vertices + edge midpoints + polygon means)."""
    return 2 * (mesh.used_points.size + mesh.n_edges + mesh.n_polygons)
