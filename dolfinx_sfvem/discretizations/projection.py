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

The per-polygon functions are ``numba.njit``; :func:`build_projections` loops over all
polygons inside numba and returns the flattened :class:`Projections`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
import numpy.typing as npt

from dolfinx_sfvem.discretizations.monomials import (
    evaluate_monomials, exponents, gauss_legendre, monomial_index, n_monomials, polygon_monomial_integrals)

#: Relative tolerance on singular values (sigma <= RANK_TOL * sigma_max counts as zero) of the
#: projected-gradient operators in the L^2(E)-orthonormal polynomial basis, applied as
#: RANK_TOL^2 to the eigenvalues of their Gram matrices. Measured on the test polygons for
#: l = 2..10: exact null-space modes at lambda / lambda_max <= 1e-15 (sigma <= 3e-8), the smallest
#: genuine ones at lambda / lambda_max >= 7e-6 (sigma >= 2.6e-3); RANK_TOL^2 = 9e-12 lies
#: between with more than three orders of magnitude on both sides. Genuinely weak modes below
#: RANK_TOL do occur: an edge shorter than about 1e-5 h_E, or collinear vertices a few per cent
#: of h_E apart (sigma ~ 1e-6 for three hanging nodes 0.02 h_E apart at l = 6); such a polygon
#: gets a larger l or, beyond l_max, an error.
RANK_TOL = 3e-6

#: Smallest admissible relative Cholesky pivot of the monomial mass matrix, d_j / M_jj (the
#: squared sine of the angle between m_j and the span of the monomials before it). Honest
#: polygons stay above 1e-7 up to l = 10; below 1e-12 the orthonormalised moments lose more than
#: 6 digits, so null-space modes could no longer be told from RANK_TOL (thin, rotated slivers).
MASS_PIVOT_TOL = 1e-12

# status of a polygon after the l-selection pass
_OK, _NOT_CCW, _ZERO_EDGE, _SINGULAR_MASS, _RANK_DEFICIENT = 0, 1, 2, 3, 4


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
    """_OK, or why the vertices are not a counter-clockwise polygon with N >= 3 distinct corners."""
    N = xy.shape[0]
    for i in range(N):
        if xy[i, 0] == xy[(i + 1) % N, 0] and xy[i, 1] == xy[(i + 1) % N, 1]:
            return _ZERO_EDGE
    area, _, _ = polygon_geometry(xy)
    return _OK if area > 0.0 else _NOT_CCW


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


