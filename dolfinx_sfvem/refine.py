"""Local refinement of a polygon mesh with hanging nodes, and transfer of an SFVEM state to it.

Refinement (docs/refinement-local.md): every selected polygon is cut into *pieces* that are
star-shaped from a centre point -- the polygon itself with the centre of its fan
sub-triangulation (its centroid if that sees every edge, else the centroid of its visibility region), or,
for a polygon without such a point, the ear triangles of its sub-triangulation with their
centroids. A piece with vertices v_0 .. v_{n-1} and edge midpoints m_i (on edge v_i v_{i+1})
becomes the n quadrilaterals [c, m_{i-1}, v_i, m_i], except at a reflex vertex v_i, where the
dart-shaped quadrilateral is replaced by the two triangles [c, m_{i-1}, v_i] and [c, v_i, m_i]
(repeated refinement of darts would give ever thinner polygons). A polygon that is not refined but shares
a split edge gets that edge's midpoint inserted into its vertex list: a hanging node.

Transfer: the SFVEM DOFs of the refined mesh (vertex values, edge-midpoint values, polygon
means; paper §4.1) are taken from the old state so that any field whose edge traces are
quadratic and whose polygon projections Π^∇_2 (Eq. 36) reproduce it -- every quadratic -- is
carried over exactly: a node on an old edge takes the value of that edge's quadratic trace, a
node inside an old polygon the value of its projection Π^∇_2 u, and the mean of a new polygon
cut from an old one the mean of Π^∇_2 u over it.

Node keys follow :attr:`~dolfinx_sfvem.space.VEMSpace.node_key`: point index for vertices,
``n_points`` + global edge index for midpoints, ``n_points + n_edges`` + polygon index for
means. Points keep their index: refinement only appends points.
"""
from __future__ import annotations

import typing
from dataclasses import dataclass

import numba
import numpy as np
import numpy.typing as npt

from .polygon_mesh import PolygonMesh
from .monomials import evaluate_monomials
from .polygon import RTOL, point_segment_distance
from .projection import RANK_TOL, _build_all, build_projections
from .quadrature import polygon_quadrature
from .space import _GlobalEdges, _ranges, _vertex_positions

Marker = typing.Callable[[np.ndarray], np.ndarray]
Selection = typing.Union[Marker, npt.ArrayLike, None]


@dataclass(frozen=True)
class Refinement:
    """A refined mesh and how it derives from the mesh it was cut from.

    Attributes
    ----------
    coarse : PolygonMesh
        The mesh that was refined.
    mesh : PolygonMesh
        The refined mesh; its first ``coarse.n_points`` points are those of ``coarse``.
    parent : (mesh.n_polygons,) int64
        The polygon of ``coarse`` containing each polygon of ``mesh``.
    selected : (coarse.n_polygons,) bool
        The polygons of ``coarse`` that were split: the selection and the neighbours split to keep
        the projection order bounded (:func:`refine_mesh`); the others at most gained hanging nodes.
    levels : int
        Times the selected polygons (and then their children) were split.
    """
    coarse: PolygonMesh
    mesh: PolygonMesh
    parent: npt.NDArray[np.int64]
    selected: npt.NDArray[np.bool_]
    levels: int

    def describe(self) -> str:
        """One line: polygons and points before and after."""
        return (f"refined {int(self.selected.sum())} of {self.coarse.n_polygons} polygons {self.levels} time(s): "
                f"{self.mesh.n_polygons} polygons, {self.mesh.n_points} points "
                f"({self.mesh.hanging_nodes.size} hanging nodes)")


