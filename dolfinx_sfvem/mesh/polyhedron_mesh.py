"""Polyhedral meshes: storage, validation and queries (the meshes of the coming 3D SFVEM).

A :class:`PolyhedronMesh` holds points, the global faces (each stored once, CSR of vertex
indices in cyclic order), the faces of every cell (CSR of face indices with a sign: +1 if the
stored face's normal, by the right-hand rule, points out of the cell, -1 if into it) and one
region tag per cell. Faces are planar polygons and may have collinear vertices: the hanging
vertices of an octree (a coarse cube's face split into the faces of its finer neighbours, a
midpoint on a face's edge). :meth:`PolyhedronMesh.polyhedron` gives one cell as the element's
input (the ``points, faces`` of :mod:`~dolfinx_sfvem.mesh.polyhedron`): its points and its
faces in local indices, every face oriented out of the cell.

Validation (construction), each failure a ``ValueError`` naming the cell and the defect:

- the arrays: shapes, index ranges, offsets, signs of +-1, at least 4 faces per cell, no face
  listed twice in a cell;
- every face: at least 3 vertices, none repeated, nonzero area, planar (every vertex within
  ``planar_rtol`` times the face's diameter of the plane through its centroid normal to its
  area vector), not self-intersecting; no two faces with the same vertex set;
- every face in one or two cells, with opposite signs in two (the cells lie on either side);
- every cell closed and consistently oriented: each of its edges in exactly two of its faces,
  once in each direction (a flipped face runs an edge the same way as its neighbour; an open
  cell has an edge in one face only);
- every cell of positive volume (faces pointing out; a cell whose faces all point in has a
  negative volume);
- the mesh conforming: no point of a boundary face lies on another boundary face without being
  one of its vertices (a face not split like the faces facing it, a hanging vertex missing on one
  side, or two cells touching along distinct coincident points put a point there).

Not checked: self-intersecting cells, cells overlapping without sharing a face or touching the
boundary.

Tolerance: ``tol = RTOL * d`` with ``d`` the diagonal of the bounding box of the used points
(``RTOL`` of :mod:`dolfinx_sfvem.mesh.polygon`); a face of area at most ``tol`` times its diameter, a
cell of volume at most ``tol`` times its squared diameter are degenerate.

The face and cell loops are compiled (numba): validating 10^5 cells takes 1-2 s.
"""
from __future__ import annotations

from collections.abc import Mapping

import numba
import numpy as np
import numpy.typing as npt

from dolfinx_sfvem.mesh.cell_mesh import TOLERANCE, CellMesh, facet_normals, note_flat, reference_facets
from scipy.spatial import cKDTree

from dolfinx_sfvem.mesh.polygon import RTOL, point_location, self_intersection
from dolfinx_sfvem.mesh.polygon_mesh import as_points
from dolfinx_sfvem.mesh.csr import concatenated_ranges, segment_owner

#: default relative planarity tolerance of a face (of its diameter)
PLANAR_RTOL = 1e-8

# status codes of the face and cell kernels
_OK, _FEW_VERTICES, _REPEATED, _ZERO_AREA, _NOT_PLANAR, _SELF_INTERSECTING = 0, 1, 2, 3, 4, 12
_FEW_FACES, _FACE_TWICE, _SAME_DIRECTION, _OPEN, _NON_MANIFOLD, _ZERO_VOLUME, _NEGATIVE_VOLUME = 5, 6, 7, 8, 9, 10, 11


# --------------------------------------------------------------------------- compiled kernels
@numba.njit(cache=True, inline="always")
def _cross_dot(a0, a1, a2, b0, b1, b2, c0, c1, c2):
    """(a x b) . c of 3-vectors given by components."""
    return (a1 * b2 - a2 * b1) * c0 + (a2 * b0 - a0 * b2) * c1 + (a0 * b1 - a1 * b0) * c2


@numba.njit(cache=True, inline="always")
def _distance(points, a, b):
    """Distance between points a and b."""
    return np.sqrt((points[a, 0] - points[b, 0]) ** 2 + (points[a, 1] - points[b, 1]) ** 2
                   + (points[a, 2] - points[b, 2]) ** 2)


@numba.njit(cache=True)
def plane_coordinates(points, vertices, origin, normal):
    """Coordinates (n, 2) of the points ``vertices`` in an orthonormal basis (u, v) of the plane
    through ``origin`` normal to the unit vector ``normal``, u x v = normal (counter-clockwise
    seen from the side the normal points to)."""
    k = np.argmin(np.abs(normal))
    e = np.zeros(3)
    e[k] = 1.0
    u = np.cross(e, normal)
    u /= np.sqrt((u ** 2).sum())
    v = np.cross(normal, u)
    xy = np.empty((vertices.size, 2))
    for i in range(vertices.size):
        d = points[vertices[i]] - origin
        xy[i, 0], xy[i, 1] = d @ u, d @ v
    return xy


