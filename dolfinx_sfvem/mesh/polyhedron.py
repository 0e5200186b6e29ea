"""Geometry and quadrature of one polyhedron given as (points, faces) (docs/method.md §8).

A polyhedron is ``points`` (n_v, 3) and ``faces``, a list of local vertex-index arrays, each a
planar polygon in cyclic order whose right-hand-rule normal points out of the polyhedron
(:meth:`PolyhedronMesh.polyhedron <dolfinx_sfvem.mesh.polyhedron_mesh.PolyhedronMesh.polyhedron>`
gives a cell so). Faces may have collinear vertices (hanging vertices of an octree).

Every face gets an orthonormal frame (t_1, t_2, n): n the outward unit normal (Newell's area
vector), t_1 along its first side, t_2 = n x t_1, so that its vertices, written in the plane
coordinates ((x - x_0) . t_1, (x - x_0) . t_2), are counter-clockwise: the 2D polygon code
(:mod:`dolfinx_sfvem.mesh.polygon`, :mod:`dolfinx_sfvem.discretizations.projection`) then works on the face as is.
Each face is cut into triangles by the 2D sub-triangulation (a fan from its centroid, from the
centroid of its visibility region, or ear clipping), positive in the face's plane; the
polyhedron into the tetrahedra (x_c, triangle) with x_c its centroid ("fans from the face centres
and the cell centre"). The tetrahedra's signed volumes add up to the polyhedron for any x_c, so
the sub-tetrahedral rule is exact for polynomials even when x_c does not see every face
(non-convex cells: some weights are then negative, :func:`polyhedron_quadrature`).

The compiled kernels take the faces in CSR form (``face_offsets``, ``face_vertices``).
"""
from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import basix
import numba
import numpy as np
import numpy.typing as npt

from dolfinx_sfvem.discretizations.monomials3d import evaluate_monomials3, n_monomials3
from dolfinx_sfvem.mesh.polygon import FAILED, RTOL, sub_triangulation
from dolfinx_sfvem.mesh.polygon import diameter as polygon_diameter
from dolfinx_sfvem.discretizations.quadrature import compress_rule, triangle_rule

#: Largest distance of a face vertex from the face's plane, relative to the polyhedron's diameter.
#: Non-planar faces break the exactness of every face integral (the projections are built in the
#: face's plane), so they are rejected; planar faces computed in floating point (Voronoi cells,
#: rotated cubes) are planar to about 1e-15 of the diameter.
PLANARITY_TOL = 1e-8


# --------------------------------------------------------------------------- input
def faces_csr(faces: Sequence[npt.ArrayLike]) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """The faces as CSR arrays: ``face_vertices[face_offsets[f]:face_offsets[f + 1]]`` is face f."""
    faces = [np.asarray(f, dtype=np.int64).ravel() for f in faces]
    offsets = np.concatenate([[0], np.cumsum([f.size for f in faces])]).astype(np.int64)
    vertices = np.concatenate(faces).astype(np.int64) if faces else np.empty(0, dtype=np.int64)
    return offsets, vertices


def polyhedron_edges(faces: Sequence[npt.ArrayLike]) -> npt.NDArray[np.int64]:
    """The edges of a polyhedron, (n_e, 2) int64: sorted pairs (a < b) in lexicographic order.

    An edge is a pair of vertices that follow each other in a face (a face side); with
    hanging vertices each piece between two vertices is its own edge.
    """
    offsets, vertices = faces_csr(faces)
    return _edges(offsets, vertices)


