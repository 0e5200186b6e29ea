"""Projections of the order-2 SFVEM per polygon: Pi^nabla_2 and Pi^0_l nabla (paper §4.1).

Conventions (shared with the rest of the package)
-------------------------------------------------
Polygon E with N counter-clockwise vertices x_0..x_{N-1}, edge i from x_i to x_{i+1},
midpoints m_i, centroid x_E, diameter h_E (largest vertex distance), scaled monomials
m_a (see :mod:`dolfinx_sfvem.discretizations.monomials`). The nd = 2N + 1 scalar DOFs of v are

    v~ = [v(x_0), ..., v(x_{N-1}), v(m_0), ..., v(m_{N-1}), (1/|E|) int_E v].

Results per polygon
-------------------
``Pi_nabla`` (6, nd)
    Pi^nabla_2 v = sum_a m_a(x) (Pi_nabla v~)_a, the H^1 projection onto P_2 (Eq. 36).
``Pi_m`` (2, nl, nd), nl = (l+1)(l+2)/2
    The L^2 projection of the gradient onto [P_l]^2 (Eqs. 41-43):
    grad v(x) = [m(x) . Pi_m[0] v~, m(x) . Pi_m[1] v~] (Eq. 43) and the second derivatives
    d2v/dx_c dx_d = (dm/dx_d)(x) . Pi_m[c] v~ (Eq. 45, not symmetrised).

The per-polygon functions are ``numba.njit``. What polygons and polyhedra share, the rank check, the
choice of l and the loop over the cells, is :mod:`~dolfinx_sfvem.discretizations.cell_projection`:
this module gives it a polygon through the overloads of ``prepare_cell`` (for
:class:`PolygonCells`) and ``cell_system`` (for :class:`PolygonSystem`), and
:func:`build_projections` returns its :class:`~dolfinx_sfvem.discretizations.cell_projection.Projections`.
"""
from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
import numpy.typing as npt
from numba.extending import overload

from dolfinx_sfvem.discretizations.cell_projection import (
    GEOMETRY_STATUS, OK, RANK_TOL, Projections, build_cell_projections, build_cells, cell_system, is_tuple_of,
    prepare_cell)
from dolfinx_sfvem.discretizations.monomials import (
    evaluate_monomials, exponents, gauss_legendre, monomial_index, n_monomials, polygon_monomial_integrals)


# geometry failures of a polygon (cell_projection.GEOMETRY_STATUS and on)
_NOT_CCW, _ZERO_EDGE = GEOMETRY_STATUS, GEOMETRY_STATUS + 1


# --------------------------------------------------------------------------- geometry
@numba.njit(cache=True)
def polygon_geometry(xy: np.ndarray) -> tuple[float, np.ndarray, float]:
    """Signed area, centroid and diameter of a polygon.

    Parameters
    ----------
    xy : (N, 2) float64
        Vertices.

    Returns
    -------
    area : float
        Signed area (positive for counter-clockwise vertices).
    x_E : (2,) float64
        Area centroid.
    h_E : float
        Diameter, the largest distance between two vertices.
    """
    N = xy.shape[0]
    area = 0.0
    x_E = np.zeros(2)
    for i in range(N):  # shoelace, relative to x_0 for round-off
        a0 = xy[i] - xy[0]
        a1 = xy[(i + 1) % N] - xy[0]
        cross = a0[0] * a1[1] - a1[0] * a0[1]
        area += 0.5 * cross
        x_E += (a0 + a1) * cross / 6.0
    x_E = xy[0] + x_E / area
    h_E = 0.0
    for i in range(N):
        for j in range(i + 1, N):
            h_E = max(h_E, np.sqrt((xy[i, 0] - xy[j, 0]) ** 2 + (xy[i, 1] - xy[j, 1]) ** 2))
    return area, x_E, h_E


