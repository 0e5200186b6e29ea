"""Polygonal meshes: validation, hanging nodes, topology (sides, edges), sub-triangulation, DOLFINx mesh.

A :class:`PolygonMesh` holds points, counter-clockwise polygon vertex lists (CSR) and
one region tag per polygon. Construction validates the mesh and rejects it with a
``ValueError`` naming the polygon and the reason; it accepts

- hanging nodes: a vertex lying on a straight side of a polygon is an ordinary
  vertex of that polygon (it is collinear with its two neighbours);
- T-junctions: a vertex of one polygon lying inside an edge of a neighbour that
  does not list it is inserted into the neighbour's vertex list
  (``insert_hanging_nodes=True``), which glues meshes of different densities.

Tolerance: ``tol = RTOL * d`` with ``d`` the diagonal of the bounding box of the
points used by polygons (``RTOL`` from :mod:`dolfinx_sfvem.mesh.polygon`). Points closer
than ``tol`` coincide, a point within ``tol`` of an edge lies on it, polygons with area
at most ``tol`` times their diameter are degenerate, sub-triangles have heights > ``tol``.

Topology, computed once on first use (a PolygonMesh is not modified after construction):
the *sides* of the polygons (one per vertex entry, to the next vertex counter-clockwise), the
undirected *edges* (a side shared by two polygons is one edge) numbered in the order of
:func:`edge_key`, the polygons on either side of every edge, the boundary edges.

The pairwise checks (coincident points, T-junctions, edge contacts, edge midpoints
inside other polygons) find candidate pairs through a sparse uniform grid (cells of
about the mean edge length, only occupied cells stored) over bounding boxes, compiled
with numba: O(n log n) for meshes with bounded local size variation.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import dolfinx.mesh
import numba
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from dolfinx_sfvem import _compat
from dolfinx_sfvem.mesh.csr import edge_key, next_entries, previous_entries, segment_owner
from dolfinx_sfvem.mesh.refine import select_polygons, split_level
from dolfinx_sfvem.mesh.polygon import (
    FAILED, FAN, RTOL, centroid, diameter, point_location, point_segment_distance, ear_clipping, segment_distance,
    self_intersection, signed_area, sub_triangulation)

# status codes of _orient_and_check
_OK, _REPEATED, _ZERO_AREA, _SELF_INTERSECTION = 0, 1, 2, 3


# --------------------------------------------------------------------------- input conversion
def as_points(points: npt.ArrayLike, dim: int = 2) -> npt.NDArray[np.float64]:
    """``points`` as a C-contiguous (n, dim) float64 array; ValueError naming the malformed input
    or the first point that is not finite."""
    try:
        x = np.asarray(points)
    except (TypeError, ValueError) as err:
        raise ValueError(f"points must be an (n, {dim}) array of floats: {err}") from None
    if x.dtype.kind not in "iuf":
        raise ValueError(f"points must be an (n, {dim}) array of floats, got dtype {x.dtype}")
    x = x.astype(np.float64)
    if x.ndim != 2 or x.shape[1] != dim:
        raise ValueError(f"points must have shape (n, {dim}), got {x.shape}")
    finite = np.isfinite(x).all(axis=1)
    if not finite.all():
        k = int(np.argmin(finite))
        raise ValueError(f"point {k} is not finite: {x[k]}")
    return np.ascontiguousarray(x)


def _as_csr(polygons: Iterable[npt.ArrayLike], n_points: int) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Vertex lists -> CSR (offsets, vertices), checking shapes, types and index range."""
    if isinstance(polygons, (str, bytes)):
        raise ValueError("polygons must be a sequence of vertex-index sequences")
    try:
        seq = list(polygons)
    except TypeError:
        raise ValueError("polygons must be a sequence of vertex-index sequences") from None
    if not seq:
        raise ValueError("the mesh has no polygons")
    arrays = []
    for i, p in enumerate(seq):
        try:
            a = np.asarray(p)
        except (TypeError, ValueError) as err:
            raise ValueError(f"polygon {i}: not a sequence of vertex indices ({err})") from None
        if a.ndim != 1:
            raise ValueError(f"polygon {i}: vertex indices must form a flat sequence, got shape {a.shape}")
        if a.size < 3:
            raise ValueError(f"polygon {i}: {a.size} vertices, at least 3 needed")
        if a.dtype.kind not in "iu":
            raise ValueError(f"polygon {i}: vertex indices must be integers, got dtype {a.dtype}")
        if a.dtype.kind == "u" and a.max() >= n_points:
            raise ValueError(f"polygon {i}: vertex index {a.max()} out of range [0, {n_points})")
        arrays.append(a.astype(np.int64, copy=False))
    offsets = np.zeros(len(arrays) + 1, dtype=np.int64)
    np.cumsum([a.size for a in arrays], out=offsets[1:])
    vertices = np.concatenate(arrays)
    bad = np.flatnonzero((vertices < 0) | (vertices >= n_points))
    if bad.size:
        k = bad[0]
        raise ValueError(f"polygon {np.searchsorted(offsets, k, 'right') - 1}: vertex index {vertices[k]} "
                         f"out of range [0, {n_points})")
    return offsets, vertices


def _as_tags(tags: npt.ArrayLike | None, n_polygons: int) -> npt.NDArray[np.int32]:
    if tags is None:
        return np.zeros(n_polygons, dtype=np.int32)
    try:
        t = np.asarray(tags)
    except (TypeError, ValueError) as err:
        raise ValueError(f"tags must be a sequence of integers: {err}") from None
    if t.shape != (n_polygons,):
        raise ValueError(f"tags must have one entry per polygon, shape ({n_polygons},), got {t.shape}")
    if t.dtype.kind not in "iu":
        raise ValueError(f"tags must be integers, got dtype {t.dtype}")
    info = np.iinfo(np.int32)
    bad = np.flatnonzero((t < info.min) | (t > info.max))
    if bad.size:
        raise ValueError(f"polygon {bad[0]}: tag {t[bad[0]]} does not fit in int32")
    return t.astype(np.int32)


