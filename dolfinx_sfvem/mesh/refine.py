"""Local refinement of a polygon mesh with hanging nodes (docs/refinement-local.md).

Every selected polygon is cut into *pieces* that are star-shaped from a centre point -- the
polygon itself with the centre of its fan sub-triangulation (its centroid if that sees every
edge, else the centroid of its visibility region), or, for a polygon without such a point, the
ear triangles of its sub-triangulation with their centroids. A piece with vertices v_0 .. v_{n-1}
and edge midpoints m_i (on edge v_i v_{i+1}) becomes the n quadrilaterals [c, m_{i-1}, v_i, m_i],
except at a reflex vertex v_i, where the dart-shaped quadrilateral is replaced by the two
triangles [c, m_{i-1}, v_i] and [c, v_i, m_i] (repeated refinement of darts would give ever
thinner polygons). A polygon that is not refined but shares a split edge gets that edge's
midpoint inserted into its vertex list: a hanging node. Points keep their index: refinement only
appends points.

This module works on the arrays of a mesh (:class:`Polygons`, what it reads of a
:class:`~dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh`) and builds none:
:meth:`PolygonMesh.refine <dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh.refine>` makes the mesh of
each level from :func:`split_level`. This is geometry and topology only; carrying an SFVEM state
over to the refined mesh is :func:`dolfinx_sfvem.discretizations.state_transfer.transfer_state`.
"""
from __future__ import annotations

import typing

import numpy as np
import numpy.typing as npt

from dolfinx_sfvem.mesh.csr import concatenated_ranges, edge_key, next_entries, previous_entries
from dolfinx_sfvem.mesh.polygon import RTOL
from dolfinx_sfvem.discretizations.projection import without_sufficient_order

Marker = typing.Callable[[np.ndarray], np.ndarray]
Selection = typing.Union[Marker, npt.ArrayLike, None]


class Sides(typing.Protocol):
    """The sides of a polygon mesh: one per vertex entry, from ``start`` to ``end`` (n_sides,) int64."""
    start: npt.NDArray[np.int64]
    end: npt.NDArray[np.int64]


class Polygons(typing.Protocol):
    """What the refinement reads of a :class:`~dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh`."""
    n_points: int
    n_polygons: int
    points: npt.NDArray[np.float64]                 # (n_points, 2)
    offsets: npt.NDArray[np.int64]                  # (n_polygons + 1,) CSR offsets of ``vertices``
    vertices: npt.NDArray[np.int64]                 # counter-clockwise vertex lists
    tags: npt.NDArray[np.int32]                     # (n_polygons,) region tags
    region_names: dict[str, int]
    centroids: npt.NDArray[np.float64]              # (n_polygons, 2)
    interior_node: npt.NDArray[np.int64]            # (n_polygons, 2): equal entries for a fan sub-triangulation
    nodes: npt.NDArray[np.float64]                  # points, then the fan centres
    triangles: npt.NDArray[np.int64]                # (n_triangles, 3) sub-triangles
    triangle_offsets: npt.NDArray[np.int64]         # (n_polygons + 1,) CSR offsets of ``triangles``
    sides: Sides


class Tagged(typing.Protocol):
    """What the selection reads of a mesh: a polygon mesh or a 3D cell mesh."""
    tags: npt.NDArray[np.int32]                     # (n_cells,) region tags
    region_names: dict[str, int]
    centroids: npt.NDArray[np.float64]              # (n_cells, d)