# --------------------------------------------------------------------------- selection
def select_polygons(mesh: PolygonMesh, where: Selection = None,
                    tags: typing.Iterable[int | str] | None = None) -> npt.NDArray[np.bool_]:
    """Mask (n_polygons,) of the polygons chosen by ``where`` and ``tags`` (both: the intersection).

    Parameters
    ----------
    where
        A marker ``f(x) -> bool (n,)`` of the centroids ``x`` (2, n) (as the markers of
        :meth:`~dolfinx_sfvem.problem.ContactProblem.fix`), a boolean mask (n_polygons,), or
        polygon indices.
    tags
        Region tags (or names in ``mesh.region_names``): all polygons of these regions.

    Raises
    ------
    ValueError
        Nothing given, a marker result or mask of the wrong shape, indices out of range, an
        unknown tag or name, an empty selection.
    """
    if where is None and tags is None:
        raise ValueError("refine: give a centroid marker, a polygon mask or polygon indices, and/or region tags")
    n = mesh.n_polygons
    chosen = np.ones(n, dtype=bool)
    if callable(where):
        marked = np.asarray(where(mesh.centroids.T.copy()))
        if marked.shape != (n,) or marked.dtype.kind not in "bui":
            raise ValueError(f"refine: the marker must return a bool array of shape ({n},) (one entry per polygon "
                             f"centroid), got shape {marked.shape} and dtype {marked.dtype}")
        chosen &= marked.astype(bool)
    elif where is not None:
        given = np.asarray(where)
        if given.dtype == bool:
            if given.shape != (n,):
                raise ValueError(f"refine: a polygon mask must have shape ({n},), got {given.shape}")
            chosen &= given
        elif given.dtype.kind in "iu" and given.ndim <= 1:
            given = given.reshape(-1)
            bad = given[(given < 0) | (given >= n)]
            if bad.size:
                raise ValueError(f"refine: polygon index {bad[0]} out of range [0, {n})")
            mask = np.zeros(n, dtype=bool)
            mask[given] = True
            chosen &= mask
        else:
            raise ValueError("refine: 'where' must be a centroid marker, a boolean mask or polygon indices, "
                             f"got an array of dtype {given.dtype} and shape {given.shape}")
    if tags is not None:
        chosen &= np.isin(mesh.tags, _region_tags(mesh, tags))
    if not chosen.any():
        raise ValueError("refine: the selection is empty (no polygon chosen)")
    return chosen


def _region_tags(mesh: PolygonMesh, tags: typing.Iterable[int | str]) -> npt.NDArray[np.int64]:
    """Tags from tags or region names; ValueError for one that no polygon carries."""
    if isinstance(tags, (int, str, np.integer)):
        tags = [tags]
    out = []
    for t in tags:
        if isinstance(t, str):
            if t not in mesh.region_names:
                raise ValueError(f"refine: {t!r} is not a region name of the mesh "
                                 f"(its names: {sorted(mesh.region_names) or 'none'})")
            t = mesh.region_names[t]
        if not np.any(mesh.tags == t):
            raise ValueError(f"refine: no polygon has region tag {t} (tags: {np.unique(mesh.tags).tolist()})")
        out.append(int(t))
    return np.asarray(out, dtype=np.int64)


# --------------------------------------------------------------------------- splitting
def _pieces(mesh: PolygonMesh, chosen: npt.NDArray[np.int64]):
    """Star-shaped pieces of the chosen polygons: (offsets, vertices, centres (n, 2), polygon (n,)).

    A polygon with a fan sub-triangulation is one piece around its fan centre; any other is
    split into its ear triangles, each around its centroid."""
    a, b = mesh.interior_node[chosen, 0], mesh.interior_node[chosen, 1]
    fan = chosen[a == b]
    ears = chosen[a != b]
    N = np.diff(mesh.offsets)[fan]
    fan_vertices = mesh.vertices[_ranges(mesh.offsets[fan], N)]
    n_tri = np.diff(mesh.triangle_offsets)[ears]
    triangles = mesh.triangles[_ranges(mesh.triangle_offsets[ears], n_tri)]
    sizes = np.concatenate([N, np.full(triangles.shape[0], 3)])
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    vertices = np.concatenate([fan_vertices, triangles.ravel()]).astype(np.int64)
    centres = np.vstack([mesh.nodes[mesh.interior_node[fan, 0]], mesh.points[triangles].mean(axis=1)])
    polygon = np.concatenate([fan, np.repeat(ears, n_tri)]).astype(np.int64)
    return offsets, vertices, centres, polygon