# --------------------------------------------------------------------------- per-polygon kernels
@numba.njit(cache=True)
def _orient_and_check(points, offsets, vertices, tol):
    """Orient every polygon counter-clockwise (in place, keeping its first vertex) and
    check it. Returns (code, polygon, i, j) for the first failure, or (_OK, -1, 0, 0):
    _REPEATED (vertex index i), _ZERO_AREA, _SELF_INTERSECTION (local edges i, j)."""
    mark = np.full(points.shape[0], -1, dtype=np.int64)
    for p in range(offsets.size - 1):
        s, e = offsets[p], offsets[p + 1]
        for k in range(s, e):
            if mark[vertices[k]] == p:
                return _REPEATED, p, vertices[k], 0
            mark[vertices[k]] = p
        xy = points[vertices[s:e]]
        area = signed_area(xy)
        if area < 0.0:
            vertices[s + 1:e] = vertices[s + 1:e][::-1].copy()
            xy = points[vertices[s:e]]
            area = -area
        if area <= tol * diameter(xy):
            return _ZERO_AREA, p, 0, 0
        i, j = self_intersection(xy, tol)
        if i >= 0:
            return _SELF_INTERSECTION, p, i, j
    return _OK, -1, 0, 0


@numba.njit(cache=True)
def _measures(points, offsets, vertices):
    """Areas (n_polygons,) and centroids (n_polygons, 2)."""
    n = offsets.size - 1
    areas = np.empty(n)
    centroids = np.empty((n, 2))
    for p in range(n):
        xy = points[vertices[offsets[p]:offsets[p + 1]]]
        areas[p] = signed_area(xy)
        centroids[p] = centroid(xy)
    return areas, centroids


@numba.njit(cache=True)
def _collinear_vertices(points, offsets, vertices, tol):
    """Mask over CSR entries: the vertex lies within ``tol`` of the segment joining its neighbours."""
    mask = np.zeros(vertices.size, dtype=np.bool_)
    for p in range(offsets.size - 1):
        s, e = offsets[p], offsets[p + 1]
        for k in range(s, e):
            prev = vertices[k - 1] if k > s else vertices[e - 1]
            nxt = vertices[k + 1] if k + 1 < e else vertices[s]
            mask[k] = point_segment_distance(points[vertices[k]], points[prev], points[nxt]) <= tol
    return mask


@numba.njit(cache=True)
def _triangulate_all(points, offsets, vertices, tol):
    """Sub-triangulate every polygon (see :func:`~dolfinx_sfvem.mesh.polygon.sub_triangulation`).

    Returns (failed polygon or -1, extra (n_extra, 2), triangles (n_t, 3) into
    vstack(points, extra), triangle offsets (n_polygons + 1,), interior (n_polygons, 2)).
    """
    n_poly = offsets.size - 1
    n_pts = points.shape[0]
    triangles = np.empty((vertices.size, 3), dtype=np.int64)
    tri_offsets = np.zeros(n_poly + 1, dtype=np.int64)
    extra = np.empty((n_poly, 2))
    interior = np.empty((n_poly, 2), dtype=np.int64)
    n_extra = 0
    for p in range(n_poly):
        verts = vertices[offsets[p]:offsets[p + 1]]
        n = verts.size
        status, c, tri, a, b = sub_triangulation(points[verts], tol)
        if status == FAILED:
            return p, extra[:0], triangles[:0], tri_offsets, interior
        centre = n_pts + n_extra
        t0 = tri_offsets[p]
        for t in range(tri.shape[0]):
            for k in range(3):
                triangles[t0 + t, k] = verts[tri[t, k]] if tri[t, k] < n else centre
        tri_offsets[p + 1] = t0 + tri.shape[0]
        if status == FAN:
            extra[n_extra] = c
            n_extra += 1
            interior[p, 0], interior[p, 1] = centre, centre
        else:
            interior[p, 0], interior[p, 1] = verts[a], verts[b]
    return -1, extra[:n_extra].copy(), triangles[:tri_offsets[-1]].copy(), tri_offsets, interior


@numba.njit(cache=True)
def _quadrature_triangulate_all(points, offsets, vertices, tol, triangles, tri_offsets):
    """N − 2 triangles per polygon by ear clipping (into ``points``); where ear clipping
    fails, the polygon's sub-triangles ``triangles[tri_offsets[p]:tri_offsets[p + 1]]``
    (indices into ``vstack(points, extra)``) are used. Returns (triangles, offsets)."""
    n_poly = offsets.size - 1
    out = np.empty((vertices.size + triangles.shape[0], 3), dtype=np.int64)
    out_offsets = np.zeros(n_poly + 1, dtype=np.int64)
    for p in range(n_poly):
        verts = vertices[offsets[p]:offsets[p + 1]]
        ok, tri, _ = ear_clipping(points[verts], tol)
        t0 = out_offsets[p]
        if ok:
            for t in range(tri.shape[0]):
                for k in range(3):
                    out[t0 + t, k] = verts[tri[t, k]]
            out_offsets[p + 1] = t0 + tri.shape[0]
        else:
            n_t = tri_offsets[p + 1] - tri_offsets[p]
            out[t0:t0 + n_t] = triangles[tri_offsets[p]:tri_offsets[p + 1]]
            out_offsets[p + 1] = t0 + n_t
    return out[:out_offsets[-1]].copy(), out_offsets


# --------------------------------------------------------------------------- spatial hash
@numba.njit(cache=True)
def _cell(x, origin, h):
    return np.int64(np.floor((x - origin) / h))