# --------------------------------------------------------------------------- selection
def select_polygons(mesh: Tagged, where: Selection = None, tags: typing.Iterable[int | str] | None = None,
                    what: str = "polygon") -> npt.NDArray[np.bool_]:
    """Mask (n_polygons,) of the polygons chosen by ``where`` and ``tags`` (both: the intersection);
    the cells of a 3D mesh likewise (``what = "cell"``, the word of the messages).

    Parameters
    ----------
    where
        A marker ``f(x) -> bool (n,)`` of the centroids ``x`` (d, n) (as the markers of
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
        raise ValueError(f"refine: give a centroid marker, a {what} mask or {what} indices, and/or region tags")
    n = mesh.tags.shape[0]
    chosen = np.ones(n, dtype=bool)
    if callable(where):
        marked = np.asarray(where(mesh.centroids.T.copy()))
        if marked.shape != (n,) or marked.dtype.kind not in "bui":
            raise ValueError(f"refine: the marker must return a bool array of shape ({n},) (one entry per {what} "
                             f"centroid), got shape {marked.shape} and dtype {marked.dtype}")
        chosen &= marked.astype(bool)
    elif where is not None:
        given = np.asarray(where)
        if given.dtype == bool:
            if given.shape != (n,):
                raise ValueError(f"refine: a {what} mask must have shape ({n},), got {given.shape}")
            chosen &= given
        elif given.dtype.kind in "iu" and given.ndim <= 1:
            given = given.reshape(-1)
            bad = given[(given < 0) | (given >= n)]
            if bad.size:
                raise ValueError(f"refine: {what} index {bad[0]} out of range [0, {n})")
            mask = np.zeros(n, dtype=bool)
            mask[given] = True
            chosen &= mask
        else:
            raise ValueError(f"refine: 'where' must be a centroid marker, a boolean mask or {what} indices, "
                             f"got an array of dtype {given.dtype} and shape {given.shape}")
    if tags is not None:
        chosen &= np.isin(mesh.tags, _region_tags(mesh, tags, what))
    if not chosen.any():
        raise ValueError(f"refine: the selection is empty (no {what} chosen)")
    return chosen


def _region_tags(mesh: Tagged, tags: typing.Iterable[int | str], what: str) -> npt.NDArray[np.int64]:
    """Tags from tags or region names; ValueError for one that no polygon (cell) carries."""
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
            raise ValueError(f"refine: no {what} has region tag {t} (tags: {np.unique(mesh.tags).tolist()})")
        out.append(int(t))
    return np.asarray(out, dtype=np.int64)


# --------------------------------------------------------------------------- splitting
def _pieces(mesh: Polygons, chosen: npt.NDArray[np.int64]):
    """Star-shaped pieces of the chosen polygons: (offsets, vertices, centres (n, 2), polygon (n,)).

    A polygon with a fan sub-triangulation is one piece around its fan centre; any other is
    split into its ear triangles, each around its centroid."""
    a, b = mesh.interior_node[chosen, 0], mesh.interior_node[chosen, 1]
    fan = chosen[a == b]
    ears = chosen[a != b]
    N = np.diff(mesh.offsets)[fan]
    fan_vertices = mesh.vertices[concatenated_ranges(mesh.offsets[fan], N)]
    n_tri = np.diff(mesh.triangle_offsets)[ears]
    triangles = mesh.triangles[concatenated_ranges(mesh.triangle_offsets[ears], n_tri)]
    sizes = np.concatenate([N, np.full(triangles.shape[0], 3)])
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    vertices = np.concatenate([fan_vertices, triangles.ravel()]).astype(np.int64)
    centres = np.vstack([mesh.nodes[mesh.interior_node[fan, 0]], mesh.points[triangles].mean(axis=1)])
    polygon = np.concatenate([fan, np.repeat(ears, n_tri)]).astype(np.int64)
    return offsets, vertices, centres, polygon


def _split_once(mesh: Polygons, selected: npt.NDArray[np.bool_]
                ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int64],
                           npt.NDArray[np.int64], npt.NDArray[np.bool_]]:
    """One refinement level: (points, offsets, vertices, parent, is_child) of the new polygons.

    Points of ``mesh`` keep their index; edge midpoints and then piece centres are appended.
    ``is_child`` marks the polygons cut from selected ones (the others are the unselected
    polygons, with the midpoints of their split edges inserted)."""
    n, x = mesh.n_points, mesh.points
    offsets, vertices, centres, polygon = _pieces(mesh, np.flatnonzero(selected))
    nxt, prev = next_entries(offsets), previous_entries(offsets)
    split, first, midpoint_of_entry = np.unique(edge_key(vertices, vertices[nxt], n), return_index=True,
                                                return_inverse=True)
    midpoint_of_entry = n + midpoint_of_entry.reshape(-1)
    midpoints = 0.5 * (x[vertices[first]] + x[vertices[nxt[first]]])
    centre_of_piece = n + split.size + np.arange(centres.shape[0])
    # quad [c, m_{i-1}, v_i, m_i] for every piece entry i; at a reflex vertex the two
    # triangles [c, m_{i-1}, v_i], [c, v_i, m_i] instead (no darts)
    piece = np.repeat(np.arange(offsets.size - 1), np.diff(offsets))
    d_in, d_out = x[vertices] - x[vertices[prev]], x[vertices[nxt]] - x[vertices]
    reflex = (d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
              < -RTOL * np.hypot(*d_in.T) * np.hypot(*d_out.T))        # collinear (hanging) vertices are not
    c, m_prev, v, m = centre_of_piece[piece], midpoint_of_entry[prev], vertices, midpoint_of_entry
    children = [np.column_stack([c, m_prev, v, m])[~reflex], np.column_stack([c, m_prev, v])[reflex],
                np.column_stack([c, v, m])[reflex]]
    child_polygon = np.concatenate([polygon[piece][~reflex], polygon[piece][reflex], polygon[piece][reflex]])
    child_sizes = np.concatenate([np.full(k.shape[0], k.shape[1]) for k in children])

    # unselected polygons: insert the midpoint of every split edge after its start vertex
    kept = np.flatnonzero(~selected)
    kept_sides = concatenated_ranges(mesh.offsets[kept], np.diff(mesh.offsets)[kept])
    key = edge_key(mesh.sides.start[kept_sides], mesh.sides.end[kept_sides], n)
    pos = np.minimum(np.searchsorted(split, key), split.size - 1)
    hit = split[pos] == key
    kept_vertices = np.insert(mesh.vertices[kept_sides], np.flatnonzero(hit) + 1, n + pos[hit])
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
    new_vertices = flat[concatenated_ranges(start[order], sizes[order])]
    is_child = np.concatenate([np.zeros(kept.size, dtype=bool), np.ones(child_polygon.size, dtype=bool)])[order]
    points = np.vstack([mesh.points, midpoints, centres])
    return points, new_offsets, new_vertices, parent[order], is_child


def split_level(mesh: Polygons, chosen: npt.NDArray[np.bool_], max_l: int
                ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int64],
                           npt.NDArray[np.int64], npt.NDArray[np.bool_]]:
    """One refinement level of the ``chosen`` polygons (mask (n_polygons,), extended in place),
    closed: a neighbour whose new hanging nodes would need a projection order l > ``max_l`` (the
    rank check of docs/method.md §3) is chosen too, until no polygon needs more.

    Returns
    -------
    points : (n_new_points, 2)
        The points of ``mesh`` (same indices), then edge midpoints and piece centres.
    offsets, vertices
        The new polygons (CSR, counter-clockwise), ordered by parent.
    parent : int64
        The polygon of ``mesh`` containing each new polygon.
    is_child : bool
        The new polygons cut from chosen ones (the others are unchosen polygons, with the
        midpoints of their split edges inserted).
    """
    while True:
        points, offsets, vertices, parent, is_child = _split_once(mesh, chosen)
        gained = np.flatnonzero(~is_child & (np.diff(offsets) > np.diff(mesh.offsets)[parent]))
        beyond = gained[without_sufficient_order(points, offsets, vertices, gained, 3, max_l)]
        if beyond.size == 0:
            return points, offsets, vertices, parent, is_child
        chosen[parent[beyond]] = True
