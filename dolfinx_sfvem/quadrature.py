"""Quadrature over polygons: Gauss rules on each polygon's sub-triangles.

The energy integrals of the SFVEM (paper Eqs. 46, 52, 56) are not polynomial, so they
are integrated numerically on the quadrature sub-triangulation of every polygon
(DESIGN §4.4: exact for degree at least 2l, where l is the polygon's projection order).
"""
from __future__ import annotations

import functools

import basix
import numba
import numpy as np
import numpy.typing as npt


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
