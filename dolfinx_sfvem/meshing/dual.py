"""Dual polygons of a triangle mesh: one polygon per triangle vertex, made of the triangles'
centroids and edge midpoints around it (split at region interfaces and boundaries)."""
from __future__ import annotations


import numpy as np
import numpy.typing as npt

from dolfinx_sfvem.mesh.csr import edge_key
from dolfinx_sfvem.meshing.polygon_sets import PolygonSet, compact_points, length_tolerance, split_csr


def _checked_triangles(points: npt.ArrayLike, triangles: npt.ArrayLike,
                       tags: npt.ArrayLike | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points (n,2), counter-clockwise triangles (m,3) and tags (m,) of a triangle mesh.

    Clockwise triangles are reordered; wrong shapes, out-of-range indices and triangles
    with a height below :func:`length_tolerance` are errors naming the culprit.
    """
    points = np.asarray(points, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64)
    tags = np.zeros(len(triangles), dtype=np.int32) if tags is None else np.asarray(tags)
    if points.ndim != 2 or points.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {points.shape}")
    if triangles.ndim != 2 or triangles.shape[1] != 3 or len(triangles) == 0:
        raise ValueError(f"triangles must have shape (m, 3) with m > 0, got {triangles.shape}")
    if tags.shape != (len(triangles),):
        raise ValueError(f"triangle_tags must have shape ({len(triangles)},), got {tags.shape}")
    bad = np.flatnonzero(((triangles < 0) | (triangles >= len(points))).any(axis=1))
    if bad.size:
        raise ValueError(f"triangle {bad[0]}: vertex index out of range [0, {len(points)})")
    a, b, c = (points[triangles[:, j]] for j in range(3))
    twice_area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    longest = np.max([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
                      np.linalg.norm(a - c, axis=1)], axis=0)
    degenerate = np.flatnonzero(np.abs(twice_area) <= length_tolerance(points) * longest)
    if degenerate.size:
        raise ValueError(f"triangles {degenerate[:10].tolist()} have zero area")
    ccw = triangles.copy()
    cw = twice_area < 0
    ccw[cw, 1], ccw[cw, 2] = triangles[cw, 2], triangles[cw, 1]
    return points, ccw, tags


def _corner_successors(n_points: int, region: np.ndarray, v: np.ndarray, frm: np.ndarray,
                       to: np.ndarray) -> np.ndarray:
    """Next corner counter-clockwise around the same vertex within the same region.

    Corner ``k`` of a counter-clockwise triangle spans the angle at vertex ``v[k]`` from the
    edge towards ``frm[k]`` to the edge towards ``to[k]``; its successor is the corner at
    ``v[k]`` of the same region whose ``frm`` is ``to[k]``, or -1 when that edge is on the
    region's boundary (outer boundary or interface).
    """
    n_regions = int(region.max()) + 1 if region.size else 1
    if n_regions * n_points * n_points >= 2 ** 62:
        raise ValueError("triangle mesh too large for the corner lookup")
    keys = (region * n_points + v) * n_points + frm
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    clash = np.flatnonzero(sorted_keys[1:] == sorted_keys[:-1])
    if clash.size:
        k = order[clash[0]]
        raise ValueError(f"edge ({v[k]}, {frm[k]}) is shared by two triangles of the same orientation "
                         "and region: overlapping or non-manifold triangles")
    wanted = (region * n_points + v) * n_points + to
    pos = np.minimum(np.searchsorted(sorted_keys, wanted), keys.size - 1)
    return np.where(sorted_keys[pos] == wanted, order[pos], -1)


def _walk(successor: np.ndarray, heads: np.ndarray, chain: np.ndarray, rank: np.ndarray,
          first_chain: int) -> None:
    """Number the corners reachable from ``heads`` (chain id, position) in place.

    All chains advance together, one vectorised step per position; a walk stops at the
    end of an open fan or when it comes back to an already numbered corner (a cycle).
    """
    current, ids, step = heads, np.arange(first_chain, first_chain + heads.size), 0
    while current.size:
        chain[current], rank[current] = ids, step
        nxt = successor[current]
        going = nxt >= 0
        going[going] = chain[nxt[going]] < 0
        current, ids, step = nxt[going], ids[going], step + 1


def _fans(successor: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split corners into fans around their vertex.

    Returns
    -------
    chain : (K,) int64
        Fan of each corner; open fans (bounded by two boundary edges) come first.
    rank : (K,) int64
        Position of each corner in its fan, counter-clockwise.
    n_open : int
        Number of open fans; the others are closed cycles around interior vertices.
    """
    k = successor.size
    chain, rank = np.full(k, -1, dtype=np.int64), np.zeros(k, dtype=np.int64)
    has_predecessor = np.zeros(k, dtype=bool)
    has_predecessor[successor[successor >= 0]] = True
    open_heads = np.flatnonzero(~has_predecessor)
    _walk(successor, open_heads, chain, rank, 0)
    in_cycle = np.flatnonzero(chain < 0)
    label = np.arange(k)
    while True:  # smallest corner index of each cycle, one step around the cycle per pass
        updated = np.minimum(label[in_cycle], label[successor[in_cycle]])
        if np.array_equal(updated, label[in_cycle]):
            break
        label[in_cycle] = updated
    cycle_heads = in_cycle[label[in_cycle] == in_cycle]
    _walk(successor, cycle_heads, chain, rank, open_heads.size)
    return chain, rank, open_heads.size


def _fan_ends(chain: np.ndarray, rank: np.ndarray, successor: np.ndarray,
              n_open: int) -> tuple[np.ndarray, np.ndarray]:
    """First and last corner (n_open,) of every open fan, ordered by fan."""
    heads = np.flatnonzero((rank == 0) & (chain < n_open))
    tails = np.flatnonzero(successor < 0)
    return heads[np.argsort(chain[heads])], tails[np.argsort(chain[tails])]


def _fan_polygons(chain: np.ndarray, rank: np.ndarray, n_open: int, corner_point: np.ndarray,
                  open_vertex: np.ndarray, first_mid: np.ndarray,
                  last_mid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CSR polygons (offsets, point ids), one per fan, counter-clockwise.

    A closed fan is the points of its corners in fan order; an open fan is
    ``open_vertex, first_mid, corner points..., last_mid`` (all (n_open,) per fan).
    """
    n_fans = int(chain.max()) + 1
    fan_size = np.bincount(chain, minlength=n_fans)
    open_ids = np.arange(n_open)
    fan = np.concatenate([chain, open_ids, open_ids, open_ids])
    position = np.concatenate([rank + np.where(chain < n_open, 2, 0), np.zeros(n_open, np.int64),
                               np.ones(n_open, np.int64), fan_size[:n_open] + 2])
    point = np.concatenate([corner_point, open_vertex, first_mid, last_mid])
    offsets = np.concatenate([[0], np.cumsum(fan_size + np.where(np.arange(n_fans) < n_open, 3, 0))])
    return offsets, point[np.lexsort((position, fan))]


def _undirected_ids(a: np.ndarray, b: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distinct undirected edges (E,) end points and the id of every given edge (a, b)."""
    _, first, ids = np.unique(edge_key(a, b, n), return_index=True, return_inverse=True)
    return a[first], b[first], ids.reshape(-1)


def dual_polygons(points: npt.ArrayLike, triangles: npt.ArrayLike,
                  triangle_tags: npt.ArrayLike | None = None) -> PolygonSet:
    """Voronoi-like polygonal mesh dual to a triangle mesh.

    One polygon per (vertex, region, fan of that region's triangles around the vertex):

    * around a vertex interior to its region, the polygon joins the centroids of the
      surrounding triangles (the centroidal dual, star-shaped about the vertex);
    * around a vertex on the outer boundary or on a region interface, it is
      ``vertex, midpoint of the first boundary edge, centroids..., midpoint of the last
      boundary edge`` (counter-clockwise). The boundary/interface is thereby followed
      exactly: the polygons of each region tile exactly the union of its triangles,
      straight boundaries and interfaces stay straight (the vertex becomes a collinear
      polygon vertex there) and corners, also re-entrant ones, are kept (the polygon is
      then non-convex).

    A vertex touched by a region through two separate fans gets two polygons. Each
    dual edge joins the centroids of two neighbouring triangles; it crosses their shared
    edge inside that edge for any triangulation of reasonable quality (edge ab shared by
    abp and baq: the segment pq must meet line ab within [a - (b-a), b + (b-a)]).

    Parameters
    ----------
    points : (n, 2) float
        Triangle mesh vertices.
    triangles : (m, 3) int
        Vertex indices, either orientation.
    triangle_tags : (m,) int, optional
        Region of each triangle (default: all 0).

    Returns
    -------
    PolygonSet
        Points (used vertices, boundary/interface edge midpoints, triangle centroids),
        counter-clockwise polygons and the region tag of each polygon.
    """
    points, triangles, tags = _checked_triangles(points, triangles, triangle_tags)
    region_values, region_of_triangle = np.unique(tags, return_inverse=True)
    n, m = len(points), len(triangles)
    # corner k = j*m + t: vertex j of triangle t, spanning from vertex j+1 to vertex j+2
    v, frm, to = (triangles[:, np.roll([0, 1, 2], -shift)].T.ravel() for shift in range(3))
    region = np.tile(region_of_triangle, 3)
    successor = _corner_successors(n, region, v, frm, to)
    chain, rank, n_open = _fans(successor)
    heads, tails = _fan_ends(chain, rank, successor, n_open)
    # candidate points: vertices, midpoints of region-boundary edges, triangle centroids
    edge_a, edge_b, edge_id = _undirected_ids(np.concatenate([v[heads], v[tails]]),
                                              np.concatenate([frm[heads], to[tails]]), n)
    candidates = np.concatenate([points, 0.5 * (points[edge_a] + points[edge_b]), points[triangles].mean(axis=1)])
    first_mid, last_mid = np.split(n + edge_id, 2)
    centroid_of_corner = n + edge_a.size + np.tile(np.arange(m), 3)
    offsets, point_ids = _fan_polygons(chain, rank, n_open, centroid_of_corner, v[heads], first_mid, last_mid)
    used_points, flat = compact_points(candidates, point_ids)
    fan_tags = np.empty(offsets.size - 1, dtype=np.int32)
    fan_tags[chain] = region_values[region]
    return PolygonSet(used_points, split_csr(offsets, flat), fan_tags)