@numba.njit(cache=True)
def cholesky(M: np.ndarray) -> tuple[np.ndarray, bool]:
    """Lower Cholesky factor L of M = L L^T, and False if a relative pivot is below MASS_PIVOT_TOL."""
    n = M.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        d = M[j, j]
        for k in range(j):
            d -= L[j, k] ** 2
        if not d > MASS_PIVOT_TOL * M[j, j]:
            return L, False
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, n):
            s = M[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / L[j, j]
    return L, True


@numba.njit(cache=True)
def orthonormal_moments(L: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Q[c] = L^{-1} R[c]: the projected gradient in the L^2(E)-orthonormal basis L^{-1} m.

    With M = L L^T, ||Pi^0_l d_c v||_{L^2(E)} = |Q[c] v~| for every v, so singular values
    of Q do not depend on the (ill-conditioned) monomial basis.

    Parameters
    ----------
    L : (nl, nl) float64
        Cholesky factor of M.
    R : (D, nl, nd) float64
        From :func:`projection_system` (D = 2) or the polyhedron's system (D = 3).

    Returns
    -------
    Q : (D, nl, nd) float64
    """
    nl = L.shape[0]
    Q = R.copy()
    for c in range(R.shape[0]):
        for a in range(nl):  # forward substitution
            for b in range(a):
                for k in range(Q.shape[2]):
                    Q[c, a, k] -= L[a, b] * Q[c, b, k]
            for k in range(Q.shape[2]):
                Q[c, a, k] /= L[a, a]
    return Q


@numba.njit(cache=True)
def gradient_projection(L: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Pi_m[c] = M^{-1} R[c] = L^{-T} Q[c], the monomial coefficients of Pi^0_l nabla (Eq. 43).

    Returns
    -------
    Pi_m : (D, nl, nd) float64
    """
    nl = L.shape[0]
    Pi_m = Q.copy()
    for c in range(Q.shape[0]):
        for a in range(nl - 1, -1, -1):  # back substitution with L^T
            for b in range(a + 1, nl):
                for k in range(Q.shape[2]):
                    Pi_m[c, a, k] -= L[b, a] * Pi_m[c, b, k]
            for k in range(Q.shape[2]):
                Pi_m[c, a, k] /= L[a, a]
    return Pi_m


@numba.njit(cache=True)
def _tridiagonal_form(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Householder reduction of a symmetric matrix to tridiagonal form (same eigenvalues).

    Only the lower triangle of A is read.

    Returns
    -------
    d : (n,) float64
        Diagonal.
    e : (n-1,) float64
        Off-diagonal.
    """
    A = A.copy()  # only the lower triangle is used and updated
    n = A.shape[0]
    e = np.zeros(max(n - 1, 0))
    v = np.zeros(n)
    p = np.zeros(n)
    for k in range(n - 2):
        # reflector H = I - 2 v v^T (|v| = 1) mapping A[k+1:, k] to alpha e_1
        norm2 = 0.0
        for i in range(k + 1, n):
            norm2 += A[i, k] ** 2
        alpha = -np.sqrt(norm2) if A[k + 1, k] > 0.0 else np.sqrt(norm2)
        e[k] = alpha
        v_norm2 = norm2 - 2.0 * alpha * A[k + 1, k] + alpha ** 2  # |A[k+1:, k] - alpha e_1|^2
        if v_norm2 == 0.0:
            continue
        for i in range(k + 1, n):
            v[i] = A[i, k] / np.sqrt(v_norm2)
        v[k + 1] -= alpha / np.sqrt(v_norm2)
        # A22 <- H A22 H = A22 - 2 v w^T - 2 w v^T with p = A22 v, w = p - (v.p) v
        vp = 0.0
        for i in range(k + 1, n):
            p[i] = 0.0
            for j in range(k + 1, i + 1):
                p[i] += A[i, j] * v[j]
            for j in range(i + 1, n):
                p[i] += A[j, i] * v[j]
            vp += v[i] * p[i]
        for i in range(k + 1, n):
            p[i] -= vp * v[i]
        for i in range(k + 1, n):
            for j in range(k + 1, i + 1):
                A[i, j] -= 2.0 * (v[i] * p[j] + p[i] * v[j])
    if n >= 2:
        e[n - 2] = A[n - 1, n - 2]
    return np.diag(A).copy(), e


@numba.njit(cache=True)
def _eigenvalues_below(d: np.ndarray, e: np.ndarray, x: float) -> int:
    """Number of eigenvalues < x of the symmetric tridiagonal (d, e) (Sturm sequence / inertia)."""
    count = 0
    q = 1.0
    for i in range(d.size):
        q = d[i] - x - (e[i - 1] ** 2 / q if i > 0 else 0.0)
        if q == 0.0:
            q = -1e-300
        if q < 0.0:
            count += 1
    return count


@numba.njit(cache=True)
def count_zero_eigenvalues(A: np.ndarray, tol: float) -> int:
    """Number of eigenvalues lambda <= tol * lambda_max of a symmetric positive semi-definite A.

    Tridiagonal form plus Sylvester's law of inertia; lambda_max by bisection to 1e-3
    relative. (A fraction of the cost of a LAPACK eigen- or singular-value solve for these
    sizes with Debian's reference LAPACK.)
    """
    d, e = _tridiagonal_form(A)
    n = d.size
    upper = 0.0  # Gershgorin bound, lambda_max <= upper <= 3 lambda_max
    for i in range(n):
        upper = max(upper, d[i] + (abs(e[i - 1]) if i > 0 else 0.0) + (abs(e[i]) if i < n - 1 else 0.0))
    lower = 0.0
    while upper - lower > 1e-3 * upper:
        middle = 0.5 * (lower + upper)
        if _eigenvalues_below(d, e, middle) == n:
            upper = middle
        else:
            lower = middle
    return _eigenvalues_below(d, e, tol * upper)


@numba.njit(cache=True)
def null_space_dimensions(Q: np.ndarray, tol: float) -> tuple[int, int]:
    """Null-space dimensions of the scalar projected gradient and of the projected small strain.

    In the orthonormal basis of :func:`orthonormal_moments`, with D = Q.shape[0] the space
    dimension, int_E |Pi grad v|^2 = v~^T (sum_c Q_c^T Q_c) v~ and
    int_E sym(Pi grad u) : sym(Pi grad u) = u~^T A u~ with the D x D blocks
    A_cc = Q_c^T Q_c + 1/2 sum_{d != c} Q_d^T Q_d and A_cd = Q_d^T Q_c / 2 (c != d)
    (the linear-elastic element stiffness for mu = 1/2, lambda = 0). A mode counts as zero when
    its eigenvalue is <= tol^2 lambda_max, i.e. its singular value in the projected
    operator is <= tol sigma_max.

    Parameters
    ----------
    Q : (D, nl, nd) float64
        From :func:`orthonormal_moments`, D = 2 on a polygon, 3 on a polyhedron.
    tol : float
        Relative singular-value tolerance.

    Returns
    -------
    gradient_nullity : int
        dim ker(v~ -> Pi^0_l grad v) on the nd scalar DOFs; 1 (the constants) is right.
    strain_nullity : int
        dim ker(u~ -> sym Pi^0_l grad u) on the D nd vector DOFs (u_x DOFs, then u_y, ...);
        D(D+1)/2 (the rigid motions: 3 in 2D, 6 in 3D) is right. These are the zero eigenvalues
        of the linear-elastic element stiffness (docs/method.md §3 table, §8).
    """
    D = Q.shape[0]
    nd = Q.shape[2]
    gradient = np.zeros((nd, nd))
    for c in range(D):
        gradient += Q[c].T @ Q[c]
    A = np.zeros((D * nd, D * nd))
    for c in range(D):
        A[c * nd:(c + 1) * nd, c * nd:(c + 1) * nd] = 0.5 * gradient + 0.5 * (Q[c].T @ Q[c])
        for d in range(D):
            if d != c:
                A[c * nd:(c + 1) * nd, d * nd:(d + 1) * nd] = 0.5 * (Q[d].T @ Q[c])
    return count_zero_eigenvalues(gradient, tol ** 2), count_zero_eigenvalues(A, tol ** 2)


@numba.njit(cache=True)
def rank_of_projection(M: np.ndarray, R: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray, int, int]:
    """The rank check of one projection system M Pi_m[c] = R[c] (polygon or polyhedron).

    Returns
    -------
    L : (nl, nl) float64
        Cholesky factor of M.
    Q : (D, nl, nd) float64
        :func:`orthonormal_moments`; R itself when M is singular.
    gradient_nullity, strain_nullity : int
        :func:`null_space_dimensions`; both -1 if M is numerically singular (:func:`cholesky`).
    """
    L, mass_ok = cholesky(M)
    if not mass_ok:
        return L, R, -1, -1
    Q = orthonormal_moments(L, R)
    gradient_nullity, strain_nullity = null_space_dimensions(Q, tol)
    return L, Q, gradient_nullity, strain_nullity


@numba.njit(cache=True)
def select_l(xy: np.ndarray, x_E: np.ndarray, h_E: float, Pi_nabla: np.ndarray, l_from: int, l_to: int,
             tol: float) -> tuple[int, int, int, np.ndarray, np.ndarray]:
    """Smallest sufficient l in [l_from, l_to] (docs/method.md §3), with its factors L and Q.

    l is sufficient when the projected small strain u~ -> sym Pi^0_l grad u has exactly the
    3 rigid motions in its null space *and* the projected gradient v~ -> Pi^0_l grad v only the
    constants (rank 2N on the scalar DOFs). The strain criterion is the strict one and the
    one that matters: a non-constant scalar null-space mode v gives the non-rigid, strain-free
    field (v, 0), so strain-sufficient implies gradient-sufficient, but not conversely (the
    U-shaped octagon of the tests at l = 3: gradient nullity 1, strain nullity 5). docs/method.md's
    table counts zero eigenvalues of the linear-elastic stiffness, i.e. the strain null space.
    Checking both costs little and guards the implication against tolerance artefacts.
    The null space shrinks as l grows (P_l is contained in P_{l+1}), so the first sufficient l is
    the smallest. An l with 3 nl < 2(2N+1) - 3 cannot be sufficient (too few strain
    components) and is skipped without computing, unless it is l_to.

    Parameters
    ----------
    xy : (N, 2) float64
        Counter-clockwise vertices.
    x_E, h_E
        Centroid (2,) and diameter.
    Pi_nabla : (6, 2N+1) float64
        From :func:`pi_nabla_2`.
    l_from, l_to : int
        Range of l tried, 1 <= l_from <= l_to.
    tol : float
        Relative singular-value tolerance (:data:`RANK_TOL`).

    Returns
    -------
    l : int
        The first sufficient l; else l_to, or the l whose mass matrix is singular.
    gradient_nullity, strain_nullity : int
        Null-space dimensions at l (:func:`null_space_dimensions`); both -1 if the P_l mass matrix
        is numerically singular (:func:`cholesky`).
    L : (nl, nl) float64
        Cholesky factor of the P_l mass matrix.
    Q : (2, nl, 2N+1) float64
        :func:`orthonormal_moments` at l.
    """
    l = l_from
    N = xy.shape[0]
    while True:
        if 3 * n_monomials(l) < 4 * N - 1 and l < l_to:
            l += 1  # rank(sym Pi grad) <= 3 nl < 2(2N+1) - 3: insufficient by counting alone
            continue
        M, R = projection_system(xy, x_E, h_E, Pi_nabla, l)
        L, Q, gradient_nullity, strain_nullity = rank_of_projection(M, R, tol)
        if gradient_nullity == -1 or (gradient_nullity == 1 and strain_nullity == 3) or l == l_to:
            return l, gradient_nullity, strain_nullity, L, Q
        l += 1


# --------------------------------------------------------------------------- bulk build
@numba.njit(cache=True)
def _build_all(points, offsets, vertices, polygons, l_from, l_to, tol, Pi_nabla_offsets):
    """One loop over the selected polygons: status, l, nullities, geometry, Pi_nabla, Pi_m.

    A polygon with status != _OK gets an empty Pi_m block (the caller raises).
    """
    n = polygons.size
    status = np.zeros(n, dtype=np.int32)
    l = np.zeros(n, dtype=np.int32)
    nullities = np.zeros((n, 2), dtype=np.int64)
    centroid = np.zeros((n, 2))
    diameter = np.zeros(n)
    area = np.zeros(n)
    Pi_nabla_flat = np.zeros(Pi_nabla_offsets[-1])
    Pi_m_offsets = np.zeros(n + 1, dtype=np.int64)
    l_guess = l_from.min() if n > 0 else 1
    Pi_m_flat = np.empty(2 * n_monomials(l_guess) * (Pi_nabla_offsets[-1] // 6))  # grows when needed
    for j in range(n):
        e = polygons[j]
        xy = points[vertices[offsets[e]:offsets[e + 1]]]
        Pi_m_offsets[j + 1] = Pi_m_offsets[j]
        status[j] = _polygon_status(xy)
        if status[j] != _OK:
            continue
        area[j], x_E, diameter[j] = polygon_geometry(xy)
        centroid[j] = x_E
        Pi_nabla = pi_nabla_2(xy, x_E, diameter[j], area[j])
        Pi_nabla_flat[Pi_nabla_offsets[j]:Pi_nabla_offsets[j + 1]] = Pi_nabla.ravel()
        l[j], nullities[j, 0], nullities[j, 1], L, Q = select_l(xy, x_E, diameter[j], Pi_nabla, l_from[j], l_to[j], tol)
        if nullities[j, 0] == -1:
            status[j] = _SINGULAR_MASS
        elif nullities[j, 0] != 1 or nullities[j, 1] != 3:
            status[j] = _RANK_DEFICIENT
        if status[j] != _OK:
            continue
        Pi_m = gradient_projection(L, Q).ravel()
        end = Pi_m_offsets[j] + Pi_m.size
        if end > Pi_m_flat.size:
            grown = np.empty(max(2 * Pi_m_flat.size, end))
            grown[:Pi_m_offsets[j]] = Pi_m_flat[:Pi_m_offsets[j]]
            Pi_m_flat = grown
        Pi_m_flat[Pi_m_offsets[j]:end] = Pi_m
        Pi_m_offsets[j + 1] = end
    return status, l, nullities, centroid, diameter, area, Pi_nabla_flat, Pi_m_offsets, Pi_m_flat[:Pi_m_offsets[-1]]


class ProjectionBlocks:
    """The per-cell views of flattened projections, in any dimension d (the polygons' :class:`Projections`
    and the polyhedra's :class:`~dolfinx_sfvem.discretizations.projection3d.Projections3D`): needs the attributes
    ``l``, ``centroid`` (n, d), ``Pi_nabla_offsets``, ``Pi_nabla``, ``Pi_m_offsets``, ``Pi_m``."""

    def Pi_nabla_of(self, j: int) -> npt.NDArray[np.float64]:
        """Pi_nabla of cell j, (dim P_2, n_d_j): (6, n_d_j) in 2D, (10, n_d_j) in 3D (a view)."""
        d = self.centroid.shape[1]
        return self.Pi_nabla[self.Pi_nabla_offsets[j]:self.Pi_nabla_offsets[j + 1]].reshape(math.comb(2 + d, d), -1)

    def Pi_m_of(self, j: int) -> npt.NDArray[np.float64]:
        """Pi_m of cell j, (d, dim P_l_j, n_d_j) (a view)."""
        d = self.centroid.shape[1]
        block = self.Pi_m[self.Pi_m_offsets[j]:self.Pi_m_offsets[j + 1]]
        return block.reshape(d, math.comb(int(self.l[j]) + d, d), -1)

    def histogram(self) -> dict[int, int]:
        """Number of cells per degree l, {l: count}, increasing l."""
        values, counts = np.unique(self.l, return_counts=True)
        return {int(v): int(c) for v, c in zip(values, counts)}


@dataclass(frozen=True)
class Projections(ProjectionBlocks):
    """Pi^nabla_2 and Pi^0_l nabla of a set of polygons, flattened for the compiled loops.

    Polygon j (0..n-1, in the order they were built) has nd_j = 2 N_j + 1 scalar DOFs
    (module docstring) and nl_j = (l_j + 1)(l_j + 2)/2 monomials.

    Attributes
    ----------
    l : (n,) int32
        Degree of the gradient projection per polygon.
    centroid : (n, 2) float64
        x_E, the centre of the scaled monomials.
    diameter : (n,) float64
        h_E, the scaling of the monomials.
    area : (n,) float64
        |E|.
    Pi_nabla_offsets : (n+1,) int64
    Pi_nabla : (Pi_nabla_offsets[-1],) float64
        Pi_nabla[Pi_nabla_offsets[j]:Pi_nabla_offsets[j+1]] reshapes (C order) to (6, nd_j).
    Pi_m_offsets : (n+1,) int64
    Pi_m : (Pi_m_offsets[-1],) float64
        Pi_m[Pi_m_offsets[j]:Pi_m_offsets[j+1]] reshapes (C order) to (2, nl_j, nd_j).
    """

    l: npt.NDArray[np.int32]
    centroid: npt.NDArray[np.float64]
    diameter: npt.NDArray[np.float64]
    area: npt.NDArray[np.float64]
    Pi_nabla_offsets: npt.NDArray[np.int64]
    Pi_nabla: npt.NDArray[np.float64]
    Pi_m_offsets: npt.NDArray[np.int64]
    Pi_m: npt.NDArray[np.float64]

    @property
    def n_polygons(self) -> int:
        return self.l.size

    def summary(self) -> str:
        """One line: polygon count and the distribution of l."""
        parts = ", ".join(f"l={k}: {c} ({100.0 * c / self.n_polygons:.1f}%)" for k, c in self.histogram().items())
        return f"SFVEM projections of {self.n_polygons} polygons; {parts}"


# --------------------------------------------------------------------------- input checks and errors
def validate_polygon(xy: npt.NDArray[np.float64], e: int = 0) -> None:
    """Raise ValueError (naming polygon e) unless xy (N, 2) is a counter-clockwise polygon, N >= 3."""
    if xy.ndim != 2 or xy.shape[1] != 2 or xy.shape[0] < 3:
        raise ValueError(f"polygon {e}: need an (N, 2) vertex array with N >= 3, got shape {xy.shape}")
    status = _polygon_status(np.ascontiguousarray(xy, dtype=np.float64))
    if status == _ZERO_EDGE:
        raise ValueError(f"polygon {e}: two consecutive vertices coincide")
    if status == _NOT_CCW:
        raise ValueError(f"polygon {e}: vertices are not counter-clockwise (signed area "
                         f"{polygon_geometry(xy)[0]:.3e})")


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


def _l_range(l: int | npt.ArrayLike | None, n: int, l_min: int, l_max: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-polygon range [l_from, l_to] searched by :func:`select_l`."""
    if not 1 <= l_min <= l_max:
        raise ValueError(f"need 1 <= l_min <= l_max, got l_min={l_min}, l_max={l_max}")
    if l is None:
        return np.full(n, l_min, dtype=np.int64), np.full(n, l_max, dtype=np.int64)
    l_given = np.asarray(l)
    if not np.issubdtype(l_given.dtype, np.integer) or l_given.ndim > 1 or l_given.ndim == 1 and l_given.size != n:
        raise ValueError(f"l must be an int or one int per built polygon ({n}), got {l!r}")
    l_given = np.broadcast_to(l_given.astype(np.int64), (n,)).copy()
    bad = np.flatnonzero((l_given < 1) | (l_given > l_max))
    if bad.size:
        raise ValueError(f"l={l_given[bad[0]]} (built polygon {bad[0]}) is outside [1, l_max={l_max}]; "
                         "raise l_max to allow it")
    return l_given, l_given


def _rank_error(e: int, xy: np.ndarray, status: int, l: int, nullities: np.ndarray, l_given: bool,
                l_max: int) -> ValueError:
    """The error for polygon e (mesh index) whose l is not sufficient."""
    if status == _SINGULAR_MASS:
        return ValueError(f"polygon {e}: the P_{l} monomial mass matrix is numerically singular (relative "
                          f"Cholesky pivot < {MASS_PIVOT_TOL:g}); the polygon is too thin or degenerate for "
                          f"scaled monomials of degree {l}")
    deficiency = (f"{nullities[1]} zero-strain modes where the 3 rigid motions are expected, gradient null space "
                  f"{nullities[0]} where 1 is expected; relative SVD tolerance {RANK_TOL:g}")
    if not l_given:
        return ValueError(f"polygon {e}: no l <= l_max={l_max} is sufficient (at l={l}: {deficiency}); "
                          "degenerate polygon or l_max too small")
    smallest = f"no l <= l_max={l_max} is sufficient"
    if l < l_max:
        area, x_E, h_E = polygon_geometry(xy)
        l_ok, gradient_nullity, strain_nullity, _, _ = select_l(xy, x_E, h_E, pi_nabla_2(xy, x_E, h_E, area),
                                                              l + 1, l_max, RANK_TOL)
        if gradient_nullity == 1 and strain_nullity == 3:
            smallest = f"the smallest sufficient l is {l_ok}"
    return ValueError(f"polygon {e}: l={l} is rank-deficient ({deficiency}); {smallest}")


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
        polygon the smallest sufficient l >= l_min (docs/method.md §3, :func:`select_l`).
    l_min : int
        Smallest l tried by the automatic choice (the paper uses 3).
    l_max : int
        Largest l allowed (scaled monomials of higher degree get ill-conditioned: the patch
        test loses about one digit per degree above 7).

    Returns
    -------
    Projections

    Raises
    ------
    ValueError
        Naming the first bad polygon: fewer than 3 vertices, coinciding consecutive vertices,
        not counter-clockwise, a given l that is rank-deficient (with the smallest sufficient
        l), no sufficient l <= l_max, or a numerically singular mass matrix.
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
    l_from, l_to = _l_range(l, polygons.size, l_min, l_max)
    nd = 2 * (offsets[polygons + 1] - offsets[polygons]) + 1
    Pi_nabla_offsets = np.concatenate(([0], np.cumsum(6 * nd))).astype(np.int64)

    status, l_chosen, nullities, centroid, diameter, area, Pi_nabla, Pi_m_offsets, Pi_m = _build_all(
        points, offsets, vertices, polygons, l_from, l_to, RANK_TOL, Pi_nabla_offsets)
    failed = np.flatnonzero(status != _OK)
    if failed.size:
        j = failed[0]
        e = int(polygons[j])
        xy = points[vertices[offsets[e]:offsets[e + 1]]]
        validate_polygon(xy, e)
        raise _rank_error(e, xy, int(status[j]), int(l_chosen[j]), nullities[j], l is not None, l_max)
    return Projections(l_chosen, centroid, diameter, area, Pi_nabla_offsets, Pi_nabla, Pi_m_offsets, Pi_m)


def without_sufficient_order(points: npt.NDArray[np.float64], offsets: npt.NDArray[np.int64],
                             vertices: npt.NDArray[np.int64], polygons: npt.NDArray[np.int64],
                             l_from: int, l_to: int) -> npt.NDArray[np.bool_]:
    """Mask (polygons.size,) bool: no projection order l_from <= l <= l_to passes the rank check
    of :func:`select_l` (tolerance :data:`RANK_TOL`) for the polygon, or it is not a valid
    counter-clockwise polygon.

    ``points`` (n_points, 2) float64, ``offsets`` (n_poly + 1,) int64 and ``vertices`` int64 as
    in :func:`build_projections`; ``polygons`` (n,) int64 the polygons checked.
    """
    n = polygons.size
    nd = 2 * (offsets[polygons + 1] - offsets[polygons]) + 1
    status = _build_all(points, offsets, vertices, polygons, np.full(n, l_from, dtype=np.int64),
                        np.full(n, l_to, dtype=np.int64), RANK_TOL,
                        np.concatenate([[0], np.cumsum(6 * nd)]).astype(np.int64))[0]
    return status != _OK
