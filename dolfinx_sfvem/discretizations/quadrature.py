"""Quadrature over polygons, exact for a given polynomial degree.

The energy integrals of the SFVEM (paper Eqs. 46, 52, 56) are not polynomial, so they
are integrated numerically on every polygon with a rule exact for degree 2l, where l is
the polygon's projection order (docs/method.md §4). Every point costs one evaluation of the
pointwise energy kernels per assembly, so the rules are made small:

- the reference: Gauss rules on each polygon's sub-triangles (:func:`polygon_quadrature`);
- parallelograms (any number of collinear hanging nodes on their sides) get the tensor
  Gauss rule of the parallelogram, (d//2 + 1)² points;
- the other polygons, solid and third medium alike, get the sub-triangle rule compressed to
  at most dim P_d points by non-negative least squares on the moments
  (Carathéodory–Tchakaloff compression): a subset of the sub-triangle points with new
  positive weights, exact for the same degree (:func:`compressed_polygon_quadrature`).
  In the medium this changes the answer by the quadrature error of a non-polynomial
  integrand, far below the discretization error.
"""
from __future__ import annotations

import functools

import basix
import numba
import numpy as np
import numpy.typing as npt
import scipy.optimize

from dolfinx_sfvem.discretizations.monomials3d import monomial_matrix3


