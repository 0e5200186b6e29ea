"""Polygonal meshes for the paper's benchmarks: duals of gmsh triangle meshes, structured
quads, hanging-node gluing, gmsh ``.msh`` input and a small ``.npz`` format.

Every generator returns a :class:`~dolfinx_sfvem.polygon_mesh.PolygonMesh` whose polygons carry an
integer region tag (:data:`SOLID`, :data:`MEDIUM`, ...). Meshes of different densities are
glued by concatenation with coincident points merged (:func:`glue`); ``PolygonMesh`` then
inserts every vertex lying strictly inside a neighbour's straight edge into that neighbour
(hanging nodes). Building blocks that are not yet meshes are :class:`PolygonSet` triples
``(points, polygons, tags)``.

gmsh is imported lazily (its import changes the SIGINT handler and fails outside the main
thread); each generator that needs it runs its own gmsh session (initialise ... finalise),
so do not call one while holding a gmsh session of your own open — use
``from_gmsh(None)`` to read your current model instead.
"""
from __future__ import annotations

import contextlib
import dataclasses
import inspect
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.csgraph
import scipy.spatial

from .polygon_mesh import PolygonMesh

#: region tag of the solid bodies (further solids: 3, 4, ...)
SOLID = 1
#: region tag of the third medium
MEDIUM = 2

#: identifier stored in the ``.npz`` files written by :func:`write_polygons`
NPZ_FORMAT = "dolfinx-sfvem-polygons-1"

#: relative tolerance (times the bounding-box size) of all geometric comparisons here
REL_TOL = 1e-9


class PolygonSet(NamedTuple):
    """Polygons not yet validated as a mesh.

    Attributes
    ----------
    points : (n, 2) float64
        Vertex coordinates.
    polygons : list of (N_i,) int64
        Vertex indices of each polygon (counter-clockwise when made here; PolygonMesh
        reorients clockwise ones).
    tags : (m,) int32
        Region tag of each polygon.
    """

    points: np.ndarray
    polygons: list[np.ndarray]
    tags: np.ndarray

    def to_mesh(self) -> PolygonMesh:
        """Validate into a :class:`PolygonMesh` (T-junctions repaired)."""
        return PolygonMesh(self.points, self.polygons, self.tags, insert_hanging_nodes=True)


# --------------------------------------------------------------------------- CSR helpers
def _csr(polygons: Sequence[npt.ArrayLike]) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (m+1,) and flat vertex indices of a list of polygons."""
    sizes = np.fromiter((len(p) for p in polygons), dtype=np.int64, count=len(polygons))
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    flat = (np.concatenate([np.asarray(p, dtype=np.int64) for p in polygons]) if polygons
            else np.empty(0, dtype=np.int64))
    return offsets, flat


def _split(offsets: np.ndarray, flat: np.ndarray) -> list[np.ndarray]:
    """Inverse of :func:`_csr`."""
    return np.split(flat, offsets[1:-1])


def _next_in_polygon(offsets: np.ndarray) -> np.ndarray:
    """Flat position of the next (counter-clockwise) vertex of every flat position."""
    nxt = np.arange(1, offsets[-1] + 1)
    nxt[offsets[1:] - 1] = offsets[:-1]
    return nxt


def _compact(points: np.ndarray, flat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop points no polygon uses; returns the used points and the renumbered indices."""
    used, renumbered = np.unique(flat, return_inverse=True)
    return points[used], renumbered.astype(np.int64)


def _tolerance(points: np.ndarray) -> float:
    """Absolute length tolerance: :data:`REL_TOL` times the bounding-box size."""
    extent = float(np.ptp(points, axis=0).max()) if points.size else 0.0
    return REL_TOL * (extent if extent > 0 else 1.0)


def _as_polygon_set(part: PolygonSet | PolygonMesh | tuple) -> PolygonSet:
    """A PolygonSet from a PolygonMesh or a ``(points, polygons, tags)`` triple."""
    if isinstance(part, PolygonMesh):
        return PolygonSet(part.points, _split(part.offsets, part.vertices), part.tags)
    points, polygons, tags = part
    return PolygonSet(np.asarray(points, dtype=np.float64), list(polygons), np.asarray(tags))