@numba.njit(cache=True)
def _cell_entries(boxes, origin, h):
    """One entry (i, j, k) per box k (m, 4) [xmin, ymin, xmax, ymax] and grid cell (i, j) of size
    ``h`` it overlaps: three (n_entries,) arrays."""
    n = 0
    for k in range(boxes.shape[0]):
        n += ((_cell(boxes[k, 2], origin[0], h) - _cell(boxes[k, 0], origin[0], h) + 1)
              * (_cell(boxes[k, 3], origin[1], h) - _cell(boxes[k, 1], origin[1], h) + 1))
    ci = np.empty(n, dtype=np.int64)
    cj = np.empty(n, dtype=np.int64)
    item = np.empty(n, dtype=np.int64)
    n = 0
    for k in range(boxes.shape[0]):
        for i in range(_cell(boxes[k, 0], origin[0], h), _cell(boxes[k, 2], origin[0], h) + 1):
            for j in range(_cell(boxes[k, 1], origin[1], h), _cell(boxes[k, 3], origin[1], h) + 1):
                ci[n], cj[n], item[n] = i, j, k
                n += 1
    return ci, cj, item


@numba.njit(cache=True)
def _join_cells(ai, aj, a_item, bi, bj, b_item, boxes_a, boxes_b, same, origin, h):
    """Pairs (a, b) (n_pairs, 2) of overlapping boxes from two entry lists sorted by cell.

    Each pair is taken once, in the cell holding the lower-left corner of the boxes'
    intersection; with ``same`` (both lists the same) only a < b."""
    pairs = np.empty((0, 2), dtype=np.int64)
    for sweep in range(2):
        count = 0
        p, q = 0, 0
        while p < ai.size and q < bi.size:
            if ai[p] < bi[q] or (ai[p] == bi[q] and aj[p] < bj[q]):
                p += 1
            elif ai[p] > bi[q] or aj[p] > bj[q]:
                q += 1
            else:
                p_end, q_end = p, q
                while p_end < ai.size and ai[p_end] == ai[p] and aj[p_end] == aj[p]:
                    p_end += 1
                while q_end < bi.size and bi[q_end] == bi[q] and bj[q_end] == bj[q]:
                    q_end += 1
                for x in range(p, p_end):
                    a = a_item[x]
                    for y in range(q, q_end):
                        b = b_item[y]
                        if same and b <= a:
                            continue
                        x0 = max(boxes_a[a, 0], boxes_b[b, 0])
                        y0 = max(boxes_a[a, 1], boxes_b[b, 1])
                        if (x0 > min(boxes_a[a, 2], boxes_b[b, 2]) or y0 > min(boxes_a[a, 3], boxes_b[b, 3])
                                or _cell(x0, origin[0], h) != ai[p] or _cell(y0, origin[1], h) != aj[p]):
                            continue
                        if sweep == 1:
                            pairs[count, 0], pairs[count, 1] = a, b
                        count += 1
                p, q = p_end, q_end
        if sweep == 0:
            pairs = np.empty((count, 2), dtype=np.int64)
    return pairs


def _sorted_cell_entries(boxes: npt.NDArray[np.float64], origin: npt.NDArray[np.float64], h: float):
    ci, cj, item = _cell_entries(boxes, origin, h)
    order = np.lexsort((cj, ci))
    return ci[order], cj[order], item[order]


def _overlapping_pairs(boxes_a: npt.NDArray[np.float64], boxes_b: npt.NDArray[np.float64] | None,
                       h: float) -> npt.NDArray[np.int64]:
    """Pairs (a, b) (n_pairs, 2) of overlapping boxes (m_a, 4) x (m_b, 4), or a < b within
    ``boxes_a`` if ``boxes_b`` is None, through a sparse uniform grid of cell size ``h``
    (doubled until the boxes cover at most ~8 cells each on average)."""
    same = boxes_b is None
    boxes_b = boxes_a if same else boxes_b
    both = np.vstack([boxes_a, boxes_b])
    origin = both[:, :2].min(axis=0)
    while True:
        cells = np.floor((both - np.tile(origin, 2)) / h)
        if ((cells[:, 2] - cells[:, 0] + 1) * (cells[:, 3] - cells[:, 1] + 1)).sum() <= 8 * both.shape[0] + 64:
            break
        h *= 2.0
    a = _sorted_cell_entries(boxes_a, origin, h)
    b = a if same else _sorted_cell_entries(boxes_b, origin, h)
    return _join_cells(*a, *b, boxes_a, boxes_b, same, origin, h)


def _point_boxes(x: npt.NDArray[np.float64], pad: float) -> npt.NDArray[np.float64]:
    return np.hstack([x - pad, x + pad])


# --------------------------------------------------------------------------- pairwise tests
@numba.njit(cache=True)
def _close_points(points, pairs, tol):
    """Mask over point pairs: closer than ``tol``."""
    out = np.empty(pairs.shape[0], dtype=np.bool_)
    for k in range(pairs.shape[0]):
        a, b = pairs[k]
        out[k] = np.hypot(points[a, 0] - points[b, 0], points[a, 1] - points[b, 1]) <= tol
    return out


@numba.njit(cache=True)
def _points_on_edges(points, pts, e0, e1, pairs, tol):
    """For (point pts[i], edge j) pairs: mask 'the point lies within ``tol`` of the edge and is
    not one of its end points', and the position t in [0, 1] of its projection on the edge."""
    on = np.zeros(pairs.shape[0], dtype=np.bool_)
    t = np.zeros(pairs.shape[0])
    for k in range(pairs.shape[0]):
        p, e = pts[pairs[k, 0]], pairs[k, 1]
        a, b = e0[e], e1[e]
        if p != a and p != b and point_segment_distance(points[p], points[a], points[b]) <= tol:
            on[k] = True
            dx, dy = points[b, 0] - points[a, 0], points[b, 1] - points[a, 1]
            t[k] = ((points[p, 0] - points[a, 0]) * dx + (points[p, 1] - points[a, 1]) * dy) / (dx * dx + dy * dy)
    return on, t