@numba.njit(cache=True)
def _face_geometry(points, offsets, vertices, tol, planar_rtol):
    """Area vectors (n_f, 3) (right-hand rule, length = area) and centroids (n_f, 3) of the faces,
    and the first failure (code, face, detail) or (_OK, -1, 0): _FEW_VERTICES, _REPEATED (vertex),
    _ZERO_AREA, _NOT_PLANAR (local vertex farthest off the plane), _SELF_INTERSECTING (local side).

    Fan from the vertex mean m: triangle i (m, x_i, x_{i+1}) has the area vector
    a_i = (x_i - m) x (x_{i+1} - m) / 2; A = sum a_i, centroid sum (a_i . n)(m + x_i + x_{i+1}) / 3 / |A|."""
    n_f = offsets.size - 1
    area_vectors = np.zeros((n_f, 3))
    centroids = np.zeros((n_f, 3))
    for f in range(n_f):
        s, e = offsets[f], offsets[f + 1]
        n = e - s
        if n < 3:
            return area_vectors, centroids, _FEW_VERTICES, f, n
        for i in range(s, e):
            for j in range(i + 1, e):
                if vertices[i] == vertices[j]:
                    return area_vectors, centroids, _REPEATED, f, vertices[i]
        m = np.zeros(3)
        diam = 0.0
        for i in range(s, e):
            for d in range(3):
                m[d] += points[vertices[i], d] / n
            for j in range(i + 1, e):
                diam = max(diam, _distance(points, vertices[i], vertices[j]))
        for i in range(s, e):
            p, q = points[vertices[i]], points[vertices[i + 1 if i + 1 < e else s]]
            u0, u1, u2, v0, v1, v2 = p[0] - m[0], p[1] - m[1], p[2] - m[2], q[0] - m[0], q[1] - m[1], q[2] - m[2]
            area_vectors[f, 0] += 0.5 * (u1 * v2 - u2 * v1)
            area_vectors[f, 1] += 0.5 * (u2 * v0 - u0 * v2)
            area_vectors[f, 2] += 0.5 * (u0 * v1 - u1 * v0)
        area = np.sqrt((area_vectors[f] ** 2).sum())
        if area <= tol * diam:
            return area_vectors, centroids, _ZERO_AREA, f, 0
        n0, n1, n2 = area_vectors[f, 0] / area, area_vectors[f, 1] / area, area_vectors[f, 2] / area
        for i in range(s, e):
            p, q = points[vertices[i]], points[vertices[i + 1 if i + 1 < e else s]]
            w = 0.5 * _cross_dot(p[0] - m[0], p[1] - m[1], p[2] - m[2], q[0] - m[0], q[1] - m[1], q[2] - m[2],
                                 n0, n1, n2) / area
            for d in range(3):
                centroids[f, d] += w * (m[d] + p[d] + q[d]) / 3.0
        worst, k = 0.0, 0
        for i in range(s, e):
            p = points[vertices[i]]
            dist = abs((p[0] - centroids[f, 0]) * n0 + (p[1] - centroids[f, 1]) * n1 + (p[2] - centroids[f, 2]) * n2)
            if dist > worst:
                worst, k = dist, i - s
        if worst > planar_rtol * diam + tol:
            return area_vectors, centroids, _NOT_PLANAR, f, k
        i, _ = self_intersection(plane_coordinates(points, vertices[s:e], centroids[f], area_vectors[f] / area), tol)
        if i >= 0:
            return area_vectors, centroids, _SELF_INTERSECTING, f, i
    return area_vectors, centroids, _OK, -1, 0