@numba.njit(cache=True)
def _polygon_status(xy: np.ndarray) -> int:
    """OK, or why the vertices are not a counter-clockwise polygon with N >= 3 distinct corners."""
    N = xy.shape[0]
    for i in range(N):
        if xy[i, 0] == xy[(i + 1) % N, 0] and xy[i, 1] == xy[(i + 1) % N, 1]:
            return _ZERO_EDGE
    area, _, _ = polygon_geometry(xy)
    return OK if area > 0.0 else _NOT_CCW


# --------------------------------------------------------------------------- Pi^nabla_2
@numba.njit(cache=True)
def pi_nabla_2(xy: np.ndarray, x_E: np.ndarray, h_E: float, area: float) -> np.ndarray:
    """Matrix of the H^1 projection Pi^nabla_2 onto P_2 (Eq. 36), G Pi_nabla = B.

    Rows a >= 1: int_E grad(Pi v) . grad m_a = int_E grad v . grad m_a
    = -Lap(m_a) |E| mean(v) + sum_e int_e (dm_a/dn) v (docs/method.md §2); v is quadratic and
    dm_a/dn linear on an edge, so Simpson's rule (|e|/6, 4|e|/6, |e|/6) at
    (x_i, m_i, x_{i+1}) is exact. Row 0: equal means (second line of Eq. 36).

    Parameters
    ----------
    xy : (N, 2) float64
        Counter-clockwise vertices.
    x_E : (2,) float64
        Centroid.
    h_E : float
        Diameter.
    area : float
        |E|.

    Returns
    -------
    Pi_nabla : (6, 2N+1) float64
        Pi^nabla_2 v = sum_a m_a (Pi_nabla v~)_a.
    """
    N = xy.shape[0]
    nd = 2 * N + 1
    integrals = polygon_monomial_integrals(xy, x_E, h_E, 2)
    alpha = exponents(2)
    G = np.zeros((6, 6))
    B = np.zeros((6, nd))
    for b in range(6):
        G[0, b] = integrals[b] / area
    B[0, 2 * N] = 1.0
    for a in range(1, 6):
        pa, qa = alpha[a, 0], alpha[a, 1]
        for b in range(1, 6):
            pb, qb = alpha[b, 0], alpha[b, 1]
            if pa * pb > 0:
                G[a, b] += pa * pb * integrals[monomial_index(pa + pb - 2, qa + qb)] / h_E ** 2
            if qa * qb > 0:
                G[a, b] += qa * qb * integrals[monomial_index(pa + pb, qa + qb - 2)] / h_E ** 2
        laplacian = (pa * (pa - 1) + qa * (qa - 1)) / h_E ** 2  # constant for degree <= 2
        B[a, 2 * N] = -laplacian * area
    m = np.empty(6)
    dm_dx = np.empty(6)
    dm_dy = np.empty(6)
    x = np.empty(2)
    simpson = np.array([1.0, 4.0, 1.0]) / 6.0
    for i in range(N):
        x0 = xy[i]
        x1 = xy[(i + 1) % N]
        dofs = (i, N + i, (i + 1) % N)  # nodes x_i, m_i, x_{i+1}
        for s in range(3):
            x[:] = x0 + 0.5 * s * (x1 - x0)
            evaluate_monomials(x, x_E, h_E, 2, m, dm_dx, dm_dy)
            for a in range(1, 6):
                # |e| dm_a/dn with |e| n = (dy, -dx)
                B[a, dofs[s]] += simpson[s] * (dm_dx[a] * (x1[1] - x0[1]) - dm_dy[a] * (x1[0] - x0[0]))
    return np.linalg.solve(G, B)