@numba.njit(cache=True)
def _edge_contacts(points, e0, e1, edge_polygon, pairs, tol):
    """Mask over edge pairs of different polygons that cross or touch other than at a shared
    end point (edges with both end points shared are left to the directed-edge check)."""
    out = np.zeros(pairs.shape[0], dtype=np.bool_)
    for k in range(pairs.shape[0]):
        i, j = pairs[k]
        if edge_polygon[i] == edge_polygon[j]:
            continue
        a, b, c, d = e0[i], e1[i], e0[j], e1[j]
        shared = int(a == c) + int(a == d) + int(b == c) + int(b == d)
        if shared == 0:
            out[k] = segment_distance(points[a], points[b], points[c], points[d]) <= tol
        elif shared == 1:
            x = b if (a == c or a == d) else a  # the unshared end of edge i
            y = d if (c == a or c == b) else c  # the unshared end of edge j
            out[k] = (point_segment_distance(points[x], points[c], points[d]) <= tol
                      or point_segment_distance(points[y], points[a], points[b]) <= tol)
    return out


@numba.njit(cache=True)
def _midpoints_inside(points, offsets, vertices, e0, e1, edge_polygon, pairs, tol):
    """Mask over (edge, polygon) pairs: the edge midpoint lies strictly inside that other polygon."""
    out = np.zeros(pairs.shape[0], dtype=np.bool_)
    for k in range(pairs.shape[0]):
        e, q = pairs[k]
        if edge_polygon[e] != q:
            mid = 0.5 * (points[e0[e]] + points[e1[e]])
            out[k] = point_location(mid, points[vertices[offsets[q]:offsets[q + 1]]], tol) == 1
    return out


@numba.njit(cache=True)
def _locate(x, points, offsets, vertices, tol):
    """Index of a polygon containing each point of x (n, 2) (on its boundary within tol counts),
    -1 for points outside the mesh."""
    n_poly = offsets.size - 1
    lo = np.empty((n_poly, 2))
    hi = np.empty((n_poly, 2))
    for k in range(n_poly):
        xy = points[vertices[offsets[k]:offsets[k + 1]]]
        for c in range(2):
            lo[k, c] = xy[:, c].min() - tol
            hi[k, c] = xy[:, c].max() + tol
    found = np.full(x.shape[0], -1, dtype=np.int64)
    for i in range(x.shape[0]):
        for k in range(n_poly):
            if lo[k, 0] <= x[i, 0] <= hi[k, 0] and lo[k, 1] <= x[i, 1] <= hi[k, 1]:
                if point_location(x[i], points[vertices[offsets[k]:offsets[k + 1]]], tol) >= 0:
                    found[i] = k
                    break
    return found


def coordinate_bisection(centroids: npt.NDArray[np.float64], n_parts: int) -> npt.NDArray[np.int32]:
    """Recursive coordinate bisection of cell centroids (any dimension).

    Each set is cut across its longest centroid extent so that the two halves hold cell counts
    proportional to their part counts (ties broken by cell index: deterministic).

    Parameters
    ----------
    centroids : (n_cells, dim) float64
    n_parts
        Number of parts (>= 1).

    Returns
    -------
    (n_cells,) int32
        Part of every cell, in [0, n_parts).
    """
    if int(n_parts) != n_parts or n_parts < 1:
        raise ValueError(f"n_parts must be a positive integer, got {n_parts}")
    parts = np.zeros(len(centroids), dtype=np.int32)

    def bisect(ids: npt.NDArray[np.int64], first: int, k: int) -> None:
        if k == 1 or ids.size == 0:
            parts[ids] = first
            return
        c = centroids[ids]
        axis = int(np.argmax(np.ptp(c, axis=0)))
        ids = ids[np.lexsort((ids, c[:, axis]))]
        k_low = k // 2
        n_low = ids.size * k_low // k
        bisect(ids[:n_low], first, k_low)
        bisect(ids[n_low:], first + k_low, k - k_low)

    bisect(np.arange(len(centroids), dtype=np.int64), 0, int(n_parts))
    return parts


class Sides(NamedTuple):
    """The directed sides of the polygons of a :class:`PolygonMesh`, one per entry of its
    vertex array (in that order): side k runs from vertex entry k to the next one of its
    polygon, counter-clockwise. Every array is (offsets[-1],) int64.

    Attributes
    ----------
    start, end
        End points (point indices).
    polygon
        The polygon the side belongs to.
    edge
        Its undirected edge (:meth:`PolygonMesh.edge_index`).
    neighbour
        The polygon on the other side of the edge (the one holding the reverse side), -1 on
        the boundary of the mesh.
    """
    start: npt.NDArray[np.int64]
    end: npt.NDArray[np.int64]
    polygon: npt.NDArray[np.int64]
    edge: npt.NDArray[np.int64]
    neighbour: npt.NDArray[np.int64]


def _first_pair(pi: npt.NDArray[np.int64], pj: npt.NDArray[np.int64]) -> int:
    """Among conflicts between polygons pi[k] and pj[k], the one whose (higher, lower) polygon
    index comes first: it names the first polygon that does not fit with the ones before it."""
    return int(np.lexsort((np.minimum(pi, pj), np.maximum(pi, pj)))[0])