@numba.njit(cache=True)
def _cell_geometry(points, face_offsets, face_vertices, cell_offsets, cell_faces, signs,
                   face_area_vectors, face_centroids, tol):
    """Volumes (n_c,) and centroids (n_c, 3) of the cells, and the first failure
    (code, cell, a, b) or (_OK, -1, 0, 0): _FEW_FACES, _FACE_TWICE (face a), _SAME_DIRECTION,
    _OPEN, _NON_MANIFOLD (edge (a, b)), _ZERO_VOLUME, _NEGATIVE_VOLUME.

    The volume is (1/3) sum_f sign_f (c_f - x_0) . A_f (divergence theorem, x_0 the cell's first
    vertex); the centroid that of the signed tetrahedra (x_0, c_f, v_i, v_{i+1}) over every
    oriented side (v_i, v_{i+1}) of every face (exact for planar faces, any shape)."""
    n_c = cell_offsets.size - 1
    volumes = np.zeros(n_c)
    centroids = np.zeros((n_c, 3))
    size = 0
    for c in range(n_c):
        m = 0
        for k in range(cell_offsets[c], cell_offsets[c + 1]):
            m += face_offsets[cell_faces[k] + 1] - face_offsets[cell_faces[k]]
        size = max(size, m)
    start = np.empty(size, dtype=np.int64)
    end = np.empty(size, dtype=np.int64)
    for c in range(n_c):
        s, e = cell_offsets[c], cell_offsets[c + 1]
        if e - s < 4:
            return volumes, centroids, _FEW_FACES, c, e - s, 0
        for k in range(s, e):
            for k2 in range(k + 1, e):
                if cell_faces[k] == cell_faces[k2]:
                    return volumes, centroids, _FACE_TWICE, c, cell_faces[k], 0
        m = 0
        for k in range(s, e):
            f = cell_faces[k]
            fs, fe = face_offsets[f], face_offsets[f + 1]
            for i in range(fs, fe):
                a, b = face_vertices[i], face_vertices[i + 1 if i + 1 < fe else fs]
                if signs[k] < 0:
                    a, b = b, a
                start[m], end[m] = a, b
                m += 1
        for i in range(m):
            same, reverse = 0, 0
            for j in range(m):
                if start[j] == start[i] and end[j] == end[i]:
                    same += 1
                elif start[j] == end[i] and end[j] == start[i]:
                    reverse += 1
            if same > 1:
                return volumes, centroids, _SAME_DIRECTION, c, start[i], end[i]
            if reverse == 0:
                return volumes, centroids, _OPEN, c, start[i], end[i]
            if reverse > 1:
                return volumes, centroids, _NON_MANIFOLD, c, start[i], end[i]
        x0 = points[start[0]]
        diam = 0.0
        for i in range(m):
            diam = max(diam, _distance(points, start[0], start[i]))
        m = 0
        cx, cy, cz = 0.0, 0.0, 0.0
        for k in range(s, e):
            f = cell_faces[k]
            f0, f1, f2 = face_centroids[f, 0] - x0[0], face_centroids[f, 1] - x0[1], face_centroids[f, 2] - x0[2]
            volumes[c] += signs[k] * (f0 * face_area_vectors[f, 0] + f1 * face_area_vectors[f, 1]
                                      + f2 * face_area_vectors[f, 2]) / 3.0
            for i in range(face_offsets[f], face_offsets[f + 1]):
                a, b = points[start[m]], points[end[m]]
                a0, a1, a2, b0, b1, b2 = a[0] - x0[0], a[1] - x0[1], a[2] - x0[2], b[0] - x0[0], b[1] - x0[1], b[2] - x0[2]
                v = _cross_dot(a0, a1, a2, b0, b1, b2, f0, f1, f2) / 24.0
                cx += v * (f0 + a0 + b0)
                cy += v * (f1 + a1 + b1)
                cz += v * (f2 + a2 + b2)
                m += 1
        if abs(volumes[c]) <= tol * diam * diam:
            return volumes, centroids, _ZERO_VOLUME, c, 0, 0
        if volumes[c] < 0.0:
            return volumes, centroids, _NEGATIVE_VOLUME, c, 0, 0
        centroids[c, 0] = x0[0] + cx / volumes[c]
        centroids[c, 1] = x0[1] + cy / volumes[c]
        centroids[c, 2] = x0[2] + cz / volumes[c]
    return volumes, centroids, _OK, -1, 0, 0


@numba.njit(cache=True)
def _points_on_faces(points, offsets, vertices, area_vectors, centroids, point, face, tol):
    """Mask over the pairs (point[k], face[k]): the point lies on the closed face (within ``tol``
    of its plane and of its polygon) and is not one of its vertices."""
    out = np.zeros(point.size, dtype=np.bool_)
    for k in range(point.size):
        f, p = face[k], point[k]
        verts = vertices[offsets[f]:offsets[f + 1]]
        if np.any(verts == p):
            continue
        normal = area_vectors[f] / np.sqrt((area_vectors[f] ** 2).sum())
        if abs((points[p] - centroids[f]) @ normal) > tol:
            continue
        xy = plane_coordinates(points, np.append(verts, p), centroids[f], normal)
        out[k] = point_location(xy[-1], xy[:-1], tol) >= 0
    return out


