"""Collapse of the short edges of a mesh of polyhedra with planar faces (the cleaning of
:func:`~dolfinx_sfvem.meshing.voronoi.voronoi_box`).

Nearly cospherical seeds give Voronoi vertices nearly coincident: edges of 1e-5 of the cell's
diameter, faces of 1e-11 of its squared diameter, on which the element's rank test fails or its
projections are ill-conditioned. Here every edge
shorter than ``min_edge`` times the diameter of a cell holding it is collapsed:

1. the clusters of points joined by short edges are merged into one point each, kept where one of
   them is (the one on the most planes of the box, so that box faces stay on the box; its
   coordinates then set to every box plane that a point of the cluster lies on);
2. every face is renumbered with the merged points, consecutive repeats dropped: a face left with
   fewer than 3 vertices disappears from its cells (both cells see the same stored face, so a
   shared face stays identical in both);
3. a merged point moves the faces that held another point of its cluster off their planes (a
   Voronoi vertex is equidistant from 4 seeds, a merged one would have to be from 5 or more, so no
   position keeps every face planar: the off-plane distance is up to the merged edge's length, a
   relative non-planarity up to ``min_edge``, where PolyhedronMesh accepts 1e-8 and the element's
   face projections, computed in the face's plane, need the face flat). Such a face is split into
   flat pieces: every piece holding a vertex off the face's plane is a triangle with apex there
   (the ear at the vertex, or two triangles through a vertex across the face, whichever has the
   larger smallest triangle); the rest keeps the face's plane. The cells become slightly
   non-convex across the cut (two faces at an angle of about 180 degrees);
4. faces with the same vertex set stored once; a cell holding one face twice (a pocket of no
   volume) loses both;

repeated until no edge is short (a cut adds a diagonal that may itself be short). Points on the
box's planes are compared exactly (the caller puts them on the planes).
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from dolfinx_sfvem.mesh.csr import concatenated_ranges, segment_owner
from dolfinx_sfvem.mesh.polyhedron_mesh import _relative_orientation, _vertex_sets

#: a vertex farther than this times its face's size from the face's plane is cut off (a tenth of
#: PolyhedronMesh's planarity tolerance)
OFF_PLANE_RTOL = 1e-9


@numba.njit(cache=True)
def cell_diameters(points, face_offsets, face_vertices, cell_offsets, cell_faces):
    """Largest distance between two vertices of every cell, (n_cells,)."""
    n_c = cell_offsets.size - 1
    out = np.zeros(n_c)
    for c in range(n_c):
        m = 0
        for k in range(cell_offsets[c], cell_offsets[c + 1]):
            m += face_offsets[cell_faces[k] + 1] - face_offsets[cell_faces[k]]
        vertices = np.empty(m, dtype=np.int64)
        m = 0
        for k in range(cell_offsets[c], cell_offsets[c + 1]):
            for i in range(face_offsets[cell_faces[k]], face_offsets[cell_faces[k] + 1]):
                vertices[m] = face_vertices[i]
                m += 1
        vertices = np.unique(vertices)
        for i in range(vertices.size):
            for j in range(i + 1, vertices.size):
                out[c] = max(out[c], np.sqrt(((points[vertices[i]] - points[vertices[j]]) ** 2).sum()))
    return out


def _next_in_face(offsets: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Index of the cyclically next entry of every entry of a CSR array of faces."""
    nxt = np.arange(1, offsets[-1] + 1)
    nxt[offsets[1:] - 1] = offsets[:-1]
    return nxt