def _edge_keys(a: npt.NDArray[np.int64], b: npt.NDArray[np.int64], n: int) -> npt.NDArray[np.int64]:
    return np.minimum(a, b) * n + np.maximum(a, b)


def _split_once(mesh: PolygonMesh, selected: npt.NDArray[np.bool_]
                ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int64],
                           npt.NDArray[np.int64], npt.NDArray[np.bool_]]:
    """One refinement level: (points, offsets, vertices, parent, is_child) of the new polygons.

    Points of ``mesh`` keep their index; edge midpoints and then piece centres are appended.
    ``is_child`` marks the polygons cut from selected ones (the others are the unselected
    polygons, with the midpoints of their split edges inserted)."""
    n = mesh.n_points
    offsets, vertices, centres, polygon = _pieces(mesh, np.flatnonzero(selected))
    this, nxt = _vertex_positions(offsets, np.arange(offsets.size - 1))
    split, midpoint_of_entry = np.unique(_edge_keys(vertices[this], vertices[nxt], n), return_inverse=True)
    midpoint_of_entry = n + midpoint_of_entry.reshape(-1)
    midpoints = 0.5 * (mesh.points[split // n] + mesh.points[split % n])
    centre_of_piece = n + split.size + np.arange(centres.shape[0])
    # quad [c, m_{i-1}, v_i, m_i] for every piece entry i (prev: the entry whose successor is i);
    # at a reflex vertex the two triangles [c, m_{i-1}, v_i], [c, v_i, m_i] instead (no darts)
    prev = np.empty_like(nxt)
    prev[nxt] = this
    piece = np.repeat(np.arange(offsets.size - 1), np.diff(offsets))
    x = mesh.points
    d_in, d_out = x[vertices[this]] - x[vertices[prev]], x[vertices[nxt]] - x[vertices[this]]
    reflex = (d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
              < -RTOL * np.hypot(*d_in.T) * np.hypot(*d_out.T))        # collinear (hanging) vertices are not
    c, m_prev, v, m = centre_of_piece[piece], midpoint_of_entry[prev], vertices[this], midpoint_of_entry[this]
    children = [np.column_stack([c, m_prev, v, m])[~reflex], np.column_stack([c, m_prev, v])[reflex],
                np.column_stack([c, v, m])[reflex]]
    child_polygon = np.concatenate([polygon[piece][~reflex], polygon[piece][reflex], polygon[piece][reflex]])
    child_sizes = np.concatenate([np.full(k.shape[0], k.shape[1]) for k in children])

    # unselected polygons: insert the midpoint of every split edge after its start vertex
    kept = np.flatnonzero(~selected)
    k_this, k_nxt = _vertex_positions(mesh.offsets, kept)
    key = _edge_keys(mesh.vertices[k_this], mesh.vertices[k_nxt], n)
    pos = np.minimum(np.searchsorted(split, key), split.size - 1)
    hit = split[pos] == key
    kept_vertices = np.insert(mesh.vertices[k_this], np.flatnonzero(hit) + 1, n + pos[hit])
    kept_sizes = np.diff(mesh.offsets)[kept] + np.bincount(np.repeat(np.arange(kept.size),
                                                                     np.diff(mesh.offsets)[kept])[hit],
                                                           minlength=kept.size)
    # all polygons, ordered by parent (children of one polygon together, in piece order)
    parent = np.concatenate([kept, child_polygon])
    sizes = np.concatenate([kept_sizes, child_sizes])
    flat = np.concatenate([kept_vertices] + [k.ravel() for k in children])
    start = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    order = np.argsort(parent, kind="stable")
    new_offsets = np.concatenate([[0], np.cumsum(sizes[order])]).astype(np.int64)
    new_vertices = flat[_ranges(start[order], sizes[order])]
    is_child = np.concatenate([np.zeros(kept.size, dtype=bool), np.ones(child_polygon.size, dtype=bool)])[order]
    points = np.vstack([mesh.points, midpoints, centres])
    return points, new_offsets, new_vertices, parent[order], is_child


def _beyond_l(points: npt.NDArray[np.float64], offsets: npt.NDArray[np.int64], vertices: npt.NDArray[np.int64],
              polygons: npt.NDArray[np.int64], max_l: int) -> npt.NDArray[np.bool_]:
    """Mask over ``polygons``: no projection order 3 <= l <= max_l passes the rank check."""
    n = polygons.size
    nd = 2 * (offsets[polygons + 1] - offsets[polygons]) + 1
    status = _build_all(points, offsets, vertices, polygons, np.full(n, 3, dtype=np.int64),
                        np.full(n, max_l, dtype=np.int64), RANK_TOL,
                        np.concatenate([[0], np.cumsum(6 * nd)]).astype(np.int64))[0]
    return status != 0


def refine_mesh(mesh: PolygonMesh, where: Selection = None, levels: int = 1, *,
                tags: typing.Iterable[int | str] | None = None, max_l: int = 6) -> Refinement:
    """Split the selected polygons ``levels`` times; unrefined neighbours gain hanging nodes.

    Parameters
    ----------
    mesh
        Any valid polygon mesh (convex, non-convex polygons, hanging nodes).
    where, tags
        The polygons to refine (:func:`select_polygons`).
    levels
        Number of splits (>= 1); level k + 1 splits the children of level k, so a selected
        polygon ends up as about (number of vertices) x 4^(levels - 1) polygons.
    max_l
        A neighbour whose new hanging nodes would need a projection order l > ``max_l`` (the
        rank check of docs/method.md §3; many hanging nodes on one side) is split too, at that
        level, until no polygon needs more (closure).

    Returns
    -------
    Refinement
        The new mesh (region tags and names kept) and the parent of every new polygon.
    """
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 1:
        raise ValueError(f"refine: levels must be an integer >= 1, got {levels!r}")
    if isinstance(max_l, bool) or not isinstance(max_l, (int, np.integer)) or not 3 <= max_l <= 10:
        raise ValueError(f"refine: max_l must be an integer in [3, 10], got {max_l!r}")
    chosen = select_polygons(mesh, where, tags)
    current, ancestor = mesh, np.arange(mesh.n_polygons, dtype=np.int64)
    for _ in range(int(levels)):
        while True:
            points, offsets, vertices, parent, is_child = _split_once(current, chosen)
            gained = np.flatnonzero(~is_child & (np.diff(offsets) > np.diff(current.offsets)[parent]))
            beyond = gained[_beyond_l(points, offsets, vertices, gained, int(max_l))]
            if beyond.size == 0:
                break
            chosen[parent[beyond]] = True
        refined = PolygonMesh(points, np.split(vertices, offsets[1:-1]), current.tags[parent],
                              insert_hanging_nodes=False)
        refined.region_names = dict(mesh.region_names)
        current, ancestor, chosen = refined, ancestor[parent], is_child
    split = np.bincount(ancestor, minlength=mesh.n_polygons) > 1
    return Refinement(mesh, current, ancestor, split, int(levels))


# --------------------------------------------------------------------------- state transfer
@numba.njit(cache=True)
def _on_edge(x, polygon, points, offsets, vertices, tol):
    """For every point x[i] (n, 2) in polygon[i]: the CSR entry of the polygon edge it lies on
    (within tol) or -1, and its position t in [0, 1] along that edge."""
    entry = np.full(x.shape[0], -1, dtype=np.int64)
    t = np.zeros(x.shape[0])
    for i in range(x.shape[0]):
        s, e = offsets[polygon[i]], offsets[polygon[i] + 1]
        for k in range(s, e):
            a = points[vertices[k]]
            b = points[vertices[k + 1] if k + 1 < e else vertices[s]]
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
        self.edges = _GlobalEdges(mesh)
        self.local = np.full(mesh.n_polygons, -1, dtype=np.int64)
        self.local[polygons] = np.arange(polygons.size)
        self.proj = build_projections(mesh.points, mesh.offsets, mesh.vertices, polygons=polygons)
        this, nxt = _vertex_positions(mesh.offsets, polygons)
        v, w = mesh.vertices[this], mesh.vertices[nxt]
        N = mesh.offsets[polygons + 1] - mesh.offsets[polygons]
        first = np.concatenate([[0], np.cumsum(2 * N + 1)[:-1]])
        self.dof_offsets = np.concatenate([[0], np.cumsum(2 * N + 1)]).astype(np.int64)
        self.dof_values = np.empty((self.dof_offsets[-1], 2))
        self.dof_values[_ranges(first, N)] = values[v]
        self.dof_values[_ranges(first + N, N)] = values[self._midpoint_key(v, w)]
        self.dof_values[first + 2 * N] = values[mesh.n_points + self.edges.n_edges + polygons]

    def _midpoint_key(self, a, b):
        return self.mesh.n_points + self.edges(a, b)

    def at(self, x: npt.NDArray[np.float64], polygon: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        """u (n, 2) at points x (n, 2) of the polygons ``polygon`` (n,): the edge trace on their
        boundary, Π^∇_2 u inside."""
        mesh = self.mesh
        entry, t = _on_edge(x, polygon, mesh.points, mesh.offsets, mesh.vertices, mesh.tol)
        out = np.empty((x.shape[0], 2))
        edge = entry >= 0
        inside = ~edge
        out[inside] = self.projected(x[inside], polygon[inside])
        k = entry[edge]
        start = mesh.vertices[k]
        end = mesh.vertices[np.where(k + 1 < mesh.offsets[polygon[edge] + 1], k + 1, mesh.offsets[polygon[edge]])]
        s = t[edge][:, None]
        out[edge] = (self.values[start] * (1 - s) * (1 - 2 * s) + self.values[self._midpoint_key(start, end)]
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
        From :func:`refine_mesh`.
    values : (n_keys_coarse, 2) float64
        Displacement at every node key of the coarse mesh (module docstring; rows of unused
        points are ignored).

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
    fine_edges = _GlobalEdges(fine)
    n_fine_keys = fine.n_points + fine_edges.n_edges + fine.n_polygons
    out = np.full((n_fine_keys, 2), np.nan)
    out[:coarse.n_points] = values[:coarse.n_points]

    # one polygon listing each new point and each edge; refined parents only change anything
    this, nxt = _vertex_positions(fine.offsets, np.arange(fine.n_polygons))
    a, b = fine.vertices[this], fine.vertices[nxt]
    owner = parent[fine.polygon_of_entry()]
    new_point, first = np.unique(a, return_index=True)
    keep = new_point >= coarse.n_points
    out[new_point[keep]] = old.at(fine.points[new_point[keep]], owner[first[keep]])
    edge, first = np.unique(fine_edges(a, b), return_index=True)
    out[fine.n_points + edge] = old.at(0.5 * (fine.points[a[first]] + fine.points[b[first]]), owner[first])

    # means: unrefined polygons keep theirs, children integrate Π^∇_2 u of their parent
    mean_key = fine.n_points + fine_edges.n_edges + np.arange(fine.n_polygons)
    child = refinement.selected[parent]
    n_coarse_edges = old.edges.n_edges
    out[mean_key[~child]] = values[coarse.n_points + n_coarse_edges + parent[~child]]
    children = np.flatnonzero(child)
    q_offsets, x_q, w_q = polygon_quadrature(fine.nodes, fine.quadrature_triangles, fine.quadrature_triangle_offsets,
                                             children, np.full(children.size, 2))
    counts = np.diff(q_offsets)
    u_q = old.projected(x_q, np.repeat(parent[children], counts)) * w_q[:, None]
    out[mean_key[children]] = np.add.reduceat(u_q, q_offsets[:-1], axis=0) / fine.areas[children, None]
    return out