def _sides(offsets: np.ndarray, vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end vertex of every face side, in face order."""
    counts = np.diff(offsets)
    face_of = np.repeat(np.arange(counts.size), counts)
    position = np.arange(vertices.size) - offsets[face_of]
    following = offsets[face_of] + (position + 1) % counts[face_of]
    return vertices, vertices[following]


def _edges(offsets: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    a, b = _sides(offsets, vertices)
    return np.unique(np.column_stack([np.minimum(a, b), np.maximum(a, b)]), axis=0).astype(np.int64)


def validate_polyhedron(points: npt.ArrayLike, faces: Sequence[npt.ArrayLike]) -> None:
    """Raise ValueError, saying what is wrong, unless (points, faces) is a closed polyhedron with
    planar, outward, cyclic faces (module docstring).

    Checked: points (n_v, 3) finite; at least 4 faces of at least 3 distinct, valid vertex
    indices; every vertex in a face; every edge in exactly two faces (closed, manifold), passed
    in opposite directions (consistent orientation: one inward face fails here); faces planar
    within PLANARITY_TOL and simple (their 2D sub-triangulation exists); positive volume (all
    faces inward fails here).
    """
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] < 4:
        raise ValueError(f"points must have shape (n_v >= 4, 3), got {points.shape}")
    if not np.all(np.isfinite(points)):
        raise ValueError("points must be finite")
    if len(faces) < 4:
        raise ValueError(f"a polyhedron needs at least 4 faces, got {len(faces)}")
    for f, face in enumerate(faces):
        face = np.asarray(face)
        if face.ndim != 1 or face.size < 3 or not np.issubdtype(face.dtype, np.integer):
            raise ValueError(f"face {f}: need an integer array of at least 3 vertex indices, got {face!r}")
        if face.min() < 0 or face.max() >= points.shape[0]:
            raise ValueError(f"face {f}: vertex index outside 0..{points.shape[0] - 1}")
        if np.unique(face).size != face.size:
            raise ValueError(f"face {f}: a vertex is repeated ({face.tolist()})")
    offsets, vertices = faces_csr(faces)
    unused = np.setdiff1d(np.arange(points.shape[0]), vertices)
    if unused.size:
        raise ValueError(f"vertex {unused[0]} is in no face")
    a, b = _sides(offsets, vertices)
    face_of = np.repeat(np.arange(len(faces)), np.diff(offsets))
    key = np.minimum(a, b) * points.shape[0] + np.maximum(a, b)
    edge_keys, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    if np.any(counts != 2):
        e = int(np.flatnonzero(counts != 2)[0])
        va, vb = divmod(int(edge_keys[e]), points.shape[0])
        uses = face_of[inverse == e].tolist()
        kind = "open polyhedron" if counts[e] == 1 else "non-manifold edge"
        raise ValueError(f"edge ({va}, {vb}) is a side of {counts[e]} faces {uses}, 2 expected ({kind})")
    direction = np.where(a < b, 1, -1)
    same = np.bincount(inverse, weights=direction)
    if np.any(same != 0):
        e = int(np.flatnonzero(same != 0)[0])
        f, g = face_of[inverse == e].tolist()
        va, vb = divmod(int(edge_keys[e]), points.shape[0])
        raise ValueError(f"faces {f} and {g} pass their common edge ({va}, {vb}) in the same direction: "
                         "one of them is oriented inward")
    h = float(np.max(np.linalg.norm(points[:, None] - points[None], axis=2)))
    deviation, tri_status = _face_checks(points, offsets, vertices)
    if np.any(deviation > PLANARITY_TOL * h):
        f = int(np.argmax(deviation))
        raise ValueError(f"face {f} is not planar: a vertex lies {deviation[f]:.3e} from its plane "
                         f"(tolerance {PLANARITY_TOL:g} x diameter {h:.3e})")
    if np.any(tri_status == FAILED):
        f = int(np.flatnonzero(tri_status == FAILED)[0])
        raise ValueError(f"face {f} is degenerate or self-intersecting in its plane")
    volume = _geometry(points, offsets, vertices)[0]
    if not volume > 0.0:
        raise ValueError(f"the faces point inward: volume {volume:.3e} <= 0")


# --------------------------------------------------------------------------- compiled kernels
@numba.njit(cache=True)
def face_frame(X: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """Area, outward unit normal n and in-plane basis (t_1, t_2) of the face with vertices X (N, 3).

    Newell's area vector 1/2 sum_i (x_i - x_0) x (x_{i+1} - x_0) is the normal times the area for
    a planar polygon in cyclic order; t_1 is the first side's direction without its normal
    part, t_2 = n x t_1 (so (t_1, t_2, n) is right-handed and the face is counter-clockwise in
    the plane coordinates).
    """
    N = X.shape[0]
    area_vector = np.zeros(3)
    for i in range(1, N - 1):
        area_vector += 0.5 * np.cross(X[i] - X[0], X[i + 1] - X[0])
    area = np.sqrt(np.sum(area_vector ** 2))
    n = area_vector / area if area > 0.0 else area_vector
    side = X[1] - X[0]
    t1 = side - np.dot(side, n) * n
    t1 /= np.sqrt(np.sum(t1 ** 2))
    t2 = np.cross(n, t1)
    return area, n, t1, t2


@numba.njit(cache=True)
def plane_coordinates(X: np.ndarray, origin: np.ndarray, t1: np.ndarray, t2: np.ndarray) -> np.ndarray:
    """Coordinates (N, 2) of the points X (N, 3) in the plane frame (origin, t_1, t_2)."""
    xy = np.empty((X.shape[0], 2))
    for i in range(X.shape[0]):
        xy[i, 0] = np.dot(X[i] - origin, t1)
        xy[i, 1] = np.dot(X[i] - origin, t2)
    return xy


@numba.njit(cache=True)
def _face_checks(points, offsets, vertices):
    """Per face: the largest distance of a vertex from its plane, and the 2D sub-triangulation status."""
    n_f = offsets.size - 1
    deviation = np.zeros(n_f)
    status = np.zeros(n_f, dtype=np.int64)
    for f in range(n_f):
        X = points[vertices[offsets[f]:offsets[f + 1]]]
        area, n, t1, t2 = face_frame(X)
        if not area > 0.0:
            status[f] = FAILED
            continue
        for i in range(X.shape[0]):
            deviation[f] = max(deviation[f], abs(np.dot(X[i] - X[0], n)))
        xy = plane_coordinates(X, X[0], t1, t2)
        status[f] = sub_triangulation(xy, RTOL * polygon_diameter(xy))[0]
    return deviation, status


@numba.njit(cache=True)
def face_triangles(points, offsets, vertices):
    """The faces' sub-triangles in 3D, each counter-clockwise about the outward normal.

    Returns
    -------
    triangles : (n_t, 3, 3) float64
        triangles[t, j] is the j-th corner of triangle t.
    triangle_face : (n_t,) int64
        The face of each triangle.
    """
    n_f = offsets.size - 1
    n_max = 0
    for f in range(n_f):
        n_max += offsets[f + 1] - offsets[f]
    triangles = np.empty((n_max, 3, 3))
    triangle_face = np.empty(n_max, dtype=np.int64)
    t = 0
    for f in range(n_f):
        X = points[vertices[offsets[f]:offsets[f + 1]]]
        _, _, t1, t2 = face_frame(X)
        xy = plane_coordinates(X, X[0], t1, t2)
        _, centre, tri, _, _ = sub_triangulation(xy, RTOL * polygon_diameter(xy))
        c3 = X[0] + centre[0] * t1 + centre[1] * t2
        for k in range(tri.shape[0]):
            for j in range(3):
                triangles[t, j] = X[tri[k, j]] if tri[k, j] < X.shape[0] else c3
            triangle_face[t] = f
            t += 1
    return triangles[:t].copy(), triangle_face[:t].copy()


@numba.njit(cache=True)
def _geometry(points, offsets, vertices):
    """Volume, centroid (3,), diameter, and per face area (n_f,), outward unit normal (n_f, 3),
    centroid (n_f, 3), in-plane basis (n_f, 2, 3), from the sub-triangles (exact)."""
    triangles, triangle_face = face_triangles(points, offsets, vertices)
    n_f = offsets.size - 1
    areas = np.zeros(n_f)
    normals = np.zeros((n_f, 3))
    bases = np.zeros((n_f, 2, 3))
    face_centroids = np.zeros((n_f, 3))
    for f in range(n_f):
        X = points[vertices[offsets[f]:offsets[f + 1]]]
        areas[f], normals[f], bases[f, 0], bases[f, 1] = face_frame(X)
    reference = np.zeros(3)
    for i in range(points.shape[0]):
        reference += points[i] / points.shape[0]
    volume = 0.0
    first_moment = np.zeros(3)
    for t in range(triangles.shape[0]):
        a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        f = triangle_face[t]
        face_centroids[f] += 0.5 * np.dot(np.cross(b - a, c - a), normals[f]) * (a + b + c) / 3.0
        v = np.dot(a - reference, np.cross(b - reference, c - reference)) / 6.0
        volume += v
        first_moment += v * (reference + a + b + c) / 4.0
    for f in range(n_f):
        face_centroids[f] /= areas[f]
    h = 0.0
    for i in range(points.shape[0]):
        for j in range(i + 1, points.shape[0]):
            h = max(h, np.sqrt(np.sum((points[i] - points[j]) ** 2)))
    return volume, first_moment / volume, h, areas, normals, face_centroids, bases


@numba.njit(cache=True)
def map_triangle_rule(triangles, rule_points, rule_weights):
    """A triangle rule (reference points (n_r, 2), weights summing to 1/2) on every triangle.

    Returns x_q (n_t n_r, 3) and w_q (n_t n_r,), the points of triangle t at t n_r ... (t+1) n_r - 1.
    """
    n_r = rule_weights.size
    x_q = np.empty((triangles.shape[0] * n_r, 3))
    w_q = np.empty(triangles.shape[0] * n_r)
    for t in range(triangles.shape[0]):
        a = triangles[t, 0]
        e1 = triangles[t, 1] - a
        e2 = triangles[t, 2] - a
        jacobian = np.sqrt(np.sum(np.cross(e1, e2) ** 2))
        for r in range(n_r):
            x_q[t * n_r + r] = a + rule_points[r, 0] * e1 + rule_points[r, 1] * e2
            w_q[t * n_r + r] = rule_weights[r] * jacobian
    return x_q, w_q


@numba.njit(cache=True)
def map_tetrahedron_rule(triangles, apex, rule_points, rule_weights):
    """A tetrahedron rule (reference points (n_r, 3), weights summing to 1/6) on the tetrahedra
    (apex, triangle) with signed volumes: x_q (n_t n_r, 3), w_q (n_t n_r,)."""
    n_r = rule_weights.size
    x_q = np.empty((triangles.shape[0] * n_r, 3))
    w_q = np.empty(triangles.shape[0] * n_r)
    for t in range(triangles.shape[0]):
        e0 = triangles[t, 0] - apex
        e1 = triangles[t, 1] - apex
        e2 = triangles[t, 2] - apex
        det = np.dot(e0, np.cross(e1, e2))
        for r in range(n_r):
            s0, s1, s2 = rule_points[r, 0], rule_points[r, 1], rule_points[r, 2]
            x_q[t * n_r + r] = apex + s0 * e0 + s1 * e1 + s2 * e2
            w_q[t * n_r + r] = rule_weights[r] * det
    return x_q, w_q


@numba.njit(cache=True)
def monomial_integrals_from_faces(x_q, w_q, point_face, normals, face_centroids, x_E, h_E, degree):
    """Exact integrals over E of the scaled monomials of degree <= ``degree`` (divergence theorem).

    m_a is homogeneous of degree d in x - x_E, so div((x - x_E) m_a) = (3 + d) m_a and

        int_E m_a = 1/(3 + d) sum_f ((x_f - x_E) . n_f) int_f m_a,

    (x - x_E) . n_f being constant on the planar face f. The face rule (x_q, w_q, point_face) must
    be exact for ``degree``.

    Returns
    -------
    (n_monomials3(degree),) float64
    """
    n = n_monomials3(degree)
    m = np.empty(n)
    dm = np.empty((3, n))
    sums = np.zeros(n)
    for q in range(w_q.size):
        f = point_face[q]
        flux = np.dot(face_centroids[f] - x_E, normals[f])
        evaluate_monomials3(x_q[q], x_E, h_E, degree, m, dm)
        for a in range(n):
            sums[a] += w_q[q] * flux * m[a]
    a = 0
    for d in range(degree + 1):
        for _ in range((d + 1) * (d + 2) // 2):
            sums[a] /= 3 + d
            a += 1
    return sums


# --------------------------------------------------------------------------- rules and wrappers
@functools.lru_cache(maxsize=None)
def tetrahedron_rule(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Basix's rule on the reference tetrahedron exact for ``degree``: points (n, 3), weights
    (n,) summing to 1/6."""
    points, weights = basix.make_quadrature(basix.CellType.tetrahedron, max(int(degree), 1))
    return np.ascontiguousarray(points), np.ascontiguousarray(weights)


@dataclass(frozen=True)
class PolyhedronGeometry:
    """Measures of one polyhedron (module docstring).

    Attributes
    ----------
    volume : float
    centroid : (3,) float64
    diameter : float
        Largest distance between two vertices.
    face_areas : (n_f,) float64
    face_normals : (n_f, 3) float64
        Outward unit normals.
    face_centroids : (n_f, 3) float64
    face_bases : (n_f, 2, 3) float64
        (t_1, t_2) of each face: (t_1, t_2, n) is a right-handed orthonormal frame.
    """

    volume: float
    centroid: npt.NDArray[np.float64]
    diameter: float
    face_areas: npt.NDArray[np.float64]
    face_normals: npt.NDArray[np.float64]
    face_centroids: npt.NDArray[np.float64]
    face_bases: npt.NDArray[np.float64]


def _checked(points: npt.ArrayLike, faces: Sequence[npt.ArrayLike]):
    validate_polyhedron(points, faces)
    offsets, vertices = faces_csr(faces)
    return np.ascontiguousarray(points, dtype=np.float64), offsets, vertices


def polyhedron_geometry(points: npt.ArrayLike, faces: Sequence[npt.ArrayLike]) -> PolyhedronGeometry:
    """Volume, centroid, diameter and face geometry of a polyhedron (validated first).

    Raises
    ------
    ValueError
        From :func:`validate_polyhedron`.
    """
    volume, centroid, h, areas, normals, centroids, bases = _geometry(*_checked(points, faces))
    return PolyhedronGeometry(float(volume), centroid, float(h), areas, normals, centroids, bases)


def face_quadrature(points: npt.ArrayLike, faces: Sequence[npt.ArrayLike], degree: int
                    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Quadrature on every face, exact for polynomials of ``degree`` on the face.

    The face's 2D sub-triangulation (fan or ear clipping, :func:`dolfinx_sfvem.mesh.polygon.sub_triangulation`)
    with the Gauss rule of :func:`dolfinx_sfvem.discretizations.quadrature.triangle_rule` on each triangle:
    positive weights, points inside the face.

    Returns
    -------
    x_q : (n_q, 3) float64
    w_q : (n_q,) float64
        Weights (area units); those of face f sum to its area.
    point_face : (n_q,) int64
        The face of each point.
    """
    points, offsets, vertices = _checked(points, faces)
    triangles, triangle_face = face_triangles(points, offsets, vertices)
    rule_points, rule_weights = triangle_rule(max(int(degree), 1))
    x_q, w_q = map_triangle_rule(triangles, rule_points, rule_weights)
    return x_q, w_q, np.repeat(triangle_face, rule_weights.size)


def polyhedron_quadrature(points: npt.ArrayLike, faces: Sequence[npt.ArrayLike], degree: int
                          ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Quadrature over the polyhedron exact for polynomials of ``degree``: basix's tetrahedron rule
    on the tetrahedra (centroid, face sub-triangle).

    Returns
    -------
    x_q : (n_q, 3) float64
    w_q : (n_q,) float64
        Signed weights summing to the volume. All are positive when the centroid sees every
        face sub-triangle from its inner side (convex and most star-shaped cells); otherwise
        some are negative and the rule is still exact for polynomials, not for other integrands.
    """
    points, offsets, vertices = _checked(points, faces)
    triangles, _ = face_triangles(points, offsets, vertices)
    centroid = _geometry(points, offsets, vertices)[1]
    return map_tetrahedron_rule(triangles, centroid, *tetrahedron_rule(degree))


#: relative volume defect below which a polyhedron is taken for its bounding box (:func:`energy_quadrature`)
BOX_TOL = 1e-12

#: the rules of :func:`energy_quadrature`
QUADRATURES = ("auto", "tetrahedra", "compressed")


def box_rule(lower: npt.ArrayLike, upper: npt.ArrayLike, degree: int
             ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Tensor Gauss-Legendre rule on the box [lower, upper] exact for ``degree``: (degree//2 + 1)³
    points (n, 3), positive weights (n,) summing to its volume."""
    lower, upper = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    g, wg = np.polynomial.legendre.leggauss(int(degree) // 2 + 1)
    s = (g + 1) / 2
    axes = [lower[c] + s * (upper[c] - lower[c]) for c in range(3)]
    x = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    w = np.einsum("i,j,k->ijk", *[wg / 2 * (upper[c] - lower[c]) for c in range(3)]).ravel()
    return x, w


def energy_quadrature(points: npt.ArrayLike, faces: Sequence[npt.ArrayLike], degree: int, rule: str = "auto"
                      ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The rule of a polyhedron's energy integrals, exact for polynomials of ``degree``.

    ``rule``: ``"tetrahedra"`` the sub-tetrahedral rule (:func:`polyhedron_quadrature`);
    ``"auto"`` the tensor rule (:func:`box_rule`) when the polyhedron is an axis-aligned box (its
    volume that of its bounding box: octree cells, whatever their hanging vertices), else the
    sub-tetrahedral rule; ``"compressed"`` as "auto", with the sub-tetrahedral rule compressed to
    at most dim P_degree positive weights (:func:`dolfinx_sfvem.discretizations.quadrature.compress_rule`;
    the compression takes seconds per cell at degree 10).

    Returns
    -------
    x_q : (n_q, 3) float64
    w_q : (n_q,) float64
    """
    if rule not in QUADRATURES:
        raise ValueError(f"unknown quadrature {rule!r}; valid: {QUADRATURES}")
    points = np.asarray(points, dtype=np.float64)
    if rule != "tetrahedra":
        lower, upper = points.min(axis=0), points.max(axis=0)
        box = np.prod(upper - lower)
        if abs(polyhedron_geometry(points, faces).volume - box) <= BOX_TOL * box:
            return box_rule(lower, upper, degree)
    x_q, w_q = polyhedron_quadrature(points, faces, degree)
    return compress_rule(x_q, w_q, degree) if rule == "compressed" else (x_q, w_q)


def polyhedron_monomial_integrals(points: npt.ArrayLike, faces: Sequence[npt.ArrayLike], centre: npt.ArrayLike,
                                  scale: float, degree: int) -> npt.NDArray[np.float64]:
    """int_E ((x - centre)/scale)^alpha for all |alpha| <= degree, in the order of
    :mod:`dolfinx_sfvem.discretizations.monomials3d`, by the divergence theorem (:func:`monomial_integrals_from_faces`).

    ``centre`` must be the point the monomials are homogeneous about (any point, e.g. the centroid).
    """
    points, offsets, vertices = _checked(points, faces)
    _, _, _, _, normals, centroids, _ = _geometry(points, offsets, vertices)
    triangles, triangle_face = face_triangles(points, offsets, vertices)
    rule_points, rule_weights = triangle_rule(max(int(degree), 1))
    x_q, w_q = map_triangle_rule(triangles, rule_points, rule_weights)
    return monomial_integrals_from_faces(x_q, w_q, np.repeat(triangle_face, rule_weights.size), normals,
                                         centroids, np.asarray(centre, dtype=np.float64), float(scale), int(degree))