@dataclass
class _Faces:
    """The faces (CSR of point indices, cyclic), the plane of each (unit normal (n_faces, 3), offset
    n . x (n_faces,)), and the cells' faces as (cell, face, sign) entries (k,) each."""

    offsets: np.ndarray
    vertices: np.ndarray
    normals: np.ndarray
    levels: np.ndarray
    cell: np.ndarray
    face: np.ndarray
    sign: np.ndarray

    def cell_csr(self, n_cells: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cell offsets (n_cells + 1,), cell faces and signs in PolyhedronMesh's form."""
        order = np.lexsort((self.face, self.cell))
        offsets = np.concatenate([[0], np.cumsum(np.bincount(self.cell, minlength=n_cells))]).astype(np.int64)
        return offsets, self.face[order], self.sign[order]


def _short_edges(points, faces: _Faces, n_cells: int, min_edge: float) -> npt.NDArray[np.int64]:
    """The (k, 2) face sides shorter than ``min_edge`` times the diameter of a cell of their face."""
    cell_offsets, cell_faces, _ = faces.cell_csr(n_cells)
    diameter = cell_diameters(points, faces.offsets, faces.vertices, cell_offsets, cell_faces)
    face_size = np.zeros(faces.offsets.size - 1)
    np.maximum.at(face_size, faces.face, diameter[faces.cell])
    a, b = faces.vertices, faces.vertices[_next_in_face(faces.offsets)]
    length = np.linalg.norm(points[a] - points[b], axis=1)
    short = length < min_edge * face_size[segment_owner(faces.offsets)]
    return np.column_stack([a[short], b[short]])


def _merge(points, short, lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """Cluster label of every point (clusters: connected by short edges) and the merged point of
    every cluster (module docstring, step 1)."""
    n = points.shape[0]
    graph = coo_matrix((np.ones(short.shape[0]), (short[:, 0], short[:, 1])), shape=(n, n))
    n_clusters, label = connected_components(graph, directed=False)
    on_plane = [(d, bound[d], points[:, d] == bound[d]) for d in range(3) for bound in (lower, upper)]
    count = sum(on for _, _, on in on_plane)
    order = np.lexsort((-count, label))
    _, first = np.unique(label[order], return_index=True)
    merged = points[order[first]].copy()
    for d, value, on in on_plane:
        merged[np.bincount(label[on], minlength=n_clusters) > 0, d] = value
    return label, merged


def _renumber(faces: _Faces, label) -> _Faces:
    """The faces in the merged points, consecutive repeats dropped, faces of fewer than 3 vertices
    removed from their cells (step 2)."""
    vertices = label[faces.vertices]
    keep = vertices != vertices[_next_in_face(faces.offsets)]
    owner = segment_owner(faces.offsets)[keep]
    sizes = np.bincount(owner, minlength=faces.offsets.size - 1)
    alive = sizes >= 3
    number = np.cumsum(alive) - 1
    vertices = vertices[keep]
    entries = alive[owner]
    pinched = np.unique(np.column_stack([owner[entries], vertices[entries]]), axis=0).shape[0] != entries.sum()
    if pinched:
        raise ValueError("voronoi_box: collapsing the short edges pinches a face (two of its vertices that are not "
                         "neighbours merged): choose a smaller min_edge")
    used = alive[faces.face]
    return _Faces(np.concatenate([[0], np.cumsum(sizes[alive])]).astype(np.int64), vertices[entries],
                  faces.normals[alive], faces.levels[alive], faces.cell[used], number[faces.face[used]],
                  faces.sign[used])


def _smallest_area(points, triangles) -> float:
    """Twice the smallest area of the triangles (list of 3 point indices each)."""
    x = points[np.asarray(triangles)]                                         # (k, 3, 3)
    return float(np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1).min())


def _plane(points, polygon: list) -> tuple[np.ndarray, float]:
    """Unit normal (Newell's) and offset n . x of the plane of a planar polygon."""
    x = points[np.asarray(polygon)]
    normal = np.cross(x, np.roll(x, -1, axis=0)).sum(axis=0)
    normal /= np.linalg.norm(normal)
    return normal, float(normal @ x.mean(axis=0))


def _flatten(points, polygon: list, off: list) -> list:
    """Planar pieces of the polygon (cyclic point indices, ``off`` True at the vertices off its plane):
    every piece holding an off-plane vertex v is a triangle with apex v, either the ear
    (previous, v, next) or the pair (previous, v, y), (v, next, y) through a vertex y across the
    polygon, whichever has the larger smallest triangle (the ear of a vertex with an angle near 180
    degrees is a needle, one next to a short side a sliver; small faces are what the element cannot
    see); the rest are polygons of on-plane vertices, split again if needed."""
    n = len(polygon)
    if n <= 3 or not any(off):
        return [polygon] if n >= 3 else []
    i = off.index(True)
    polygon, off = polygon[i:] + polygon[:i], off[i:] + off[:i]              # v first
    v, after, before = polygon[0], polygon[1], polygon[-1]
    best, split = _smallest_area(points, [[before, v, after]]), None
    for j in range(2, n - 1):                                                # y = polygon[j]
        area = _smallest_area(points, [[before, v, polygon[j]], [v, after, polygon[j]]])
        if area > best:
            best, split = area, j
    if split is None:
        return [[before, v, after]] + _flatten(points, polygon[1:], off[1:])
    y = polygon[split]
    return ([[before, v, y], [v, after, y]] + _flatten(points, polygon[1:split + 1], off[1:split + 1])
            + _flatten(points, polygon[split:], off[split:]))


def _flatten_faces(points, faces: _Faces) -> _Faces:
    """Every face planar: the faces with a vertex off their plane replaced by their flat pieces
    (step 3, :func:`_flatten`), appended after the other faces, in the cells of their face with
    its sign."""
    owner = segment_owner(faces.offsets)
    x = points[faces.vertices]
    distance = np.abs(np.einsum("ij,ij->i", x, faces.normals[owner]) - faces.levels[owner])
    size = np.maximum.reduceat(np.linalg.norm(x - x[faces.offsets[:-1]][owner], axis=1), faces.offsets[:-1])
    off = distance > OFF_PLANE_RTOL * size[owner]
    sizes = np.diff(faces.offsets)
    bent = np.flatnonzero((np.bincount(owner, weights=off, minlength=sizes.size) > 0) & (sizes > 3))
    if bent.size == 0:
        return faces
    pieces, parents = [], []
    for f in bent:
        s, e = faces.offsets[f], faces.offsets[f + 1]
        flat = _flatten(points, faces.vertices[s:e].tolist(), off[s:e].tolist())
        pieces += flat
        parents += [f] * len(flat)
    planes = [_plane(points, piece) for piece in pieces]
    kept = np.ones(sizes.size, dtype=bool)
    kept[bent] = False
    number = np.cumsum(kept) - 1
    # the cells' entries of the kept faces renumbered, those of a bent face once per piece
    order = np.argsort(faces.face, kind="stable")
    start = np.searchsorted(faces.face[order], parents, "left")
    count = np.searchsorted(faces.face[order], parents, "right") - start
    entries = order[concatenated_ranges(start, count)]
    stays = kept[faces.face]
    return _Faces(np.concatenate([[0], np.cumsum(np.concatenate([sizes[kept], [len(p) for p in pieces]]))]),
                  np.concatenate([faces.vertices[kept[owner]], np.concatenate(pieces)]).astype(np.int64),
                  np.vstack([faces.normals[kept], [n for n, _ in planes]]),
                  np.concatenate([faces.levels[kept], [c for _, c in planes]]),
                  np.concatenate([faces.cell[stays], faces.cell[entries]]),
                  np.concatenate([number[faces.face[stays]], np.repeat(kept.sum() + np.arange(len(pieces)), count)]),
                  np.concatenate([faces.sign[stays], faces.sign[entries]]))


def _merge_duplicates(faces: _Faces) -> _Faces:
    """Faces with the same vertex set stored once (a piece of a split face may be a face already
    there); a cell holding one face twice, once each way, has a pocket of no volume there and loses
    both (step 4)."""
    _, first, inverse = np.unique(_vertex_sets(faces.offsets, faces.vertices), axis=0, return_index=True,
                                  return_inverse=True)
    stored = first[inverse.reshape(-1)]
    if np.all(stored == np.arange(stored.size)):
        return faces
    face = stored[faces.face]
    sign = faces.sign * _relative_orientation(faces.offsets, faces.vertices, face, faces.face)
    key = faces.cell * stored.size + face
    unique, inverse, count = np.unique(key, return_inverse=True, return_counts=True)
    total = np.bincount(inverse, weights=sign)
    if np.any((count > 2) | ((count == 2) & (total != 0))):
        raise ValueError("voronoi_box: collapsing the short edges makes a cell hold a face twice the same way: "
                         "choose a smaller min_edge")
    keep = count[inverse] == 1
    alive = np.zeros(stored.size, dtype=bool)
    alive[face[keep]] = True
    number = np.cumsum(alive) - 1
    sizes = np.diff(faces.offsets)[alive]
    return _Faces(np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
                  faces.vertices[concatenated_ranges(faces.offsets[:-1][alive], sizes)], faces.normals[alive],
                  faces.levels[alive], faces.cell[keep], number[face[keep]], sign[keep])


def collapse_short_edges(points: npt.NDArray[np.float64], face_offsets: npt.NDArray[np.int64],
                         face_vertices: npt.NDArray[np.int64], face_normals: npt.NDArray[np.float64],
                         face_levels: npt.NDArray[np.float64], cell_offsets: npt.NDArray[np.int64],
                         cell_faces: npt.NDArray[np.int64], cell_face_signs: npt.NDArray[np.int64],
                         lower: npt.NDArray[np.float64], upper: npt.NDArray[np.float64], min_edge: float,
                         max_rounds: int = 10) -> tuple[np.ndarray, ...]:
    """The mesh with no edge shorter than ``min_edge`` times the diameter of a cell holding it
    (module docstring).

    Parameters
    ----------
    points : (n_points, 3) float64
        Points on the box's planes exactly on them.
    face_offsets, face_vertices : int64
        CSR of the faces (each stored once, cyclic order).
    face_normals : (n_faces, 3) float64
        Unit normal of every face's plane; ``face_levels`` (n_faces,) its offset n . x on the plane.
    cell_offsets, cell_faces, cell_face_signs : int64
        CSR of the cells' faces with their signs (as in PolyhedronMesh).
    lower, upper : (3,) float64
        The box: a point on one of its planes stays on it.
    min_edge : float
        Relative length (> 0) below which an edge is collapsed.
    max_rounds : int
        Collapse rounds before giving up.

    Returns
    -------
    points, face_offsets, face_vertices, cell_offsets, cell_faces, cell_face_signs
        The cleaned mesh (only the points used; cells in the same order).

    Raises
    ------
    ValueError
        A face pinched by the collapse, or short edges left after ``max_rounds`` rounds.
    """
    n_cells = cell_offsets.size - 1
    owner = segment_owner(cell_offsets)
    faces = _Faces(face_offsets, face_vertices, face_normals, face_levels, owner, cell_faces, cell_face_signs)
    for _ in range(max_rounds):
        short = _short_edges(points, faces, n_cells, min_edge)
        if short.shape[0] == 0:
            used, vertices = np.unique(faces.vertices, return_inverse=True)
            return (points[used], faces.offsets, vertices.reshape(-1).astype(np.int64), *faces.cell_csr(n_cells))
        label, points = _merge(points, short, lower, upper)
        faces = _merge_duplicates(_flatten_faces(points, _renumber(faces, label)))
    raise ValueError(f"voronoi_box: edges shorter than {min_edge} of their cell's diameter remain after "
                     f"{max_rounds} rounds of collapse")