# --------------------------------------------------------------------------- the mesh
class PolygonMesh:
    """A validated 2D polygonal mesh with a quadrature sub-triangulation of every polygon.

    Parameters
    ----------
    points : (n_points, 2) array_like of float
        Point coordinates (finite).
    polygons : sequence of sequences of int
        Vertex indices of every polygon, in either orientation (clockwise ones are reversed,
        keeping the first vertex).
    tags : (n_polygons,) array_like of int, optional
        Region id per polygon (default 0).
    insert_hanging_nodes : bool
        Insert a vertex lying inside a neighbour's edge into the neighbour's vertex list
        (T-junction repair). If False, such a T-junction is an error.

    Attributes
    ----------
    gdim : int
        The dimension of the points: 2.
    points : (n_points, 2) float64
    offsets : (n_polygons + 1,) int64
        Polygon i has vertices ``vertices[offsets[i]:offsets[i+1]]``, counter-clockwise.
    vertices : (offsets[-1],) int64
    tags : (n_polygons,) int32
    region_names : dict[str, int]
        Region tag by name where known (set by :func:`~dolfinx_sfvem.meshes.from_gmsh` from the
        physical groups and by the benchmark generators); empty otherwise.
    boundary_names : dict[str, (m, 2) int64]
        Segments of named boundary curves by name, as point-index pairs (set by
        :func:`~dolfinx_sfvem.meshes.read_gmsh` from the 1D physical groups); boundary conditions and
        loads take them by name (:mod:`~dolfinx_sfvem.mesh.named_boundaries`). Empty otherwise.
    tol : float
        Absolute length tolerance (``RTOL`` times the bounding-box diagonal).
    hanging_nodes : (n_hanging,) int64
        Points collinear with both neighbours in some polygon's vertex list (sorted).
    n_inserted_hanging_nodes : int
        Vertices added to polygons by T-junction repair.
    areas : (n_polygons,) float64
    centroids : (n_polygons, 2) float64
    extra_points : (n_extra, 2) float64
        Fan centres; fan centre j is node ``n_points + j``.
    triangles : (n_triangles, 3) int64
        CCW sub-triangles, indices into :attr:`nodes`.
    triangle_offsets : (n_polygons + 1,) int64
        Polygon i has triangles ``triangles[triangle_offsets[i]:triangle_offsets[i+1]]``.
    interior_node : (n_polygons, 2) int64
        Node indices (a, b) whose midpoint hosts the polygon's interior DOF: a == b == the fan
        centre, or the end points of an interior diagonal of an ear-clipped polygon.
    quadrature_triangles, quadrature_triangle_offsets
        A second triangulation, into :attr:`nodes`, used only for quadrature: N − 2 ear-clipped
        triangles per polygon (the fewest; a Gauss rule of degree d on them integrates
        polynomials of degree d over the polygon exactly, like any triangulation).

    Raises
    ------
    ValueError
        Naming the polygon ("polygon 17: ...") and the reason: fewer than 3 vertices, repeated
        or out-of-range vertex index, zero area, self-intersection, no valid sub-triangulation,
        distinct points at the same location (crack), edges of different polygons crossing or
        overlapping, an edge midpoint inside another polygon, the same directed edge in two
        polygons, an unrepaired T-junction; or naming the malformed argument.
    """

    gdim = 2

    def __init__(self, points: npt.ArrayLike, polygons: Iterable[npt.ArrayLike], tags: npt.ArrayLike | None = None, *,
                 insert_hanging_nodes: bool = True) -> None:
        self.points = as_points(points)
        offsets, vertices = _as_csr(polygons, self.points.shape[0])
        self.tags = _as_tags(tags, offsets.size - 1)
        self.region_names: dict[str, int] = {}
        self.boundary_names: dict[str, npt.NDArray[np.int64]] = {}
        used = self.points[np.unique(vertices)]
        self.tol = RTOL * float(np.hypot(*(used.max(axis=0) - used.min(axis=0))))
        self.offsets, self.vertices = offsets, vertices
        self._check_polygons()
        e0, e1, _ = self._current_sides()
        h = float(np.hypot(*(self.points[e1] - self.points[e0]).T).mean())  # bucket-grid cell size
        self._check_cracks(h)
        self.n_inserted_hanging_nodes = self._repair_t_junctions(insert_hanging_nodes, h)
        self._check_conforming(h)
        self.areas, self.centroids = _measures(self.points, self.offsets, self.vertices)
        collinear = _collinear_vertices(self.points, self.offsets, self.vertices, self.tol)
        self.hanging_nodes = np.unique(self.vertices[collinear])
        failed, self.extra_points, self.triangles, self.triangle_offsets, self.interior_node = \
            _triangulate_all(self.points, self.offsets, self.vertices, self.tol)
        if failed >= 0:
            raise ValueError(f"polygon {failed}: cannot be sub-triangulated (degenerate shape at "
                             f"tolerance {self.tol:.3g})")
        self.quadrature_triangles, self.quadrature_triangle_offsets = _quadrature_triangulate_all(
            self.points, self.offsets, self.vertices, self.tol, self.triangles, self.triangle_offsets)

    # ----------------------------------------------------------------------- validation steps
    def _current_sides(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        """Start point, end point and polygon of every side of the vertex lists as they are during
        validation (not cached: T-junction repair changes them), each (offsets[-1],)."""
        return self.vertices, self.vertices[next_entries(self.offsets)], self.polygon_of_entry()

    def _check_polygons(self) -> None:
        """Orient counter-clockwise; repeated vertices, zero area, self-intersection."""
        code, p, i, j = _orient_and_check(self.points, self.offsets, self.vertices, self.tol)
        if code == _OK:
            return
        verts = self.polygon(p)
        if code == _REPEATED:
            raise ValueError(f"polygon {p}: vertex {i} is repeated")
        if code == _ZERO_AREA:
            raise ValueError(f"polygon {p}: zero area (collinear, coincident or self-overlapping "
                             f"vertices {verts.tolist()})")
        n = verts.size
        if i == j:
            raise ValueError(f"polygon {p}: edge ({verts[i]}, {verts[(i + 1) % n]}) has zero length")
        raise ValueError(f"polygon {p}: self-intersection, edges ({verts[i]}, {verts[(i + 1) % n]}) and "
                         f"({verts[j]}, {verts[(j + 1) % n]}) cross or touch")

    def _first_polygon_of_points(self) -> npt.NDArray[np.int64]:
        """Lowest polygon index using each point (n_polygons for unused points)."""
        first = np.full(self.n_points, self.n_polygons, dtype=np.int64)
        np.minimum.at(first, self.vertices, self.polygon_of_entry())
        return first

    def _check_cracks(self, h: float) -> None:
        """Distinct used points at the same location."""
        used = np.unique(self.vertices)
        pairs = used[_overlapping_pairs(_point_boxes(self.points[used], self.tol), None, h)]
        pairs = pairs[_close_points(self.points, pairs, self.tol)]
        if pairs.size == 0:
            return
        owner = self._first_polygon_of_points()[pairs]
        k = _first_pair(owner[:, 0], owner[:, 1])
        (a, b), (pa, pb) = pairs[k], owner[k]
        if pa < pb:
            a, b, pa, pb = b, a, pb, pa
        raise ValueError(f"polygon {pa}: its vertex {a} and vertex {b} of polygon {pb} are distinct points "
                         f"at the same location (crack); merge them")

    def _repair_t_junctions(self, insert: bool, h: float) -> int:
        """Insert every vertex lying inside another polygon's edge into that polygon, in order
        along the edge (or raise if ``insert`` is False). Returns the number of insertions."""
        e0, e1, edge_polygon = self._current_sides()
        used = np.unique(self.vertices)
        edge_boxes = np.hstack([np.minimum(self.points[e0], self.points[e1]) - self.tol,
                                np.maximum(self.points[e0], self.points[e1]) + self.tol])
        pairs = _overlapping_pairs(_point_boxes(self.points[used], 0.0), edge_boxes, h)
        on, t = _points_on_edges(self.points, used, e0, e1, pairs, self.tol)
        point, edge, t = used[pairs[on, 0]], pairs[on, 1], t[on]
        if point.size == 0:
            return 0
        if not insert:
            k = int(np.lexsort((point, edge_polygon[edge]))[0])
            p, e = point[k], edge[k]
            raise ValueError(f"polygon {edge_polygon[e]}: vertex {p} (of polygon "
                             f"{self._first_polygon_of_points()[p]}) lies inside its edge ({e0[e]}, {e1[e]}) "
                             f"but is not one of its vertices (T-junction); list it or use "
                             f"insert_hanging_nodes=True")
        order = np.lexsort((t, edge))
        self.vertices = np.insert(self.vertices, edge[order] + 1, point[order])
        added = np.bincount(edge_polygon[edge], minlength=self.n_polygons)
        self.offsets = self.offsets + np.concatenate([[0], np.cumsum(added)])
        self._check_polygons()
        return int(point.size)

    def _check_conforming(self, h: float) -> None:
        """No directed edge twice, no edge contacts between polygons, no edge midpoint inside
        another polygon. With simple polygons and no cracks this excludes every overlap: an edge
        that neither crosses nor touches another polygon's boundary lies entirely inside or outside
        it, so its midpoint decides (a vertex inside another polygon implies such an edge)."""
        e0, e1, edge_polygon = self._current_sides()
        key = e0 * self.n_points + e1
        order = np.argsort(key, kind="stable")
        dup = np.flatnonzero(key[order][1:] == key[order][:-1])
        if dup.size:
            i, j = order[dup], order[dup + 1]
            k = _first_pair(edge_polygon[i], edge_polygon[j])
            pi, pj = sorted((edge_polygon[i[k]], edge_polygon[j[k]]))
            raise ValueError(f"polygon {pj}: edge ({e0[i[k]]}, {e1[i[k]]}) is also an edge of polygon {pi} "
                             f"in the same direction (overlapping polygons)")
        lo = np.minimum(self.points[e0], self.points[e1])
        hi = np.maximum(self.points[e0], self.points[e1])
        pairs = _overlapping_pairs(np.hstack([lo - self.tol, hi + self.tol]), None, h)
        pairs = pairs[_edge_contacts(self.points, e0, e1, edge_polygon, pairs, self.tol)]
        if pairs.size:
            i, j = pairs[_first_pair(edge_polygon[pairs[:, 0]], edge_polygon[pairs[:, 1]])]
            if edge_polygon[i] < edge_polygon[j]:
                i, j = j, i
            raise ValueError(f"polygon {edge_polygon[i]}: its edge ({e0[i]}, {e1[i]}) crosses or touches edge "
                             f"({e0[j]}, {e1[j]}) of polygon {edge_polygon[j]} (non-conforming mesh)")
        poly_boxes = np.hstack([np.minimum.reduceat(lo, self.offsets[:-1]),
                                np.maximum.reduceat(hi, self.offsets[:-1])])
        mid = 0.5 * (self.points[e0] + self.points[e1])
        pairs = _overlapping_pairs(_point_boxes(mid, 0.0), poly_boxes, h)
        pairs = pairs[_midpoints_inside(self.points, self.offsets, self.vertices, e0, e1, edge_polygon,
                                        pairs, self.tol)]
        if pairs.size:
            e, q = pairs[_first_pair(edge_polygon[pairs[:, 0]], pairs[:, 1])]
            p = edge_polygon[e]
            what = f"the midpoint of its edge ({e0[e]}, {e1[e]}) lies inside polygon {q}"
            if q > p:
                p, what = q, f"it contains the midpoint of edge ({e0[e]}, {e1[e]}) of polygon {p}"
            raise ValueError(f"polygon {p}: {what} (overlapping polygons)")

    # ----------------------------------------------------------------------- accessors
    @property
    def n_points(self) -> int:
        return self.points.shape[0]

    @property
    def n_polygons(self) -> int:
        return self.offsets.size - 1

    @property
    def nodes(self) -> npt.NDArray[np.float64]:
        """Sub-triangulation nodes ``vstack(points, extra_points)``, (n_points + n_extra, 2)."""
        return np.vstack([self.points, self.extra_points])

    @property
    def triangle_polygon(self) -> npt.NDArray[np.int64]:
        """Polygon of every sub-triangle, (n_triangles,)."""
        return segment_owner(self.triangle_offsets)

    def polygon_of_entry(self) -> npt.NDArray[np.int64]:
        """Polygon of every entry of :attr:`vertices`, (offsets[-1],)."""
        return segment_owner(self.offsets)

    def polygon(self, i: int) -> npt.NDArray[np.int64]:
        """Vertex indices (N,) of polygon ``i``, counter-clockwise."""
        return self.vertices[self.offsets[i]:self.offsets[i + 1]]

    def polygon_coordinates(self, i: int) -> npt.NDArray[np.float64]:
        """Vertex coordinates (N, 2) of polygon ``i``."""
        return self.points[self.polygon(i)]

    # ----------------------------------------------------------------------- topology
    # A PolygonMesh is not changed after construction: the members below are computed once.
    @cached_property
    def used_points(self) -> npt.NDArray[np.int64]:
        """Indices (k,) of the points that are vertices of some polygon, sorted (hanging nodes included)."""
        return np.unique(self.vertices)

    @cached_property
    def next_entry(self) -> npt.NDArray[np.int64]:
        """Position in :attr:`vertices` (offsets[-1],) of the next vertex, counter-clockwise, of the
        same polygon for every entry (:func:`next_entries`)."""
        return next_entries(self.offsets)

    @cached_property
    def previous_entry(self) -> npt.NDArray[np.int64]:
        """Position in :attr:`vertices` (offsets[-1],) of the previous vertex (clockwise) of the same
        polygon for every entry (:func:`previous_entries`)."""
        return previous_entries(self.offsets)

    @cached_property
    def _edge_numbering(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        """Sorted :func:`edge_key` (n_edges,) of the distinct undirected edges (the global edge
        numbering) and the edge (offsets[-1],) of every side."""
        keys, side_edge = np.unique(edge_key(self.vertices, self.vertices[self.next_entry], self.n_points),
                                    return_inverse=True)
        return keys, side_edge.reshape(-1).astype(np.int64)

    @property
    def n_edges(self) -> int:
        """Number of distinct undirected edges (a side shared by two polygons is one edge)."""
        return self._edge_numbering[0].size

    def edge_index(self, a: npt.ArrayLike, b: npt.ArrayLike) -> npt.NDArray[np.int64]:
        """Global index (n,) in [0, n_edges) of the edges between points ``a`` and ``b`` (n,), in
        either direction. Edges are numbered in the order of their :func:`edge_key` (lower end
        point, then higher).

        Raises
        ------
        ValueError
            If some pair is not an edge of a polygon (naming the first).
        """
        a, b = np.asarray(a, dtype=np.int64), np.asarray(b, dtype=np.int64)
        keys = self._edge_numbering[0]
        key = edge_key(a, b, self.n_points)
        index = np.searchsorted(keys, key)
        missing = np.flatnonzero(keys[np.minimum(index, keys.size - 1)] != key)
        if missing.size:
            k = missing[0]
            raise ValueError(f"points ({a.flat[k]}, {b.flat[k]}) are not the end points of a polygon edge")
        return index

    @cached_property
    def edge_points(self) -> npt.NDArray[np.int64]:
        """End points (n_edges, 2) of every edge, the lower point index first."""
        return np.stack(np.divmod(self._edge_numbering[0], self.n_points), axis=1)

    @cached_property
    def edge_polygons(self) -> npt.NDArray[np.int64]:
        """The polygons of every edge (n_edges, 2): column 0 the polygon whose side runs from the
        lower to the higher point index, column 1 the one whose side runs back; -1 where there is
        none (a boundary edge has one polygon; validation rejects the same directed side twice)."""
        start, end = self.vertices, self.vertices[self.next_entry]
        out = np.full((self.n_edges, 2), -1, dtype=np.int64)
        out[self._edge_numbering[1], (start > end).astype(np.int64)] = self.polygon_of_entry()
        return out

    @cached_property
    def boundary_edges(self) -> npt.NDArray[np.int64]:
        """Indices (k,) of the edges of only one polygon, sorted: the boundary of the mesh (outer
        boundary and holes)."""
        return np.flatnonzero((self.edge_polygons < 0).any(axis=1))

    @cached_property
    def sides(self) -> Sides:
        """The directed sides of the polygons (:class:`Sides`): end points, polygon, edge and the
        polygon across, one per entry of :attr:`vertices`."""
        polygon, edge = self.polygon_of_entry(), self._edge_numbering[1]
        across = self.edge_polygons[edge]
        neighbour = np.where(across[:, 0] == polygon, across[:, 1], across[:, 0])
        return Sides(self.vertices, self.vertices[self.next_entry], polygon, edge, neighbour)

    def locate(self, x: npt.ArrayLike) -> npt.NDArray[np.int64]:
        """Index (n,) of a polygon containing each point of ``x`` (n, 2) (a point on a shared edge
        belongs to one of its polygons), -1 for points outside the mesh."""
        x = np.ascontiguousarray(np.asarray(x, dtype=np.float64).reshape(-1, 2))
        return _locate(x, self.points, self.offsets, self.vertices, self.tol)

    def boundary_points(self, region: int, other: int | None = None) -> npt.NDArray[np.float64]:
        """Reference coordinates (k, 2) of the vertices and edge midpoints on the boundary of
        ``region`` that it shares with region ``other`` (None: the mesh's outer boundary): the
        nodes of the degree-2 edge traces there."""
        sides = self.sides
        across = sides.neighbour >= 0
        if other is None:
            partner = ~across
        else:
            partner = across & (self.tags[sides.neighbour] == other)
        partner &= self.tags[sides.polygon] == region
        a, b = sides.start[partner], sides.end[partner]
        return np.unique(np.concatenate([self.points[a], self.points[b], 0.5 * (self.points[a] + self.points[b])]),
                         axis=0)

    def summary(self) -> str:
        """Human-readable counts: polygons by vertex number, triangulation kinds, hanging nodes, regions."""
        n_vertices, n_by_size = np.unique(np.diff(self.offsets), return_counts=True)
        regions, n_by_region = np.unique(self.tags, return_counts=True)
        n_fans = self.extra_points.shape[0]
        lines = [
            f"PolygonMesh: {self.n_polygons} polygons, {self.n_points} points, "
            f"{self.triangles.shape[0]} sub-triangles ({n_fans} fans, {self.n_polygons - n_fans} ear-clipped)",
            "  polygons by vertex number: " + ", ".join(f"{v}: {c}" for v, c in zip(n_vertices, n_by_size)),
            f"  hanging nodes: {self.hanging_nodes.size} ({self.n_inserted_hanging_nodes} inserted at T-junctions)",
            "  regions: " + ", ".join(f"{r}: {c} polygons" for r, c in zip(regions, n_by_region)),
        ]
        return "\n".join(lines)

    def refine(self, where: Callable[[np.ndarray], np.ndarray] | npt.ArrayLike | None = None, levels: int = 1, *,
               tags: Iterable[int | str] | None = None, max_l: int = 6) -> Refinement:
        """Split the selected polygons ``levels`` times into quadrilaterals (the pieces of
        :mod:`~dolfinx_sfvem.mesh.refine`); neighbours that are not refined gain hanging nodes.

        Parameters
        ----------
        where
            A marker ``f(x) -> bool (n,)`` of the polygon centroids ``x`` (2, n), a boolean mask
            (n_polygons,) or polygon indices (:func:`~dolfinx_sfvem.mesh.refine.select_polygons`).
        levels
            Number of splits (>= 1); level k + 1 splits the children of level k, so a selected
            polygon ends up as about (number of vertices) x 4^(levels - 1) polygons.
        tags
            Region tags or names (combined with ``where`` by "and").
        max_l
            A neighbour whose new hanging nodes would need a projection order l > ``max_l`` (the
            rank check of docs/method.md §3; many hanging nodes on one side) is split too, at that
            level, until no polygon needs more (closure); an integer in [3, 10].

        Returns
        -------
        Refinement
            ``.mesh`` the refined mesh (region tags and names kept), ``.parent`` the polygon of
            this mesh holding each new one.

        Raises
        ------
        ValueError
            For ``levels`` or ``max_l`` out of range and for a selection that
            :func:`~dolfinx_sfvem.mesh.refine.select_polygons` refuses.
        """
        if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 1:
            raise ValueError(f"refine: levels must be an integer >= 1, got {levels!r}")
        if isinstance(max_l, bool) or not isinstance(max_l, (int, np.integer)) or not 3 <= max_l <= 10:
            raise ValueError(f"refine: max_l must be an integer in [3, 10], got {max_l!r}")
        chosen = select_polygons(self, where, tags)
        current, ancestor = self, np.arange(self.n_polygons, dtype=np.int64)
        for _ in range(int(levels)):
            points, offsets, vertices, parent, is_child = split_level(current, chosen, int(max_l))
            refined = PolygonMesh(points, np.split(vertices, offsets[1:-1]), current.tags[parent],
                                  insert_hanging_nodes=False)
            refined.region_names = dict(self.region_names)
            refined.boundary_names = dict(self.boundary_names)    # the same points, the same segments
            current, ancestor, chosen = refined, ancestor[parent], is_child
        split = np.bincount(ancestor, minlength=self.n_polygons) > 1
        return Refinement(self, current, ancestor, split, int(levels))

    # ----------------------------------------------------------------------- distribution
    def partition(self, n_parts: int) -> npt.NDArray[np.int32]:
        """Part (n_polygons,) int32 in [0, n_parts) of every polygon: :func:`coordinate_bisection`
        of the polygon centroids."""
        return coordinate_bisection(self.centroids, n_parts)

    def to_dolfinx(self, comm: MPI.Comm) -> tuple[dolfinx.mesh.Mesh, npt.NDArray[np.int64]]:
        """The DOLFINx triangle mesh of the sub-triangles, each polygon's cells on one rank.

        Collective. Polygons are distributed by :meth:`partition` (``comm.size`` parts); nodes are
        :attr:`nodes` (input index = node index).

        Returns
        -------
        mesh : dolfinx.mesh.Mesh
        cell_polygon : (n_local_cells,) int64
            Global polygon index of every local cell: the owned cells first
            (``mesh.topology.index_map(2).size_local`` of them), then, in parallel, one
            layer of ghost cells of polygons owned by neighbouring ranks.
        """
        triangle_polygon = self.triangle_polygon
        if comm.rank == 0:
            cells, x = self.triangles, self.nodes
            destinations = self.partition(comm.size)[triangle_polygon]
        else:
            cells, x = np.empty((0, 3), dtype=np.int64), np.empty((0, 2))
            destinations = np.empty(0, dtype=np.int32)
        mesh = _compat.create_triangle_mesh(comm, cells, x, destinations)
        return mesh, triangle_polygon[_compat.original_cell_index(mesh)]


# --------------------------------------------------------------------------- refinement record
@dataclass(frozen=True)
class Refinement:
    """A refined mesh and how it derives from the mesh it was cut from (made by
    :meth:`PolygonMesh.refine`).

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
        the projection order bounded (:meth:`PolygonMesh.refine`); the others at
        most gained hanging nodes.
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
