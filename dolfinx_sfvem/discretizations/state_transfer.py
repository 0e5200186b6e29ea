"""Transfer of an SFVEM state to a locally refined mesh (docs/refinement-local.md).

The SFVEM DOFs of the refined mesh (vertex values, edge-midpoint values, polygon means; paper
§4.1) are taken from the old state so that any field whose edge traces are quadratic and whose
polygon projections Π^∇_2 (Eq. 36) reproduce it -- every quadratic -- is carried over exactly: a
node on an old edge takes the value of that edge's quadratic trace, a node inside an old polygon
the value of its projection Π^∇_2 u, and the mean of a new polygon cut from an old one the mean
of Π^∇_2 u over it. States are indexed by node key (:mod:`~dolfinx_sfvem.discretizations.node_keys`); the
refinement (:mod:`~dolfinx_sfvem.mesh.refine`) keeps the index of every old point.

The Lagrange FEM's state on a refined simplex mesh (:mod:`~dolfinx_sfvem.mesh.cell_refine`) is the
interpolation of the old P2 field: each node of a new cell takes the value of its parent cell's P2
polynomial there (:func:`transfer_lagrange_state`), exact for every field of the old P2 space, as the
new cells lie inside the old ones. :func:`carry_state` takes either refinement.
"""
from __future__ import annotations

import numba
import numpy as np
import numpy.typing as npt

from dolfinx_sfvem.discretizations.discretization import KeyedState, values_by_key
from dolfinx_sfvem.discretizations.monomials import evaluate_monomials
from dolfinx_sfvem.discretizations.node_keys import lagrange_midpoint_keys, mean_keys, midpoint_keys, n_keys
from dolfinx_sfvem.mesh.cell_mesh import CellMesh, reference_edges
from dolfinx_sfvem.mesh.cell_refine import CellRefinement, barycentric
from dolfinx_sfvem.mesh.polygon import point_segment_distance
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh, Refinement
from dolfinx_sfvem.mesh.csr import concatenated_ranges
from dolfinx_sfvem.discretizations.projection import build_projections
from dolfinx_sfvem.discretizations.quadrature import polygon_quadrature