# --------------------------------------------------------------------------- Pi^0_l nabla
@numba.njit(cache=True)
def projection_system(xy: np.ndarray, x_E: np.ndarray, h_E: float, Pi_nabla: np.ndarray,
                      l: int) -> tuple[np.ndarray, np.ndarray]:
    """Mass matrix and right sides of the L^2 gradient projection (Eqs. 41-42).

    M c_c = r_c with M_ab = int_E m_a m_b (a, b in P_l) and

        (r_c)_a = int_dE m_a n_c v - int_E (dm_a/dx_c) Pi^nabla_2 v         (Eq. 42)

    (enhanced space: the interior term uses Pi^nabla_2 v, docs/method.md §2). On each edge v is
    quadratic through v(x_i), v(m_i), v(x_{i+1}) and m_a of degree l, so Gauss-Legendre with
    (l+2)//2 + 1 points is exact (3 points are not for l >= 4). The volume integrals are
    exact monomial integrals of degree <= 2l.

    Parameters
    ----------
    xy : (N, 2) float64
        Counter-clockwise vertices.
    x_E, h_E
        Centroid (2,) and diameter.
    Pi_nabla : (6, 2N+1) float64
        From :func:`pi_nabla_2`.
    l : int
        Degree of the projection, >= 1.

    Returns
    -------
    M : (nl, nl) float64
        P_l mass matrix.
    R : (2, nl, 2N+1) float64
        R[c] v~ = r_c.
    """
    N = xy.shape[0]
    nd = 2 * N + 1
    nl = n_monomials(l)
    integrals = polygon_monomial_integrals(xy, x_E, h_E, 2 * l)
    alpha = exponents(l)
    M = np.empty((nl, nl))
    for a in range(nl):
        for b in range(nl):
            M[a, b] = integrals[monomial_index(alpha[a, 0] + alpha[b, 0], alpha[a, 1] + alpha[b, 1])]
    R = np.zeros((2, nl, nd))
    # boundary term: sum_e int_e m_a n v, v from the quadratic Lagrange basis of the edge
    t, w = gauss_legendre((l + 2) // 2 + 1)
    m = np.empty(nl)
    dm_dx = np.empty(nl)
    dm_dy = np.empty(nl)
    x = np.empty(2)
    for i in range(N):
        x0 = xy[i]
        x1 = xy[(i + 1) % N]
        dofs = (i, N + i, (i + 1) % N)
        for g in range(t.size):
            s = t[g]
            phi = ((1.0 - s) * (1.0 - 2.0 * s), 4.0 * s * (1.0 - s), s * (2.0 * s - 1.0))
            x[:] = x0 + s * (x1 - x0)
            evaluate_monomials(x, x_E, h_E, l, m, dm_dx, dm_dy)
            for a in range(nl):
                for j in range(3):  # |e| n = (dy, -dx)
                    R[0, a, dofs[j]] += w[g] * m[a] * phi[j] * (x1[1] - x0[1])
                    R[1, a, dofs[j]] -= w[g] * m[a] * phi[j] * (x1[0] - x0[0])
    # interior term: - int_E (dm_a/dx_c) m_b (Pi_nabla v~)_b, dm_a/dx = p xi^(p-1) eta^q / h_E
    alpha_2 = exponents(2)
    for a in range(nl):
        pa, qa = alpha[a, 0], alpha[a, 1]
        for b in range(6):
            pb, qb = alpha_2[b, 0], alpha_2[b, 1]
            dx_moment = pa / h_E * integrals[monomial_index(pa - 1 + pb, qa + qb)] if pa > 0 else 0.0
            dy_moment = qa / h_E * integrals[monomial_index(pa + pb, qa - 1 + qb)] if qa > 0 else 0.0
            for k in range(nd):
                R[0, a, k] -= dx_moment * Pi_nabla[b, k]
                R[1, a, k] -= dy_moment * Pi_nabla[b, k]
    return M, R




# --------------------------------------------------------------------------- a polygon as a cell
class PolygonCells(NamedTuple):
    """The polygons of a mesh as cells of :func:`~dolfinx_sfvem.discretizations.cell_projection.build_cells`.

    Attributes
    ----------
    points : (n_points, 2) float64
    offsets : (n_poly + 1,) int64
        CSR offsets: polygon e has vertices[offsets[e]:offsets[e+1]], counter-clockwise.
    vertices : (offsets[-1],) int64
    """

    points: np.ndarray
    offsets: np.ndarray
    vertices: np.ndarray


class PolygonSystem(NamedTuple):
    """What :func:`projection_system` needs of one polygon.

    Attributes
    ----------
    xy : (N, 2) float64
        Counter-clockwise vertices.
    centroid : (2,) float64
    diameter : float
    Pi_nabla : (6, 2N+1) float64
        :func:`pi_nabla_2`.
    """

    xy: np.ndarray
    centroid: np.ndarray
    diameter: float
    Pi_nabla: np.ndarray


@numba.njit(cache=True)
def _prepare_polygon(mesh, e, tol):
    """``prepare_cell`` of polygon e: (status, vertices, area, PolygonSystem)."""
    vertices = mesh.vertices[mesh.offsets[e]:mesh.offsets[e + 1]]
    xy = mesh.points[vertices]
    status = _polygon_status(xy)
    if status != OK:
        return status, vertices, 0.0, PolygonSystem(xy, np.zeros(2), 0.0, np.zeros((6, 2 * xy.shape[0] + 1)))
    area, x_E, h_E = polygon_geometry(xy)
    Pi_nabla = np.ascontiguousarray(pi_nabla_2(xy, x_E, h_E, area))  # C order, as the failure's zeros
    return status, vertices, area, PolygonSystem(xy, x_E, h_E, Pi_nabla)


@overload(prepare_cell)
def _prepare_cell_polygon(mesh, cell, tol):
    if is_tuple_of(mesh, PolygonCells):
        return lambda mesh, cell, tol: _prepare_polygon(mesh, cell, tol)


@overload(cell_system)
def _cell_system_polygon(system, l):
    if is_tuple_of(system, PolygonSystem):
        return lambda system, l: projection_system(system.xy, system.centroid, system.diameter, system.Pi_nabla, l)


# --------------------------------------------------------------------------- input checks and errors
def polygon_error(xy: npt.NDArray[np.float64], e: int, status: int) -> ValueError:
    """The error for polygon e whose vertices xy (N, 2) have the geometry status ``status`` (not OK)."""
    if status == _ZERO_EDGE:
        return ValueError(f"polygon {e}: two consecutive vertices coincide")
    return ValueError(f"polygon {e}: vertices are not counter-clockwise (signed area {polygon_geometry(xy)[0]:.3e})")


def validate_polygon(xy: npt.NDArray[np.float64], e: int = 0) -> None:
    """Raise ValueError (naming polygon e) unless xy (N, 2) is a counter-clockwise polygon, N >= 3."""
    if xy.ndim != 2 or xy.shape[1] != 2 or xy.shape[0] < 3:
        raise ValueError(f"polygon {e}: need an (N, 2) vertex array with N >= 3, got shape {xy.shape}")
    xy = np.ascontiguousarray(xy, dtype=np.float64)
    status = _polygon_status(xy)
    if status != OK:
        raise polygon_error(xy, e, status)


def _check_csr(points: np.ndarray, offsets: np.ndarray, vertices: np.ndarray) -> None:
    if points.ndim != 2 or points.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {points.shape}")
    if offsets.ndim != 1 or offsets.size < 1 or offsets[0] != 0 or offsets[-1] != vertices.size:
        raise ValueError("offsets must be a CSR offset array: offsets[0] == 0 and offsets[-1] == len(vertices)")
    counts = np.diff(offsets)
    if np.any(counts < 3):
        e = int(np.flatnonzero(counts < 3)[0])
        raise ValueError(f"polygon {e}: {counts[e]} vertices, at least 3 needed")
    if vertices.size and (vertices.min() < 0 or vertices.max() >= points.shape[0]):
        raise ValueError(f"vertices must index points (0..{points.shape[0] - 1})")


def build_projections(points: npt.ArrayLike, offsets: npt.ArrayLike, vertices: npt.ArrayLike,
                      polygons: npt.ArrayLike | None = None, l: int | npt.ArrayLike | None = None,
                      l_min: int = 3, l_max: int = 10) -> Projections:
    """Pi^nabla_2 and Pi^0_l nabla of many polygons (one numba loop over all of them).

    Parameters
    ----------
    points : (n_points, 2) float64
        Coordinates.
    offsets : (n_poly + 1,) int
        CSR offsets: polygon e has vertices[offsets[e]:offsets[e+1]], counter-clockwise.
    vertices : (offsets[-1],) int
        Vertex indices into ``points``.
    polygons : (n,) int, optional
        Polygons to build (default all); the result is indexed 0..n-1 in this order.
    l : int or (n,) int, optional
        Degree of the gradient projection, for all polygons or per built polygon (in the
        order of ``polygons``). It must be sufficient for every polygon. Default: per
        polygon the smallest sufficient l >= l_min (docs/method.md §3,
        :func:`~dolfinx_sfvem.discretizations.cell_projection.select_l`).
    l_min : int
        Smallest l tried by the automatic choice (the paper uses 3).
    l_max : int
        Largest l allowed (scaled monomials of higher degree get ill-conditioned: the patch
        test loses about one digit per degree above 7).

    Returns
    -------
    Projections
        Of the polygons (d = 2), their areas as ``measure``.

    Raises
    ------
    ValueError
        Naming the first bad polygon: fewer than 3 vertices, coinciding consecutive vertices,
        not counter-clockwise (``polygon N: ...``), or as ``cell N: ...``
        (:func:`~dolfinx_sfvem.discretizations.cell_projection.projection_error`) a given l that is
        rank-deficient (with the smallest sufficient l), no sufficient l <= l_max, or a numerically
        singular mass matrix.
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    offsets = np.ascontiguousarray(offsets, dtype=np.int64)
    vertices = np.ascontiguousarray(vertices, dtype=np.int64)
    _check_csr(points, offsets, vertices)
    n_poly = offsets.size - 1
    polygons = np.arange(n_poly) if polygons is None else np.asarray(polygons)
    polygons = np.ascontiguousarray(polygons, dtype=np.int64)
    if polygons.ndim != 1 or (polygons.size and (polygons.min() < 0 or polygons.max() >= n_poly)):
        raise ValueError(f"polygons must be a 1D array of polygon indices in [0, {n_poly})")

    def geometry_error(e: int, status: int) -> ValueError:
        return polygon_error(points[vertices[offsets[e]:offsets[e + 1]]], e, status)

    return build_cell_projections(PolygonCells(points, offsets, vertices), polygons, 2, l, l_min, l_max,
                                  geometry_error)


def without_sufficient_order(points: npt.NDArray[np.float64], offsets: npt.NDArray[np.int64],
                             vertices: npt.NDArray[np.int64], polygons: npt.NDArray[np.int64],
                             l_from: int, l_to: int) -> npt.NDArray[np.bool_]:
    """Mask (polygons.size,) bool: no projection order l_from <= l <= l_to passes the rank check
    of :func:`~dolfinx_sfvem.discretizations.cell_projection.select_l` (tolerance
    :data:`~dolfinx_sfvem.discretizations.cell_projection.RANK_TOL`) for the polygon, or it is not a
    valid counter-clockwise polygon.

    ``points`` (n_points, 2) float64, ``offsets`` (n_poly + 1,) int64 and ``vertices`` int64 as
    in :func:`build_projections`; ``polygons`` (n,) int64 the polygons checked.
    """
    n = polygons.size
    status = build_cells(PolygonCells(points, offsets, vertices), polygons, 2, np.full(n, l_from, dtype=np.int64),
                         np.full(n, l_to, dtype=np.int64), RANK_TOL)[0]
    return status != OK