@numba.njit(cache=True)
def _relative_orientation(offsets, vertices, stored, faces):
    """+1 where local face ``faces[k]`` runs through its vertices in the cyclic order of the face
    ``stored[k]`` (same vertex set), -1 where in the reverse order, 0 where in neither."""
    out = np.zeros(faces.size, dtype=np.int64)
    for k in range(faces.size):
        a = vertices[offsets[stored[k]]:offsets[stored[k] + 1]]
        b = vertices[offsets[faces[k]]:offsets[faces[k] + 1]]
        n = a.size
        shift = 0
        while b[shift] != a[0]:
            shift += 1
        forward, backward = True, True
        for i in range(n):
            forward = forward and b[(shift + i) % n] == a[i]
            backward = backward and b[(shift - i) % n] == a[i]
        out[k] = 1 if forward else (-1 if backward else 0)
    return out


# --------------------------------------------------------------------------- input conversion
def _as_index_csr(offsets: npt.ArrayLike, values: npt.ArrayLike, n_range: int, what: str, item: str
                  ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Offsets and values of a CSR array as int64, checked: offsets start at 0, never decrease,
    end at len(values); values in [0, n_range)."""
    offsets = np.asarray(offsets)
    values = np.asarray(values)
    for name, a in (("offsets", offsets), ("values", values)):
        if a.ndim != 1 or (a.size and a.dtype.kind not in "iu"):
            raise ValueError(f"{what} {name} must be a 1D integer array, got shape {a.shape} and dtype {a.dtype}")
    offsets, values = offsets.astype(np.int64), values.astype(np.int64)
    if offsets.size < 2 or offsets[0] != 0 or offsets[-1] != values.size or np.any(np.diff(offsets) < 0):
        raise ValueError(f"{what} offsets must start at 0, never decrease and end at {values.size} "
                         f"(the number of {item} entries), with at least one {what[:-1]}")
    bad = np.flatnonzero((values < 0) | (values >= n_range))
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"{what[:-1]} {int(np.searchsorted(offsets, k, 'right') - 1)}: {item} index "
                         f"{values[k]} out of range [0, {n_range})")
    return offsets, values


def _vertex_sets(offsets: npt.NDArray[np.int64], vertices: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Every face's sorted vertex indices padded with -1: (n_faces, max face size), equal rows for
    faces with the same vertex set."""
    sizes = np.diff(offsets)
    keys = np.full((sizes.size, int(sizes.max())), -1, dtype=np.int64)
    owner = segment_owner(offsets)
    order = np.lexsort((vertices, owner))
    keys[owner, np.arange(vertices.size) - offsets[owner]] = vertices[order]
    return keys


# --------------------------------------------------------------------------- the mesh
class PolyhedronMesh:
    """A validated mesh of polyhedra with planar polygonal faces (module docstring).

    Parameters
    ----------
    points : (n_points, 3) array_like of float
    face_offsets : (n_faces + 1,) array_like of int
        Face ``f`` has the vertices ``face_vertices[face_offsets[f]:face_offsets[f + 1]]``.
    face_vertices : array_like of int
        Point indices, each face's in cyclic order; each face stored once.
    cell_offsets : (n_cells + 1,) array_like of int
        Cell ``c`` has the faces ``cell_faces[cell_offsets[c]:cell_offsets[c + 1]]``.
    cell_faces : array_like of int
        Face indices.
    cell_face_signs : array_like of int, same length as ``cell_faces``
        +1 if the stored face's normal (right-hand rule) points out of the cell, -1 if into it.
    tags : (n_cells,) array_like of int, optional
        Region tag of every cell (default 0).
    region_names : mapping str -> int, optional
        Names of region tags (every tag named must be carried by a cell).
    planar_rtol : float
        Planarity tolerance of a face, relative to its diameter.

    Attributes
    ----------
    gdim : int
        The dimension of the points: 3.
    points, face_offsets, face_vertices, cell_offsets, cell_faces, cell_face_signs, tags, region_names
        As given (int64 arrays, ``tags`` int64).
    tol : float
        Absolute length tolerance (``RTOL`` times the bounding-box diagonal of the used points).
    face_area_vectors : (n_faces, 3) float64
        Area times unit normal (right-hand rule) of every stored face.
    face_centroids : (n_faces, 3) float64
    volumes : (n_cells,) float64
    centroids : (n_cells, 3) float64

    Raises
    ------
    ValueError
        Naming the cell and the defect (module docstring).
    """

    gdim = 3

    def __init__(self, points: npt.ArrayLike, face_offsets: npt.ArrayLike, face_vertices: npt.ArrayLike,
                 cell_offsets: npt.ArrayLike, cell_faces: npt.ArrayLike, cell_face_signs: npt.ArrayLike,
                 tags: npt.ArrayLike | None = None, region_names: Mapping[str, int] | None = None, *,
                 planar_rtol: float = PLANAR_RTOL) -> None:
        self.points = as_points(points, 3)
        self.face_offsets, self.face_vertices = _as_index_csr(face_offsets, face_vertices, self.n_points,
                                                              "faces", "point")
        self.cell_offsets, self.cell_faces = _as_index_csr(cell_offsets, cell_faces, self.n_faces, "cells", "face")
        signs = np.asarray(cell_face_signs)
        if signs.shape != self.cell_faces.shape or not np.all(np.abs(signs) == 1):
            raise ValueError(f"cell_face_signs must hold +1 or -1 for each of the {self.cell_faces.size} "
                             f"entries of cell_faces")
        self.cell_face_signs = signs.astype(np.int64)
        self.tags = np.zeros(self.n_cells, np.int64) if tags is None else np.asarray(tags, dtype=np.int64).reshape(-1)
        if self.tags.shape != (self.n_cells,):
            raise ValueError(f"one tag per cell expected: {self.tags.size} tags for {self.n_cells} cells")
        self.region_names = {str(k): int(v) for k, v in (region_names or {}).items()}
        unknown = {k: v for k, v in self.region_names.items() if not np.any(self.tags == v)}
        if unknown:
            raise ValueError(f"region names {unknown} name tags that no cell has")
        used = self.points[np.unique(self.face_vertices)]
        self.tol = RTOL * float(np.linalg.norm(used.max(axis=0) - used.min(axis=0)))
        self._check_face_use()
        self._check_faces(planar_rtol)
        self._check_cells()
        self._check_conforming()

    # ----------------------------------------------------------------------- validation steps
    def _cell_of_face(self) -> npt.NDArray[np.int64]:
        """The lowest cell holding each face (n_faces,), -1 for a face of no cell."""
        first = np.full(self.n_faces, self.n_cells, dtype=np.int64)
        np.minimum.at(first, self.cell_faces, segment_owner(self.cell_offsets))
        return np.where(first == self.n_cells, -1, first)

    def _check_face_use(self) -> None:
        """Every face in one or two cells, with opposite signs in two."""
        count = np.bincount(self.cell_faces, minlength=self.n_faces)
        if np.any(count == 0):
            f = int(np.argmin(count))
            raise ValueError(f"face {f} belongs to no cell (vertices {self.face(f).tolist()})")
        owner = segment_owner(self.cell_offsets)
        if np.any(count > 2):
            f = int(np.argmax(count > 2))
            cells = owner[self.cell_faces == f].tolist()
            raise ValueError(f"cell {cells[2]}: its face {f} also belongs to cells {cells[:2]} (a face may "
                             f"belong to two cells at most)")
        sign_sum = np.bincount(self.cell_faces, weights=self.cell_face_signs, minlength=self.n_faces)
        same = np.flatnonzero((count == 2) & (sign_sum != 0))
        if same.size:
            f = int(same[0])
            a, b = owner[self.cell_faces == f].tolist()
            raise ValueError(f"cell {b}: its face {f} points the same way as in cell {a} (sign "
                             f"{int(sign_sum[f]) // 2:+d} in both): the two cells would lie on the same side of it")

    def _check_faces(self, planar_rtol: float) -> None:
        """Vertex counts, repeated vertices, areas, planarity, duplicate faces."""
        self.face_area_vectors, self.face_centroids, code, f, detail = _face_geometry(
            self.points, self.face_offsets, self.face_vertices, self.tol, float(planar_rtol))
        if code != _OK:
            c, verts = int(self._cell_of_face()[f]), self.face(f).tolist()
            what = {_FEW_VERTICES: f"has {detail} vertices, at least 3 needed",
                    _REPEATED: f"repeats vertex {detail} ({verts})",
            _SELF_INTERSECTING: f"intersects itself at its side {detail} (vertices {verts})",
                    _ZERO_AREA: f"has zero area (vertices {verts})"}.get(code)
            if code == _NOT_PLANAR:
                normal = self.face_area_vectors[f] / np.linalg.norm(self.face_area_vectors[f])
                off = abs((self.points[verts[detail]] - self.face_centroids[f]) @ normal)
                what = (f"is not planar: its vertex {verts[detail]} lies {off:.3g} off its plane (vertices "
                        f"{verts}, tolerance {planar_rtol:g} of its diameter)")
            raise ValueError(f"cell {c}: face {f} {what}")
        _, first, inverse = np.unique(_vertex_sets(self.face_offsets, self.face_vertices), axis=0,
                                      return_index=True, return_inverse=True)
        duplicate = np.flatnonzero(first[inverse.reshape(-1)] != np.arange(self.n_faces))
        if duplicate.size:
            f = int(duplicate[0])
            g = int(first[inverse.reshape(-1)[f]])
            raise ValueError(f"cell {int(self._cell_of_face()[f])}: its face {f} has the vertices of face {g} "
                             f"({sorted(self.face(g).tolist())}): store each face once")

    def _check_cells(self) -> None:
        """Closed, consistently oriented cells of positive volume."""
        self.volumes, self.centroids, code, c, a, b = _cell_geometry(
            self.points, self.face_offsets, self.face_vertices, self.cell_offsets, self.cell_faces,
            self.cell_face_signs, self.face_area_vectors, self.face_centroids, self.tol)
        if code == _OK:
            return
        faces = self.cell_face_indices(c)
        with_edge = [int(f) for f in faces if {a, b} <= set(self.face(f).tolist())]
        what = {
            _FEW_FACES: f"has {a} faces, at least 4 needed",
            _FACE_TWICE: f"lists face {a} twice",
            _SAME_DIRECTION: f"is not consistently oriented: its edge ({a}, {b}) runs the same way in its faces "
                             f"{with_edge} (one of them is flipped: wrong sign or vertex order)",
            _OPEN: f"is not closed: its edge ({a}, {b}) lies in only one of its faces ({with_edge})",
            _NON_MANIFOLD: f"is not a polyhedron: its edge ({a}, {b}) lies in more than two of its faces "
                           f"({with_edge})",
            _ZERO_VOLUME: f"has zero volume ({self.volumes[c]:.3g})",
            _NEGATIVE_VOLUME: f"has a negative volume ({self.volumes[c]:.6g}): its faces point into it",
        }[code]
        raise ValueError(f"cell {c} {what}")

    def _check_conforming(self) -> None:
        """No point of a boundary face lies on another boundary face without being its vertex (pairs
        found by a k-d tree of the boundary points)."""
        boundary = self.boundary_faces()
        sizes = np.diff(self.face_offsets)[boundary]
        entries = concatenated_ranges(self.face_offsets[boundary], sizes)
        on_boundary = np.unique(self.face_vertices[entries])
        reach = np.linalg.norm(self.points[self.face_vertices[entries]] - np.repeat(self.face_centroids[boundary],
                                                                                   sizes, axis=0), axis=1)
        reach = np.maximum.reduceat(reach, np.cumsum(sizes) - sizes) + self.tol
        near = cKDTree(self.points[on_boundary]).query_ball_point(self.face_centroids[boundary], reach)
        point = on_boundary[np.concatenate([np.asarray(n, dtype=np.int64) for n in near])]
        face = np.repeat(boundary, [len(n) for n in near])
        hit = np.flatnonzero(_points_on_faces(self.points, self.face_offsets, self.face_vertices,
                                              self.face_area_vectors, self.face_centroids, point, face, self.tol))
        if hit.size:
            p, f = int(point[hit[0]]), int(face[hit[0]])
            raise ValueError(f"cell {int(self._cell_of_face()[f])}: point {p} lies on its boundary face {f} (vertices "
                             f"{self.face(f).tolist()}) without being one of its vertices: the mesh is not "
                             f"conforming there (a face not split like the faces across it, a hanging vertex "
                             f"missing on one side, or a crack)")

    # ----------------------------------------------------------------------- accessors
    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_faces(self) -> int:
        return int(self.face_offsets.size - 1)

    @property
    def n_cells(self) -> int:
        return int(self.cell_offsets.size - 1)

    def face(self, f: int) -> npt.NDArray[np.int64]:
        """Point indices of face ``f`` in its stored cyclic order."""
        return self.face_vertices[self.face_offsets[f]:self.face_offsets[f + 1]]

    def cell_face_indices(self, c: int) -> npt.NDArray[np.int64]:
        """Indices of the faces of cell ``c``."""
        return self.cell_faces[self.cell_offsets[c]:self.cell_offsets[c + 1]]

    def polyhedron(self, c: int) -> tuple[npt.NDArray[np.float64], list[npt.NDArray[np.int64]]]:
        """Cell ``c`` as the element's input: its points (n_v, 3) (its vertices in increasing global
        index) and its faces, each an int64 array of local vertex indices in cyclic order with the
        normal pointing out of the cell, in the cell's face order."""
        s, e = self.cell_offsets[c], self.cell_offsets[c + 1]
        faces = [self.face(f) if sign > 0 else self.face(f)[::-1]
                 for f, sign in zip(self.cell_faces[s:e], self.cell_face_signs[s:e])]
        vertices = np.unique(np.concatenate(faces))
        return self.points[vertices], [np.searchsorted(vertices, f).astype(np.int64) for f in faces]

    @property
    def face_cells(self) -> npt.NDArray[np.int64]:
        """The cells of every face (n_faces, 2): column 0 the cell it points out of (sign +1),
        column 1 the cell it points into (sign -1), -1 where there is none."""
        out = np.full((self.n_faces, 2), -1, dtype=np.int64)
        out[self.cell_faces, (self.cell_face_signs < 0).astype(np.int64)] = segment_owner(self.cell_offsets)
        return out

    def boundary_faces(self) -> npt.NDArray[np.int64]:
        """Indices (k,) of the faces of only one cell, sorted: the boundary of the mesh."""
        return np.flatnonzero((self.face_cells < 0).any(axis=1))

    def edges(self) -> npt.NDArray[np.int64]:
        """Every edge of the faces once, (n_edges, 2) int64 point indices, the lower first, sorted."""
        nxt = np.arange(1, self.face_vertices.size + 1)
        nxt[self.face_offsets[1:] - 1] = self.face_offsets[:-1]
        pairs = np.sort(np.column_stack([self.face_vertices, self.face_vertices[nxt]]), axis=1)
        return np.unique(pairs, axis=0)

    def summary(self) -> str:
        """Counts: cells by number of faces, faces by number of vertices, regions."""
        n_faces, by_faces = np.unique(np.diff(self.cell_offsets), return_counts=True)
        n_verts, by_verts = np.unique(np.diff(self.face_offsets), return_counts=True)
        regions, by_region = np.unique(self.tags, return_counts=True)
        return "\n".join([
            f"PolyhedronMesh: {self.n_cells} cells, {self.n_faces} faces ({self.boundary_faces().size} on the "
            f"boundary), {self.n_points} points, volume {self.volumes.sum():.6g}",
            "  cells by number of faces: " + ", ".join(f"{k}: {n}" for k, n in zip(n_faces, by_faces)),
            "  faces by number of vertices: " + ", ".join(f"{k}: {n}" for k, n in zip(n_verts, by_verts)),
            "  regions: " + ", ".join(f"{r}: {n} cells" for r, n in zip(regions, by_region))])

    # ----------------------------------------------------------------------- construction
    @classmethod
    def from_cell_faces(cls, points: npt.ArrayLike, cell_offsets: npt.ArrayLike, face_offsets: npt.ArrayLike,
                        face_vertices: npt.ArrayLike, tags: npt.ArrayLike | None = None,
                        region_names: Mapping[str, int] | None = None, **kwargs) -> "PolyhedronMesh":
        """The mesh of cells given by their own faces, each oriented out of its cell: a face shared
        by two cells is listed by both (same vertex set, opposite cyclic order) and stored once.

        Parameters
        ----------
        points : (n_points, 3) array_like
        cell_offsets : (n_cells + 1,) array_like of int
            Cell ``c`` has the local faces ``cell_offsets[c]:cell_offsets[c + 1]``.
        face_offsets, face_vertices : array_like of int
            CSR of the local faces' point indices, outward cyclic order.
        tags, region_names, kwargs
            As for :class:`PolyhedronMesh`.

        Raises
        ------
        ValueError
            Naming the cell: a face listed by two cells with the same vertex set in an order that is
            neither the reverse nor the same cyclic order, and everything the constructor refuses.
        """
        points = as_points(points, 3)
        face_offsets, face_vertices = _as_index_csr(face_offsets, face_vertices, points.shape[0], "faces", "point")
        cell_offsets, _ = _as_index_csr(cell_offsets, np.arange(face_offsets.size - 1), face_offsets.size - 1,
                                        "cells", "face")
        _, first, inverse = np.unique(_vertex_sets(face_offsets, face_vertices), axis=0, return_index=True,
                                      return_inverse=True)
        inverse = inverse.reshape(-1)
        stored = np.sort(first)                                   # keep the faces in order of first listing
        number = np.empty(face_offsets.size - 1, dtype=np.int64)
        number[stored] = np.arange(stored.size)
        global_face = number[first[inverse]]
        signs = _relative_orientation(face_offsets, face_vertices, first[inverse], np.arange(inverse.size))
        if np.any(signs == 0):
            k = int(np.argmin(np.abs(signs)))
            cell = int(np.searchsorted(cell_offsets, k, "right") - 1)
            raise ValueError(f"cell {cell}: its face with vertices {face_vertices[face_offsets[k]:face_offsets[k + 1]]} "
                             f"lists the vertices of another cell's face in a different cyclic order")
        sizes = np.diff(face_offsets)[stored]
        vertices = face_vertices[concatenated_ranges(face_offsets[stored], sizes)]
        offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        return cls(points, offsets, vertices, cell_offsets, global_face, signs, tags, region_names, **kwargs)

    @classmethod
    def from_cell_mesh(cls, mesh: CellMesh, **kwargs) -> "PolyhedronMesh":
        """The tetrahedra or hexahedra of a 3D :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh` as polyhedra:
        cell ``c`` has the faces of DOLFINx's facet numbering (quadrilaterals in cyclic order),
        oriented out of it; points, tags and region names kept.

        A non-planar quadrilateral face of a hexahedron (its vertices farther than
        :data:`~dolfinx_sfvem.mesh.cell_mesh.TOLERANCE` times its diameter from one plane; a
        hexahedron that is not a parallelepiped may have them) becomes two flat triangles, split
        along the diagonal through its vertex of smallest index, the same in the two cells that
        share it: the polyhedron keeps the vertices and takes the face as these two triangles, where
        the trilinear hexahedron of the Lagrange FEM has the bilinear surface through them.

        A mesh of curved cells (degree-2 geometry) is read by its vertices, its faces taken flat;
        a logging warning says so (:func:`~dolfinx_sfvem.mesh.cell_mesh.note_flat`)."""
        if mesh.tdim != 3:
            raise ValueError(f"from_cell_mesh: a 3D mesh of tetrahedra or hexahedra is needed, got {mesh.cell_type}")
        note_flat(mesh, "the polyhedra of a CellMesh")
        local = np.asarray(reference_facets(mesh.cell_type), dtype=np.int64)     # (n_local, k)
        faces = mesh.cells[:, local].reshape(-1, local.shape[1])                  # cell-major
        centre = np.repeat(mesh.points[mesh.cells].mean(axis=1), local.shape[0], axis=0)
        inward = np.einsum("ij,ij->i", facet_normals(mesh.points, faces),
                           mesh.points[faces].mean(axis=1) - centre) < 0
        faces[inward] = faces[inward][:, ::-1]
        n_local, k = local.shape
        if k == 3:
            return cls.from_cell_faces(mesh.points, np.arange(mesh.n_cells + 1) * n_local,
                                       np.arange(faces.shape[0] + 1) * k, faces.ravel(), mesh.tags,
                                       mesh.region_names, **kwargs)
        split = _non_planar(mesh.points, faces)
        first = np.argmin(faces, axis=1)                        # rotate: the smallest vertex first
        turned = faces[np.arange(faces.shape[0])[:, None], (first[:, None] + np.arange(4)) % 4]
        pieces = np.where(split[:, None], turned[:, [0, 1, 2, 0, 2, 3]],
                          np.concatenate([faces, np.full((faces.shape[0], 2), -1)], axis=1))
        sizes = np.where(split[:, None], [3, 3], [4, 0]).ravel()
        per_cell = (1 + split.reshape(mesh.n_cells, n_local)).sum(axis=1)
        return cls.from_cell_faces(mesh.points, np.concatenate([[0], np.cumsum(per_cell)]),
                                   np.concatenate([[0], np.cumsum(sizes[sizes > 0])]), pieces[pieces >= 0],
                                   mesh.tags, mesh.region_names, **kwargs)


def _non_planar(points: npt.NDArray[np.float64], quads: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
    """Which quadrilaterals (n, 4), vertices in cyclic order, are not planar: their vertices lie
    ±h off the plane through their mean normal to their area vector (the same h for all four),
    h > :data:`~dolfinx_sfvem.mesh.cell_mesh.TOLERANCE` times the longer diagonal."""
    x = points[quads]
    normal = facet_normals(points, quads)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    h = np.abs(np.einsum("ij,ij->i", x[:, 0] - x.mean(axis=1), normal))
    diagonal = np.maximum(np.linalg.norm(x[:, 2] - x[:, 0], axis=1), np.linalg.norm(x[:, 3] - x[:, 1], axis=1))
    return h > TOLERANCE * diagonal