@numba.njit(cache=True)
def _on_edge(x, polygon, points, offsets, start, end, tol):
    """For every point x[i] (n, 2) in polygon[i]: the side (CSR entry, from point start[k] to
    end[k]) it lies on (within tol) or -1, and its position t in [0, 1] along that side."""
    entry = np.full(x.shape[0], -1, dtype=np.int64)
    t = np.zeros(x.shape[0])
    for i in range(x.shape[0]):
        for k in range(offsets[polygon[i]], offsets[polygon[i] + 1]):
            a, b = points[start[k]], points[end[k]]
            if point_segment_distance(x[i], a, b) <= tol:
                d = b - a
                entry[i] = k
                t[i] = ((x[i, 0] - a[0]) * d[0] + (x[i, 1] - a[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1])
                break
    return entry, t


@numba.njit(cache=True)
def _projected(x, which, centroid, diameter, Pi_offsets, Pi_nabla, dof_offsets, dof_values):
    """Π^∇_2 u of polygon which[i] at x[i]: (n, 2). Polygon j has Pi_nabla
    ``Pi_nabla[Pi_offsets[j]:Pi_offsets[j+1]]`` (6, nd_j) and DOF values
    ``dof_values[dof_offsets[j]:dof_offsets[j+1]]`` (nd_j, 2)."""
    out = np.empty((x.shape[0], 2))
    m, dm_dx, dm_dy = np.empty(6), np.empty(6), np.empty(6)
    for i in range(x.shape[0]):
        j = which[i]
        evaluate_monomials(x[i], centroid[j], diameter[j], 2, m, dm_dx, dm_dy)
        nd = dof_offsets[j + 1] - dof_offsets[j]
        P = Pi_nabla[Pi_offsets[j]:Pi_offsets[j + 1]].reshape(6, nd)
        out[i] = (m @ P) @ dof_values[dof_offsets[j]:dof_offsets[j + 1]]
    return out


class _CoarseState:
    """An SFVEM state on a mesh, read through the two ways the method defines u inside a
    polygon: edge traces (quadratic through vertex, midpoint, vertex) and Π^∇_2 (Eq. 36)."""

    def __init__(self, mesh: PolygonMesh, values: npt.NDArray[np.float64], polygons: npt.NDArray[np.int64]):
        self.mesh, self.values = mesh, values
        self.local = np.full(mesh.n_polygons, -1, dtype=np.int64)
        self.local[polygons] = np.arange(polygons.size)
        self.proj = build_projections(mesh.points, mesh.offsets, mesh.vertices, polygons=polygons)
        N = mesh.offsets[polygons + 1] - mesh.offsets[polygons]
        sides = concatenated_ranges(mesh.offsets[polygons], N)
        v, w = mesh.sides.start[sides], mesh.sides.end[sides]
        first = np.concatenate([[0], np.cumsum(2 * N + 1)[:-1]])
        self.dof_offsets = np.concatenate([[0], np.cumsum(2 * N + 1)]).astype(np.int64)
        self.dof_values = np.empty((self.dof_offsets[-1], 2))
        self.dof_values[concatenated_ranges(first, N)] = values[v]
        self.dof_values[concatenated_ranges(first + N, N)] = values[midpoint_keys(mesh, v, w)]
        self.dof_values[first + 2 * N] = values[mean_keys(mesh, polygons)]

    def at(self, x: npt.NDArray[np.float64], polygon: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        """u (n, 2) at points x (n, 2) of the polygons ``polygon`` (n,): the edge trace on their
        boundary, Π^∇_2 u inside."""
        mesh, sides = self.mesh, self.mesh.sides
        entry, t = _on_edge(x, polygon, mesh.points, mesh.offsets, sides.start, sides.end, mesh.tol)
        out = np.empty((x.shape[0], 2))
        edge = entry >= 0
        inside = ~edge
        out[inside] = self.projected(x[inside], polygon[inside])
        k = entry[edge]
        start, end = sides.start[k], sides.end[k]
        s = t[edge][:, None]
        out[edge] = (self.values[start] * (1 - s) * (1 - 2 * s) + self.values[midpoint_keys(mesh, start, end)]
                     * 4 * s * (1 - s) + self.values[end] * s * (2 * s - 1))
        return out

    def projected(self, x: npt.NDArray[np.float64], polygon: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        """Π^∇_2 u (n, 2) of the polygons ``polygon`` (n,) at x (n, 2)."""
        p = self.proj
        if np.any(self.local[polygon] < 0):
            raise RuntimeError("refine: a point inside a polygon that was not refined")
        return _projected(np.ascontiguousarray(x), self.local[polygon], p.centroid, p.diameter, p.Pi_nabla_offsets,
                          p.Pi_nabla, self.dof_offsets, self.dof_values)


def transfer_state(refinement: Refinement, values: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """SFVEM DOF values on ``refinement.mesh`` from those on ``refinement.coarse``.

    Parameters
    ----------
    refinement
        From :meth:`~dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh.refine`.
    values : (n_keys_coarse, 2) float64
        Displacement at every node key of the coarse mesh (:mod:`~dolfinx_sfvem.discretizations.node_keys`;
        rows of unused points are ignored).

    Returns
    -------
    (n_keys_fine, 2) float64
        Displacement at every node key of the refined mesh: old points keep their values,
        nodes on old edges take the edge's quadratic trace, nodes inside refined polygons
        Π^∇_2 u of the old polygon, new polygons' means the mean of Π^∇_2 u over them,
        unrefined polygons their old mean.
    """
    coarse, fine, parent = refinement.coarse, refinement.mesh, refinement.parent
    old = _CoarseState(coarse, np.asarray(values, dtype=np.float64), np.flatnonzero(refinement.selected))
    out = np.full((n_keys(fine), 2), np.nan)
    out[:coarse.n_points] = values[:coarse.n_points]

    # one polygon listing each new point and each edge; refined parents only change anything
    a, b = fine.sides.start, fine.sides.end
    owner = parent[fine.sides.polygon]
    new_point, first = np.unique(a, return_index=True)
    keep = new_point >= coarse.n_points
    out[new_point[keep]] = old.at(fine.points[new_point[keep]], owner[first[keep]])
    _, first = np.unique(fine.sides.edge, return_index=True)
    a, b, owner = a[first], b[first], owner[first]
    out[midpoint_keys(fine, a, b)] = old.at(0.5 * (fine.points[a] + fine.points[b]), owner)

    # means: unrefined polygons keep theirs, children integrate Π^∇_2 u of their parent
    mean_key = mean_keys(fine, np.arange(fine.n_polygons))
    child = refinement.selected[parent]
    out[mean_key[~child]] = values[mean_keys(coarse, parent[~child])]
    children = np.flatnonzero(child)
    q_offsets, x_q, w_q = polygon_quadrature(fine.nodes, fine.quadrature_triangles, fine.quadrature_triangle_offsets,
                                             children, np.full(children.size, 2))
    counts = np.diff(q_offsets)
    u_q = old.projected(x_q, np.repeat(parent[children], counts)) * w_q[:, None]
    out[mean_key[children]] = np.add.reduceat(u_q, q_offsets[:-1], axis=0) / fine.areas[children, None]
    return out


def _lagrange_nodes(mesh: CellMesh, cells: npt.NDArray[np.int64]
                    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """The P2 nodes of simplex ``cells`` (n,) of ``mesh``, vertices then edge midpoints in DOLFINx's
    order: (keys (n, k), coordinates (n, k, d))."""
    edges = np.asarray(reference_edges(mesh.cell_type))
    corners = mesh.cells[cells]
    keys = np.hstack([corners, lagrange_midpoint_keys(mesh.n_points, corners[:, edges[:, 0]], corners[:, edges[:, 1]])])
    x = mesh.points[corners]
    return keys, np.concatenate([x, 0.5 * (x[:, edges[:, 0]] + x[:, edges[:, 1]])], axis=1)


def transfer_lagrange_state(refinement: CellRefinement, state: KeyedState) -> KeyedState:
    """P2 node values on ``refinement.mesh`` interpolated from those on ``refinement.coarse``.

    Parameters
    ----------
    refinement
        From :func:`~dolfinx_sfvem.mesh.cell_refine.refine_cells`.
    state
        The displacement at every P2 node of the coarse mesh, by key
        (:func:`~dolfinx_sfvem.discretizations.node_keys.lagrange_midpoint_keys`).

    Returns
    -------
    KeyedState
        The displacement at every P2 node of the refined mesh: the coarse P2 field of the parent
        cell evaluated there (the module docstring).
    """
    coarse, fine, parent = refinement.coarse, refinement.mesh, refinement.parent
    old_keys, _ = _lagrange_nodes(coarse, parent)
    new_keys, x = _lagrange_nodes(fine, np.arange(fine.n_cells))
    lam = barycentric(coarse.points[coarse.cells[parent]], x)                    # (n, k, d + 1)
    edges = np.asarray(reference_edges(coarse.cell_type))
    basis = np.concatenate([lam * (2.0 * lam - 1.0), 4.0 * lam[:, :, edges[:, 0]] * lam[:, :, edges[:, 1]]],
                           axis=2)                                               # (n, k new nodes, k old nodes)
    d = state.values.shape[1]
    old = values_by_key(state.keys, state.values, old_keys.ravel()).reshape(*old_keys.shape, d)
    keys, first = np.unique(new_keys.ravel(), return_index=True)
    return KeyedState(keys, np.einsum("npk,nkd->npd", basis, old).reshape(-1, d)[first])


def carry_state(refinement: Refinement | CellRefinement, state: KeyedState) -> KeyedState:
    """The state on ``refinement.mesh`` from ``state`` on ``refinement.coarse``: :func:`transfer_state`
    (SFVEM on polygons) or :func:`transfer_lagrange_state` (P2 on simplices)."""
    if isinstance(refinement, CellRefinement):
        return transfer_lagrange_state(refinement, state)
    dense = np.full((int(state.keys.max()) + 1, state.values.shape[1]), np.nan)
    dense[state.keys] = state.values
    values = transfer_state(refinement, dense)
    return KeyedState(np.arange(values.shape[0]), values)