# --------------------------------------------------------------------------- dual polygons
def _checked_triangles(points: npt.ArrayLike, triangles: npt.ArrayLike,
                       tags: npt.ArrayLike | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points (n,2), counter-clockwise triangles (m,3) and tags (m,) of a triangle mesh.

    Clockwise triangles are reordered; wrong shapes, out-of-range indices and triangles
    with a height below :func:`_tolerance` are errors naming the culprit.
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
    degenerate = np.flatnonzero(np.abs(twice_area) <= _tolerance(points) * longest)
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
    keys, ids = np.unique(np.minimum(a, b) * n + np.maximum(a, b), return_inverse=True)
    first, second = np.divmod(keys, n)
    return first, second, ids


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
    used_points, flat = _compact(candidates, point_ids)
    fan_tags = np.empty(offsets.size - 1, dtype=np.int32)
    fan_tags[chain] = region_values[region]
    return PolygonSet(used_points, _split(offsets, flat), fan_tags)


# --------------------------------------------------------------------------- structured quads
def _n_segments(length: float, h: float) -> int:
    """Number of equal segments of size about ``h`` on a straight line of ``length``."""
    return max(1, int(round(length / h)))


def _axis_nodes(breaks: Sequence[float], h: float, refinement: int = 1) -> np.ndarray:
    """1D grid nodes: each interval between consecutive ``breaks`` split uniformly.

    Interval ``[a, b]`` gets ``refinement * _n_segments(b - a, h)`` segments, i.e. exactly
    the nodes (``refinement = 1``) or a uniform ``refinement``-fold subdivision of the nodes
    that gmsh puts on a transfinite line of size ``h`` (see :func:`_straight_region`).
    """
    pieces = [np.linspace(a, b, refinement * _n_segments(b - a, h) + 1)[:-1]
              for a, b in zip(breaks[:-1], breaks[1:])]
    return np.concatenate(pieces + [np.asarray(breaks[-1:], dtype=np.float64)])


def _quad_grid(xs: np.ndarray, ys: np.ndarray, tag: int,
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
    used_points, flat = _compact(points, quads.ravel())
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
    return _quad_grid(x0 + np.linspace(0.0, Lx, nx + 1), y0 + np.linspace(0.0, Ly, ny + 1), tag).to_mesh()


# --------------------------------------------------------------------------- gluing
def _merge_points(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge points closer than :func:`_tolerance`; returns merged points and old -> new."""
    pairs = scipy.spatial.cKDTree(points).query_pairs(_tolerance(points), output_type="ndarray")
    graph = scipy.sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                                    shape=(len(points), len(points)))
    _, label = scipy.sparse.csgraph.connected_components(graph, directed=False)
    _, first, new_index = np.unique(label, return_index=True, return_inverse=True)
    return points[first], new_index


def _concatenate(parts: Sequence[PolygonSet]) -> PolygonSet:
    """One PolygonSet of all parts, coincident points merged (first occurrence kept)."""
    shifts = np.cumsum([0] + [len(p.points) for p in parts])
    offsets, flat = _csr([poly + shift for p, shift in zip(parts, shifts) for poly in p.polygons])
    points, new_index = _merge_points(np.concatenate([p.points for p in parts]))
    tags = np.concatenate([np.asarray(p.tags, dtype=np.int32) for p in parts])
    return PolygonSet(points, _split(offsets, new_index[flat]), tags)


def glue(*parts: PolygonSet | PolygonMesh | tuple) -> PolygonMesh:
    """Concatenate meshes, merging coincident points, into one PolygonMesh.

    Points of different parts closer than :data:`REL_TOL` times the overall bounding-box
    size are merged (the first part's coordinates are kept). Where the parts' densities
    differ along a shared straight boundary, ``PolygonMesh`` inserts each vertex lying
    strictly inside a neighbour's edge into that neighbour (hanging nodes).

    Parameters
    ----------
    *parts : PolygonSet, PolygonMesh or (points (n,2), polygons, tags (m,)) triples
    """
    return _concatenate([_as_polygon_set(p) for p in parts]).to_mesh()


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
    tol = _tolerance(np.array([[0.0, 0.0], [Lx, Ly]]))
    if not all(np.abs(axis - c).min() <= tol for axis, c in ((xs, x0), (xs, x1), (ys, y0), (ys, y1))) \
            or not (x0 < x1 and y0 < y1):
        raise ValueError(f"refine box {tuple(refine)} must be non-empty with its sides on the coarse grid "
                         f"lines x = k*{Lx / n:g}, y = k*{Ly / n:g}")

    def inside(cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
        return (cx > x0) & (cx < x1) & (cy > y0) & (cy < y1)

    coarse = _quad_grid(xs, ys, tag, lambda cx, cy: ~inside(cx, cy))
    fine = _quad_grid(np.linspace(0.0, Lx, 2 * n + 1), np.linspace(0.0, Ly, 2 * n + 1), tag, inside)
    return glue(coarse, fine)


# --------------------------------------------------------------------------- gmsh
@contextlib.contextmanager
def gmsh_session() -> Iterator[object]:
    """A quiet gmsh model of our own; yields the gmsh module.

    If the caller has no gmsh session open, one is initialised and finalised here. If the
    caller's session is open, it is left open: a new model is added and removed afterwards,
    and the caller's current model and terminal option are restored.
    """
    import gmsh

    ours = not _gmsh_initialized(gmsh)
    if ours:
        newer = "interruptible" in inspect.signature(gmsh.initialize).parameters  # newer gmsh: skip its SIGINT handler
        gmsh.initialize(readConfigFiles=False, **({"interruptible": False} if newer else {}))
    previous, terminal = gmsh.model.getCurrent(), gmsh.option.getNumber("General.Terminal")
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        if not ours:
            gmsh.model.add("dolfinx_sfvem")
        yield gmsh
    finally:
        if ours:
            gmsh.finalize()
        else:
            gmsh.model.remove()
            if previous in gmsh.model.list():
                gmsh.model.setCurrent(previous)
            gmsh.option.setNumber("General.Terminal", terminal)


def _gmsh_initialized(gmsh) -> bool:
    """Whether a gmsh session is open (gmsh 4.8 has no ``isInitialized``: it lists no model
    before the first initialisation and raises after a finalisation)."""
    if hasattr(gmsh, "isInitialized"):
        return bool(gmsh.isInitialized())
    try:
        return len(gmsh.model.list()) > 0
    except Exception:
        return False


def _surface_regions(gmsh, region_tags: Mapping[str, int] | None) -> dict[int, int]:
    """Region tag of every 2D entity to read from the current gmsh model.

    With ``region_tags`` (physical-group name -> tag), the surfaces of those groups; without,
    the surfaces of all 2D physical groups tagged by the group's number, or every surface
    with tag 0 when the model has no 2D physical group.
    """
    groups = [tag for _, tag in gmsh.model.getPhysicalGroups(2)]
    if region_tags is None:
        if not groups:
            return {entity: 0 for _, entity in gmsh.model.getEntities(2)}
        selected = {group: group for group in groups}
    else:
        names = {gmsh.model.getPhysicalName(2, group): group for group in groups}
        missing = sorted(set(region_tags) - set(names))
        if missing:
            raise ValueError(f"2D physical group(s) {missing} not found in the gmsh model; it has "
                             f"{sorted(names) if names else 'no 2D physical groups'}")
        selected = {names[name]: tag for name, tag in region_tags.items()}
    regions: dict[int, int] = {}
    for group, tag in selected.items():
        for entity in gmsh.model.getEntitiesForPhysicalGroup(2, group):
            if regions.setdefault(int(entity), tag) != tag:
                raise ValueError(f"surface {entity} belongs to two physical groups with different tags")
    return regions


def model_cells(gmsh, region_tags: Mapping[str, int] | None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """All 2D cells of the current gmsh model as polygons of their corner nodes.

    Higher-order nodes are dropped (edges are straight); nodes no cell uses are removed.

    Returns
    -------
    points : (n, 2) float64
    offsets : (m + 1,) int64 and flat : (offsets[-1],) int64
        Cell i has the points ``flat[offsets[i]:offsets[i+1]]`` (gmsh's node order).
    tags : (m,) int32
        Region tag of every cell (see :func:`_surface_regions`).
    """
    node_tags, coords, _ = gmsh.model.mesh.getNodes()
    xyz = coords.reshape(-1, 3)
    if np.abs(xyz[:, 2]).max(initial=0.0) > _tolerance(xyz[:, :2]):
        raise ValueError("the gmsh mesh is not in the plane z = 0")
    node_order = np.argsort(node_tags)
    blocks, tags = [], []
    for entity, tag in _surface_regions(gmsh, region_tags).items():
        for etype, enodes in zip(*gmsh.model.mesh.getElements(2, entity)[::2]):
            _, _, _, n_nodes, _, n_corners = gmsh.model.mesh.getElementProperties(etype)
            cells = np.asarray(enodes, dtype=np.int64).reshape(-1, n_nodes)[:, :n_corners]
            blocks.append(node_order[np.searchsorted(node_tags, cells, sorter=node_order)])
            tags.append(np.full(len(cells), tag, dtype=np.int32))
    if not blocks:
        raise ValueError("the gmsh model has no 2D elements in the selected surfaces")
    sizes = np.concatenate([np.full(len(block), block.shape[1]) for block in blocks])
    points, flat = _compact(xyz[:, :2], np.concatenate([block.ravel() for block in blocks]))
    return points, np.concatenate([[0], np.cumsum(sizes)]), flat, np.concatenate(tags)


def from_gmsh(source: str | os.PathLike | None = None,
              region_tags: Mapping[str, int] | None = None) -> PolygonMesh:
    """PolygonMesh of the 2D cells of a gmsh mesh, one polygon per cell.

    Triangles, quadrilaterals and any other 2D element type of fixed size are read as
    polygons of their corner ("primary") nodes; higher-order nodes are ignored.

    Parameters
    ----------
    source : path or None
        A ``.msh`` file (read in a gmsh session of its own), or ``None`` for the current
        model of the caller's open gmsh session.
    region_tags : mapping of physical-group name -> region tag, optional
        Read the surfaces of these 2D physical groups with these tags; a missing group is
        a ValueError naming it. Default: every 2D physical group, tagged by its number,
        or all surfaces with tag 0 if the model has no 2D physical group.

    The mesh's ``region_names`` (name -> tag) let :class:`~dolfinx_sfvem.ContactProblem` take
    materials keyed by the physical groups' names. A gmsh session the caller has open stays open.
    """
    if source is None:
        import gmsh

        points, offsets, flat, tags = model_cells(gmsh, region_tags)
        names = region_names(gmsh, region_tags)
    else:
        path = os.fspath(source)
        if not os.path.isfile(path):
            raise FileNotFoundError(path)
        with gmsh_session() as gmsh:
            gmsh.merge(path)
            points, offsets, flat, tags = model_cells(gmsh, region_tags)
            names = region_names(gmsh, region_tags)
    mesh = PolygonSet(points, _split(offsets, flat), tags).to_mesh()
    mesh.region_names = names
    return mesh


def region_names(gmsh, region_tags: Mapping[str, int] | None) -> dict[str, int]:
    """Region tag by name of the current gmsh model's 2D physical groups (``region_tags`` itself
    when given; unnamed groups are left out)."""
    if region_tags is not None:
        return dict(region_tags)
    return {name: int(group) for _, group in gmsh.model.getPhysicalGroups(2)
            if (name := gmsh.model.getPhysicalName(2, group))}


#: gmsh geometry builder: ``build(gmsh, h)`` -> {region tag: surface tags}
_Builder = Callable[[object, float], Mapping[int, Sequence[int]]]


def _dual_of_gmsh(build: _Builder, h: float, keep_gmsh: str | os.PathLike | None = None) -> PolygonSet:
    """Dual polygons (:func:`dual_polygons`) of a gmsh triangle mesh of size ``h``.

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
    return dual_polygons(points, flat.reshape(-1, 3), tags)


def write_gmsh(gmsh, stem: str | os.PathLike) -> None:
    """Write the current gmsh model: ``<stem>.geo``, the geometry with the mesh options
    ``Mesh.Algorithm`` and ``Mesh.MeshSizeMax`` in force (``gmsh <stem>.geo -2`` meshes it
    again), and ``<stem>.msh``, its mesh (2D physical groups numbered by region tag)."""
    stem = os.fspath(stem)
    gmsh.write(stem + ".msh")
    gmsh.write(stem + ".geo_unrolled")
    with open(stem + ".geo_unrolled") as f:
        geometry = f.read()
    os.remove(stem + ".geo_unrolled")
    options = "".join(f"{name} = {gmsh.option.getNumber(name)!r};\n" for name in ("Mesh.Algorithm", "Mesh.MeshSizeMax"))
    with open(stem + ".geo", "w") as f:
        f.write(f"// written by dolfinx_sfvem.meshes.write_gmsh; `gmsh {os.path.basename(stem)}.geo -2` meshes it\n"
                + options + geometry)


def _straight_region(loops: Sequence[npt.ArrayLike], tag: int) -> _Builder:
    """gmsh builder (see :func:`_dual_of_gmsh`) of one region bounded by straight sides.

    ``loops[0]`` is the outer boundary, the others holes; each is a closed polyline of
    corner points (n_i, 2). Every side is a transfinite line of ``_n_segments(length, h)``
    equal segments, so the boundary nodes are predictable: they coincide with
    :func:`_axis_nodes` grids on the same sides.
    """
    def build(gmsh, h: float) -> dict[int, list[int]]:
        curve_loops = []
        for loop in loops:
            corners = np.asarray(loop, dtype=np.float64)
            pts = [gmsh.model.geo.addPoint(x, y, 0.0, h) for x, y in corners]
            lines = [gmsh.model.geo.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
            lengths = np.linalg.norm(np.roll(corners, -1, axis=0) - corners, axis=1)
            for line, length in zip(lines, lengths):
                gmsh.model.geo.mesh.setTransfiniteCurve(line, _n_segments(length, h) + 1)
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
    return _dual_of_gmsh(_straight_region([corners], tag), h).to_mesh()


# --------------------------------------------------------------------------- benchmarks
@dataclasses.dataclass(frozen=True)
class Benchmark:
    """A meshed benchmark with the named points and boundary segments its demo needs.

    Attributes
    ----------
    mesh : PolygonMesh
        Polygons tagged :data:`SOLID`, :data:`MEDIUM`, ...
    regions : dict name -> tag
        Region tags by body name (materials are assigned per region).
    points : dict name -> (x, y)
        Named points; each is a mesh vertex.
    segments : dict name -> ((x0, y0), (x1, y1))
        Named straight boundary pieces (e.g. clamped sides).
    """

    mesh: PolygonMesh
    regions: dict[str, int]
    points: dict[str, tuple[float, float]]
    segments: dict[str, tuple[tuple[float, float], tuple[float, float]]]

    def __post_init__(self):
        self.mesh.region_names = dict(self.regions)

    def vertex(self, name: str) -> int:
        """Index of the mesh vertex at the named point (ValueError if there is none)."""
        distance = np.linalg.norm(self.mesh.points - np.asarray(self.points[name]), axis=1)
        index = int(np.argmin(distance))
        if distance[index] > self.mesh.tol:
            raise ValueError(f"named point {name!r} {self.points[name]} is not a mesh vertex")
        return index

    def vertices_on(self, name: str) -> np.ndarray:
        """Indices (k,) of the mesh vertices on the named segment."""
        points = self.mesh.points
        a, b = (np.asarray(p, dtype=np.float64) for p in self.segments[name])
        s = np.clip((points - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        distance = np.linalg.norm(points - (a + s[:, None] * (b - a)), axis=1)
        return np.flatnonzero(distance <= self.mesh.tol)


def _solid_with_quad_medium(solid_loops: Sequence[npt.ArrayLike], h: float, xs: np.ndarray,
                            ys: np.ndarray, medium: Callable[[np.ndarray, np.ndarray], np.ndarray] | None,
                            keep_gmsh: str | os.PathLike | None = None) -> PolygonMesh:
    """Dual polygons of the solid glued to a quadrilateral medium grid (hanging nodes)."""
    return glue(_dual_of_gmsh(_straight_region(solid_loops, SOLID), h, keep_gmsh),
                _quad_grid(xs, ys, MEDIUM, medium))


#: C-box of paper §5.2: length, wall thickness, height
_CBOX_L, _CBOX_T, _CBOX_H = 1.0, 0.1, 0.5
#: default width of the C-box's medium column right of the beams: the wall thickness, fixed
#: whatever the mesh size (a column as thin as one small element lets the medium between the
#: beams be dragged out sideways and the beams pass through each other, docs/contact.md)
CBOX_COLUMN = 0.1


def _cbox_benchmark(mesh: PolygonMesh) -> Benchmark:
    """The C-box's regions, named points and segments around ``mesh``."""
    L, t, H = _CBOX_L, _CBOX_T, _CBOX_H
    return Benchmark(mesh, {"solid": SOLID, "medium": MEDIUM},
                     {"load": (L, H), "gap_top": (L, H - t), "gap_bottom": (L, t)},
                     {"fixed": ((0.0, 0.0), (0.0, H))})


def _cbox_medium(cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
    """Whether the points (cx, cy) of the C-box's bounding grid lie in the medium."""
    return (cx > _CBOX_L) | ((cx > _CBOX_T) & (cy > _CBOX_T) & (cy < _CBOX_H - _CBOX_T))


def cbox(h_solid: float = 0.05, medium_refinement: int = 1, keep_gmsh: str | os.PathLike | None = None,
         column: float = CBOX_COLUMN) -> Benchmark:
    """C-box of paper §5.2 (Bluhm et al. 2021) with a quadrilateral third medium.

    Geometry (L = 1, wall thickness t = 0.1, height 0.5, initial gap 0.3): solid = left
    wall [0, 0.1] x [0, 0.5], bottom beam [0, 1] x [0, 0.1] and top beam [0, 1] x [0.4, 0.5];
    medium = the cavity [0.1, 1] x [0.1, 0.4] and a column [1, 1 + column] x [0, 0.5] to
    the right of the structure (default width :data:`CBOX_COLUMN`, independent of the mesh).

    Mesh: the solid is the dual (:func:`dual_polygons`) of a gmsh triangle mesh of size
    ``h_solid`` whose straight sides carry ``round(length / h_solid)`` equal segments; the
    medium is a grid of quads ``medium_refinement`` times finer than those segments
    (column: ``medium_refinement * round(column / h_solid)`` quads across). The solid mesh does not depend on
    ``medium_refinement``. With 1, the triangle vertices on the interface are quad
    vertices and the dual midpoints between them are hanging nodes in the quads; with 2,
    the quads end exactly at the solid polygons' interface points (the triangle vertices
    there stay collinear vertices of the solid polygons, T-junctions against the quads).

    Named points: ``load`` (1, 0.5), the top-right corner where u_y is prescribed;
    ``gap_top`` (1, 0.4) and ``gap_bottom`` (1, 0.1), the inner corners at the beam tips.
    Named segments: ``fixed``, the left side x = 0.

    ``keep_gmsh``: write the solid's gmsh model to ``<keep_gmsh>.geo`` / ``.msh`` (:func:`write_gmsh`).
    """
    xs, ys = _cbox_axes(h_solid, medium_refinement, column)
    L, t, H = _CBOX_L, _CBOX_T, _CBOX_H
    outline = [(0, 0), (L, 0), (L, t), (t, t), (t, H - t), (L, H - t), (L, H), (0, H)]
    mesh = _solid_with_quad_medium([outline], h_solid, xs[xs >= t - 1e-12], ys, _cbox_medium, keep_gmsh)
    return _cbox_benchmark(mesh)


def cbox_grid(h_solid: float = 0.05, medium_refinement: int = 1, column: float = CBOX_COLUMN) -> Benchmark:
    """The C-box of :func:`cbox` (same geometry and ``column``) meshed entirely
    by its medium grid: rectangles of size ``h_solid / medium_refinement``, solid included,
    no hanging nodes. The mesh for degree-2 Lagrange FEM on quadrilaterals (Q2), see
    :meth:`~dolfinx_sfvem.fem.P2Discretization.from_polygon_mesh` with ``fem_mesh``.
    """
    xs, ys = _cbox_axes(h_solid, medium_refinement, column)
    return _cbox_benchmark(glue(_quad_grid(xs, ys, SOLID, lambda cx, cy: ~_cbox_medium(cx, cy)),
                                _quad_grid(xs, ys, MEDIUM, _cbox_medium)))


def _cbox_axes(h_solid: float, medium_refinement: int, column: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid lines of the C-box's bounding box [0, 1 + column] x [0, 0.5] (the medium's quads)."""
    if int(medium_refinement) != medium_refinement or medium_refinement < 1:
        raise ValueError(f"medium_refinement must be a positive integer, got {medium_refinement!r}")
    if not (np.isfinite(column) and column > 0.0):
        raise ValueError(f"the C-box's medium column width must be a number > 0, got {column!r}")
    L, t, H = _CBOX_L, _CBOX_T, _CBOX_H
    return (_axis_nodes([0.0, t, L, L + column], h_solid, medium_refinement),
            _axis_nodes([0.0, t, H - t, H], h_solid, medium_refinement))


def box(mesh: int = 1, h_solid: float = 0.05, keep_gmsh: str | os.PathLike | None = None) -> Benchmark:
    """Box self-contact of paper §5.1: three medium densities, one solid mesh.

    Geometry: box [0, 2] x [0, 0.5] with walls of thickness 0.1; the cavity
    [0.1, 1.9] x [0.1, 0.4] is filled with medium.

    Mesh: the solid is the dual of a gmsh triangle mesh of size ``h_solid``, its straight
    sides split at x = 1 and carrying ``round(length / h_solid)`` equal segments; the
    medium is a grid of quads ``mesh`` times finer than those segments (mesh 1, 2, 3 =
    quads of size h_solid, h_solid/2, h_solid/3). Mesh 1: interface midpoints of the
    solid hang in the quads; mesh 2: quads end at the solid's interface points; mesh 3:
    hanging nodes on both sides. The solid mesh is the same for all three.

    Named points: ``fixed`` (0, 0) lower-left corner (u = 0); ``roller`` (2, 0)
    lower-right corner (u_y = 0); ``load`` (1, 0.5) middle of the top; ``gap_top``
    (1, 0.4) and ``gap_bottom`` (1, 0.1), the inner surfaces at mid-span where the gap is
    measured. No named segments.

    ``keep_gmsh``: write the solid's gmsh model to ``<keep_gmsh>.geo`` / ``.msh`` (:func:`write_gmsh`).
    """
    if mesh not in (1, 2, 3):
        raise ValueError(f"box mesh must be 1, 2 or 3, got {mesh!r}")
    L, H, t = 2.0, 0.5, 0.1
    outer = [(0, 0), (L / 2, 0), (L, 0), (L, H), (L / 2, H), (0, H)]
    cavity = [(t, t), (L / 2, t), (L - t, t), (L - t, H - t), (L / 2, H - t), (t, H - t)]
    xs = _axis_nodes([t, L / 2, L - t], h_solid, mesh)
    ys = _axis_nodes([t, H - t], h_solid, mesh)
    polygon_mesh = _solid_with_quad_medium([outer, cavity], h_solid, xs, ys, None, keep_gmsh)
    return Benchmark(polygon_mesh, {"solid": SOLID, "medium": MEDIUM},
                     {"fixed": (0.0, 0.0), "roller": (L, 0.0), "load": (L / 2, H),
                      "gap_top": (L / 2, H - t), "gap_bottom": (L / 2, t)}, {})


def _occ_sector(gmsh, centre: Sequence[float], radius: float, angles: Sequence[float]) -> int:
    """OCC surface of a disc sector: centre -> rim at ``angles[0]`` -> arcs through the
    other rim angles (degrees, each step below 180) -> back to the centre. Every rim angle
    gives a geometry point, hence a mesh vertex."""
    cx, cy = centre
    occ = gmsh.model.occ
    c = occ.addPoint(cx, cy, 0.0)
    rim = [occ.addPoint(cx + radius * np.cos(a), cy + radius * np.sin(a), 0.0) for a in np.radians(angles)]
    arcs = [occ.addCircleArc(rim[i], c, rim[i + 1]) for i in range(len(rim) - 1)]
    loop = occ.addCurveLoop([occ.addLine(c, rim[0])] + arcs + [occ.addLine(rim[-1], c)])
    return occ.addPlaneSurface([loop])


def _occ_regions(gmsh, solids: Sequence[tuple[int, int]], medium_box: int) -> dict[int, list[int]]:
    """Fragment solid surfaces ``(region tag, surface)`` and a box around the medium into a
    conforming model; the parts of the box outside every solid are :data:`MEDIUM`."""
    objects = [(2, surface) for _, surface in solids]
    _, children = gmsh.model.occ.fragment(objects, [(2, medium_box)])
    gmsh.model.occ.synchronize()
    regions: dict[int, list[int]] = {}
    for (tag, _), parts in zip(solids, children):
        regions.setdefault(tag, []).extend(surface for _, surface in parts)
    taken = {surface for surfaces in regions.values() for surface in surfaces}
    regions[MEDIUM] = [surface for _, surface in children[-1] if surface not in taken]
    return regions


def punch(h: float = 0.05, gap: float = 1.0, keep_gmsh: str | os.PathLike | None = None) -> Benchmark:
    """Punch problem of paper §5.3, half model, polygonal (dual) meshes everywhere.

    Geometry (the paper's figure is missing; choices made here): symmetry axis x = 0;
    block [0, 2] x [0, 1] (L x H = 2 x 1 in the half model) tagged :data:`SOLID`; punch =
    quarter of a disc of radius R = 1 centred at (0, 1 + gap + R), i.e. the lower right
    quarter with its flat top at y = 1 + gap + R and its lowest point (0, 1 + gap),
    tagged 3; medium = the box [0, 2] x [1, 1 + gap + R] minus the punch. The default
    gap 1.0 with the paper's u_y = -1.3 gives an indentation of 0.3 of the block.

    Mesh: one gmsh triangle mesh of size ``h`` of all three regions (conforming along
    the curved punch surface), converted by :func:`dual_polygons`; curved boundaries are
    followed by chords (vertices on the arc).

    Named segments: ``fixed`` the block bottom y = 0; ``symmetry`` the axis x = 0 (u_x = 0);
    ``load`` the punch top where u_y is prescribed. Named points: ``punch_tip``
    (0, 1 + gap), ``block_top`` (0, 1).

    ``keep_gmsh``: write the gmsh model to ``<keep_gmsh>.geo`` / ``.msh`` (:func:`write_gmsh`).
    """
    L, H, R = 2.0, 1.0, 1.0
    top = H + gap + R

    def build(gmsh, h: float) -> dict[int, list[int]]:
        block = gmsh.model.occ.addRectangle(0.0, 0.0, 0.0, L, H)
        tool = _occ_sector(gmsh, (0.0, top), R, [0.0, -90.0])
        return _occ_regions(gmsh, [(SOLID, block), (3, tool)], gmsh.model.occ.addRectangle(0.0, H, 0.0, L, gap + R))

    return Benchmark(_dual_of_gmsh(build, h, keep_gmsh).to_mesh(), {"block": SOLID, "medium": MEDIUM, "punch": 3},
                     {"punch_tip": (0.0, H + gap), "block_top": (0.0, H)},
                     {"fixed": ((0.0, 0.0), (L, 0.0)), "symmetry": ((0.0, 0.0), (0.0, top)),
                      "load": ((0.0, top), (R, top))})


def multi_object(h: float = 0.04, gap: float = 0.1, keep_gmsh: str | os.PathLike | None = None) -> Benchmark:
    """Contact of multiple objects, paper §5.4, polygonal (dual) meshes everywhere.

    Geometry (the paper's figure is missing; choices made here): block [0, 8] x [0, 0.2]
    tagged :data:`SOLID`; 7 half-discs of radius R = 0.2 above it, centred at
    x_i = 1, 2, ..., 7 and y = 0.2 + gap + R, flat side up, round side down with its lowest
    point ``gap`` above the block, tagged 3; medium = the box [0, 8] x [0.2, 0.2 + gap + R]
    minus the discs (the cavities between all parts).

    Mesh: one gmsh triangle mesh of size ``h``, converted by :func:`dual_polygons`.

    Named segments: ``left_end`` x = 0 and ``right_end`` x = 8 of the block (clamped or
    simply supported); ``disc_top_i`` (i = 1..7) the flat top of disc i where u_y is
    prescribed. Named points: ``disc_tip_i``, the lowest point of disc i.

    ``keep_gmsh``: write the gmsh model to ``<keep_gmsh>.geo`` / ``.msh`` (:func:`write_gmsh`).
    """
    L, T, R, n = 8.0, 0.2, 0.2, 7
    top = T + gap + R
    centres = [L * (i + 1) / (n + 1) for i in range(n)]

    def build(gmsh, h: float) -> dict[int, list[int]]:
        block = gmsh.model.occ.addRectangle(0.0, 0.0, 0.0, L, T)
        discs = [(3, _occ_sector(gmsh, (x, top), R, [0.0, -90.0, -180.0])) for x in centres]
        return _occ_regions(gmsh, [(SOLID, block)] + discs, gmsh.model.occ.addRectangle(0.0, T, 0.0, L, gap + R))

    return Benchmark(_dual_of_gmsh(build, h, keep_gmsh).to_mesh(), {"block": SOLID, "medium": MEDIUM, "discs": 3},
                     {f"disc_tip_{i + 1}": (x, T + gap) for i, x in enumerate(centres)},
                     {"left_end": ((0.0, 0.0), (0.0, T)), "right_end": ((L, 0.0), (L, T)),
                      **{f"disc_top_{i + 1}": ((x - R, top), (x + R, top)) for i, x in enumerate(centres)}})


# --------------------------------------------------------------------------- I/O, summary
def write_polygons(path: str | os.PathLike, mesh: PolygonMesh) -> None:
    """Save a PolygonMesh as ``.npz``.

    Format (all arrays, numpy ``savez_compressed``): ``format`` = :data:`NPZ_FORMAT`;
    ``points`` (n, 2) float64; ``offsets`` (m+1,) int64 and ``vertices`` (offsets[-1],)
    int64, polygon i being ``vertices[offsets[i]:offsets[i+1]]`` counter-clockwise;
    ``tags`` (m,) int32.
    """
    np.savez_compressed(path, format=np.array(NPZ_FORMAT), points=mesh.points.astype(np.float64),
                        offsets=mesh.offsets.astype(np.int64), vertices=mesh.vertices.astype(np.int64),
                        tags=mesh.tags.astype(np.int32))


def read_polygons(path: str | os.PathLike) -> PolygonMesh:
    """Load a PolygonMesh written by :func:`write_polygons`."""
    with np.load(path) as data:
        if "format" not in data or str(data["format"]) != NPZ_FORMAT:
            raise ValueError(f"{os.fspath(path)} is not a {NPZ_FORMAT} file")
        return PolygonSet(data["points"], _split(data["offsets"], data["vertices"]), data["tags"]).to_mesh()


def t_junctions(mesh: PolygonMesh) -> np.ndarray:
    """Hanging nodes in the T-junction sense: vertices (k,) at which one polygon has a
    straight angle and another polygon a proper corner.

    These are where meshes of different densities meet. Unlike ``mesh.hanging_nodes``
    (every vertex collinear with its neighbours in some polygon), a collinear vertex that
    no polygon has as a corner is not counted: on a straight outer boundary, or straight
    on both sides of an interface (as the dual of a triangle mesh leaves them).
    """
    points, offsets, flat = mesh.points, mesh.offsets, mesh.vertices
    nxt = _next_in_polygon(offsets)
    prv = np.empty_like(nxt)
    prv[nxt] = np.arange(nxt.size)
    d_in, d_out = points[flat] - points[flat[prv]], points[flat[nxt]] - points[flat]
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    length_in, length_out = np.linalg.norm(d_in, axis=1), np.linalg.norm(d_out, axis=1)
    straight = (np.abs(cross) <= mesh.tol * np.maximum(length_in, length_out)) \
        & (np.einsum("ij,ij->i", d_in, d_out) > 0)
    has_straight = np.bincount(flat[straight], minlength=len(points)) > 0
    has_corner = np.bincount(flat[~straight], minlength=len(points)) > 0
    return np.flatnonzero(has_straight & has_corner)


def describe(mesh: PolygonMesh) -> str:
    """Summary: polygons by vertex count, hanging nodes, per-region counts and areas, area range.

    Hanging nodes are counted three ways: T-junctions (:func:`t_junctions`), vertices
    inserted by T-junction repair, and all collinear polygon vertices
    (``mesh.hanging_nodes``, which also holds straight-boundary vertices of dual meshes).
    """
    n_vertices, counts = np.unique(np.diff(mesh.offsets), return_counts=True)
    lines = [f"{mesh.n_polygons} polygons, {mesh.n_points} points",
             "polygons by vertex count: " + ", ".join(f"{k}: {c}" for k, c in zip(n_vertices, counts)),
             f"hanging nodes: {t_junctions(mesh).size} T-junctions ({mesh.n_inserted_hanging_nodes} vertex "
             f"insertions), {mesh.hanging_nodes.size} collinear vertices"]
    for tag in np.unique(mesh.tags):
        chosen = mesh.tags == tag
        lines.append(f"region {tag}: {chosen.sum()} polygons, area {mesh.areas[chosen].sum():.6g}")
    lines.append(f"polygon area: min {mesh.areas.min():.3g}, max {mesh.areas.max():.3g}")
    return "\n".join(lines)