@functools.lru_cache(maxsize=None)
def triangle_rule(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Jacobi rule on the reference triangle, exact for polynomials of ``degree``.

    Returns
    -------
    points : (n_q, 2) float64
        Reference coordinates.
    weights : (n_q,) float64
        Weights summing to 1/2 (the reference area).
    """
    points, weights = basix.make_quadrature(basix.CellType.triangle, int(degree))
    return np.ascontiguousarray(points), np.ascontiguousarray(weights)


@numba.njit(cache=True)
def _map_rules(nodes, triangles, tri_offsets, polygons, degrees, rule_points, rule_weights,
               rule_offsets, q_offsets, x_q, w_q):
    for k in range(polygons.size):
        e = polygons[k]
        d = degrees[k]
        q = q_offsets[k]
        for t in range(tri_offsets[e], tri_offsets[e + 1]):
            a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
            x0, y0 = nodes[a, 0], nodes[a, 1]
            e1x, e1y = nodes[b, 0] - x0, nodes[b, 1] - y0
            e2x, e2y = nodes[c, 0] - x0, nodes[c, 1] - y0
            detJ = abs(e1x * e2y - e1y * e2x)
            for r in range(rule_offsets[d], rule_offsets[d + 1]):
                s, t_ = rule_points[r, 0], rule_points[r, 1]
                x_q[q, 0] = x0 + s * e1x + t_ * e2x
                x_q[q, 1] = y0 + s * e1y + t_ * e2y
                w_q[q] = rule_weights[r] * detJ
                q += 1


def polygon_quadrature(nodes: npt.NDArray[np.float64], triangles: npt.NDArray[np.int64],
                       triangle_offsets: npt.NDArray[np.int64], polygons: npt.NDArray[np.int64],
                       degrees: npt.NDArray[np.integer]):
    """Quadrature points and weights on the sub-triangles of the given polygons.

    Parameters
    ----------
    nodes : (n_nodes, 2)
        Coordinates of the sub-triangulation nodes.
    triangles : (n_triangles, 3)
        Sub-triangles (indices into ``nodes``); those of polygon ``e`` are
        ``triangles[triangle_offsets[e]:triangle_offsets[e + 1]]``.
    triangle_offsets : (n_polygons + 1,)
    polygons : (n,)
        Polygons to integrate over, in output order.
    degrees : (n,)
        Polynomial degree integrated exactly on each of them.

    Returns
    -------
    q_offsets : (n + 1,) int64
        Points of the k-th polygon are ``x_q[q_offsets[k]:q_offsets[k + 1]]``.
    x_q : (n_q, 2) float64
        Physical quadrature points.
    w_q : (n_q,) float64
        Weights (area units); they sum to the polygon areas.
    """
    polygons = np.asarray(polygons, dtype=np.int64)
    degrees = np.asarray(degrees, dtype=np.int64)
    max_degree = int(degrees.max(initial=1))
    rules = [triangle_rule(max(d, 1)) for d in range(max_degree + 1)]
    rule_offsets = np.cumsum([0] + [r[1].size for r in rules]).astype(np.int64)
    rule_points = np.vstack([r[0] for r in rules])
    rule_weights = np.concatenate([r[1] for r in rules])
    n_tri = triangle_offsets[polygons + 1] - triangle_offsets[polygons]
    n_per_polygon = n_tri * (rule_offsets[degrees + 1] - rule_offsets[degrees])
    q_offsets = np.concatenate([[0], np.cumsum(n_per_polygon)]).astype(np.int64)
    x_q = np.empty((q_offsets[-1], 2))
    w_q = np.empty(q_offsets[-1])
    _map_rules(np.ascontiguousarray(nodes, dtype=np.float64), np.ascontiguousarray(triangles, dtype=np.int64),
               np.asarray(triangle_offsets, dtype=np.int64), polygons, degrees, rule_points, rule_weights,
               rule_offsets, q_offsets, x_q, w_q)
    return q_offsets, x_q, w_q


#: relative moment error up to which a compressed rule is accepted (else the full rule is kept)
MOMENT_TOLERANCE = 1e-11


@numba.njit(cache=True)
def scaled_monomials(x, centre, scale, degree):
    """All ((x - centre)/scale)^(p, q) with p + q <= degree at the points x (n, 2): (n_monomials, n),
    ordered by degree, then by the power of the second coordinate."""
    n = x.shape[0]
    V = np.empty(((degree + 1) * (degree + 2) // 2, n))
    for k in range(n):
        xi, eta = (x[k, 0] - centre[0]) / scale, (x[k, 1] - centre[1]) / scale
        row = 0
        for d in range(degree + 1):
            for q in range(d + 1):
                V[row, k] = xi ** (d - q) * eta ** q
                row += 1
    return V


def parallelogram_corners(xy: npt.NDArray[np.float64], tol: float = 1e-10) -> npt.NDArray[np.float64] | None:
    """The corners (4, 2), counter-clockwise, if the polygon ``xy`` (N, 2) is a parallelogram
    with any number of collinear vertices on its sides; else None."""
    e_in = xy - np.roll(xy, 1, axis=0)
    e_out = np.roll(xy, -1, axis=0) - xy
    turn = e_in[:, 0] * e_out[:, 1] - e_in[:, 1] * e_out[:, 0]
    corners = xy[np.abs(turn) > tol * np.linalg.norm(e_in, axis=1) * np.linalg.norm(e_out, axis=1)]
    if corners.shape[0] != 4:
        return None
    size = np.ptp(xy, axis=0).max()
    return corners if np.allclose(corners[0] + corners[2], corners[1] + corners[3], atol=tol * size) else None


@functools.lru_cache(maxsize=None)
def unit_square_rule(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Tensor Gauss–Legendre rule on [0, 1]², exact for ``degree``: (degree//2 + 1)² points (n, 2),
    weights (n,) summing to 1.

    Not a smaller rule of the same degree: Stroud's 12-point degree-7 rule (instead of 16
    points) made Newton stall in the compressed third medium of the box (mesh 3, gamma = 1e-6,
    at u_y = -0.29), where this rule and the sub-triangle rule converge.
    """
    g, wg = np.polynomial.legendre.leggauss(degree // 2 + 1)
    S, T = np.meshgrid((g + 1) / 2, (g + 1) / 2, indexing="ij")
    return np.column_stack([S.ravel(), T.ravel()]), np.outer(wg / 2, wg / 2).ravel()


def parallelogram_rule(corners: npt.NDArray[np.float64], degree: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`unit_square_rule` mapped to a parallelogram: points (n, 2), weights (n,).

    x(s, t) = c0 + s (c1 - c0) + t (c3 - c0) is affine, so the rule stays exact for ``degree``.
    """
    st, w = unit_square_rule(int(degree))
    e1, e2 = corners[1] - corners[0], corners[3] - corners[0]
    return corners[0] + st[:, :1] * e1 + st[:, 1:] * e2, w * abs(e1[0] * e2[1] - e1[1] * e2[0])


def compress_rule(points: npt.NDArray[np.float64], weights: npt.NDArray[np.float64],
                  degree: int) -> tuple[np.ndarray, np.ndarray]:
    """A subset of ``points`` (n, 2) or (n, 3) with non-negative weights and the same moments up to
    ``degree``.

    Non-negative least squares on the moment equations gives a basic solution with at most
    dim P_degree points ((d + 1)(d + 2)/2 in 2D, (d + 1)(d + 2)(d + 3)/6 in 3D). The input rule is returned when the result
    misses a moment by more than :data:`MOMENT_TOLERANCE` (relative) or is not smaller.
    """
    centre = weights @ points / weights.sum()
    scale = np.ptp(points, axis=0).max()
    V = (scaled_monomials if points.shape[1] == 2 else monomial_matrix3)(points, centre, scale, degree)
    moments = V @ weights
    w, _ = scipy.optimize.nnls(V, moments)
    keep = w > 0.0
    error = np.abs(V[:, keep] @ w[keep] - moments).max() / weights.sum()
    if error > MOMENT_TOLERANCE or keep.sum() >= weights.size:
        return points, weights
    return points[keep], w[keep]


def compressed_polygon_quadrature(points: npt.NDArray[np.float64], offsets: npt.NDArray[np.int64],
                                  vertices: npt.NDArray[np.int64], nodes: npt.NDArray[np.float64],
                                  triangles: npt.NDArray[np.int64], triangle_offsets: npt.NDArray[np.int64],
                                  polygons: npt.NDArray[np.int64], degrees: npt.NDArray[np.integer]):
    """Small positive rules on the given polygons, exact for ``degrees`` (module docstring).

    Parameters
    ----------
    points, offsets, vertices
        The polygon mesh: polygon e has the vertices ``points[vertices[offsets[e]:offsets[e + 1]]]``.
    nodes, triangles, triangle_offsets, polygons, degrees
        As for :func:`polygon_quadrature`, whose rule is compressed (parallelograms get their
        tensor rule).

    Returns
    -------
    q_offsets, x_q, w_q
        As for :func:`polygon_quadrature`. Every weight is positive and every point lies in
        its polygon (closed).
    """
    polygons = np.asarray(polygons, dtype=np.int64)
    degrees = np.asarray(degrees, dtype=np.int64)
    q_offsets, x_q, w_q = polygon_quadrature(nodes, triangles, triangle_offsets, polygons, degrees)
    rules = []
    for k, (e, d) in enumerate(zip(polygons, degrees)):
        corners = parallelogram_corners(points[vertices[offsets[e]:offsets[e + 1]]])
        q = slice(q_offsets[k], q_offsets[k + 1])
        if corners is not None:
            rules.append(parallelogram_rule(corners, d))
        else:
            rules.append(compress_rule(x_q[q], w_q[q], d))
    counts = [w.size for _, w in rules]
    return (np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
            np.vstack([x for x, _ in rules]), np.concatenate([w for _, w in rules]))
