"""Scaled monomials on a polygon and their exact integrals (numba).

On a polygon E with centroid x_E and diameter h_E the scaled monomials are

    m_a(x) = ((x - x_E) / h_E) ** alpha_a,      alpha_a = (p, q),   xi = (x - x_E) / h_E,

in graded order (0,0), (1,0), (0,1), (2,0), (1,1), (0,2), (3,0), ...; a polynomial of
degree <= k has n_monomials(k) = (k+1)(k+2)/2 of them (the basis m_k of paper Eq. 44).
The monomial with exponent (p, q) has index (p+q)(p+q+1)/2 + q, so the product
m_a m_b is the monomial with exponent alpha_a + alpha_b: integrals of products are
lookups in the vector of monomial integrals.

Every function here is ``numba.njit`` so that the per-polygon kernels can call it.
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def n_monomials(k: int) -> int:
    """Number of monomials of degree <= k in 2D, (k+1)(k+2)/2."""
    return (k + 1) * (k + 2) // 2


@numba.njit(cache=True)
def monomial_index(p: int, q: int) -> int:
    """Index of the monomial xi^p eta^q in the graded order."""
    d = p + q
    return d * (d + 1) // 2 + q


@numba.njit(cache=True)
def exponents(k: int) -> np.ndarray:
    """Exponents of the monomials of degree <= k.

    Returns
    -------
    (n_monomials(k), 2) int64
        Row a is alpha_a = (p, q): m_a = xi^p eta^q.
    """
    alpha = np.empty((n_monomials(k), 2), dtype=np.int64)
    a = 0
    for d in range(k + 1):
        for q in range(d + 1):
            alpha[a, 0] = d - q
            alpha[a, 1] = q
            a += 1
    return alpha


@numba.njit(cache=True)
def evaluate_monomials(x: np.ndarray, x_E: np.ndarray, h_E: float, k: int,
                       m: np.ndarray, dm_dx: np.ndarray, dm_dy: np.ndarray) -> None:
    """Values and physical first derivatives of all scaled monomials of degree <= k at a point.

    Parameters
    ----------
    x : (2,) float64
        The point (physical coordinates).
    x_E : (2,) float64
        Centroid of the polygon.
    h_E : float
        Diameter of the polygon.
    k : int
        Maximal degree.
    m, dm_dx, dm_dy : (>= n_monomials(k),) float64, written
        m_a(x), dm_a/dx(x) and dm_a/dy(x); the derivatives include the factor 1/h_E
        (d xi^p eta^q / dx = p xi^(p-1) eta^q / h_E).
    """
    xi = (x[0] - x_E[0]) / h_E
    eta = (x[1] - x_E[1]) / h_E
    m[0] = 1.0
    dm_dx[0] = 0.0
    dm_dy[0] = 0.0
    for d in range(1, k + 1):
        for q in range(d + 1):
            p = d - q
            a = monomial_index(p, q)
            # xi^p eta^q from the degree-(d-1) monomials xi^(p-1) eta^q and xi^p eta^(q-1)
            m[a] = xi * m[monomial_index(p - 1, q)] if p > 0 else eta * m[monomial_index(p, q - 1)]
            dm_dx[a] = p * m[monomial_index(p - 1, q)] / h_E if p > 0 else 0.0
            dm_dy[a] = q * m[monomial_index(p, q - 1)] / h_E if q > 0 else 0.0


@numba.njit(cache=True)
def _legendre(n: int, z: float) -> tuple[float, float]:
    """P_n(z) and P_n'(z) by the three-term recurrence (|z| < 1)."""
    p_prev, p = 1.0, z
    for j in range(2, n + 1):
        p_prev, p = p, ((2 * j - 1) * z * p - (j - 1) * p_prev) / j
    return p, n * (z * p - p_prev) / (z * z - 1.0)


@numba.njit(cache=True)
def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n-point Gauss-Legendre rule on [0, 1] (exact for degree 2n - 1).

    Returns
    -------
    t : (n,) float64
        Nodes in (0, 1).
    w : (n,) float64
        Weights, summing to 1.
    """
    t = np.empty(n)
    w = np.empty(n)
    for i in range(n):
        z = np.cos(np.pi * (i + 0.75) / (n + 0.5))  # estimate of the i-th root of P_n
        for _ in range(100):
            p, dp = _legendre(n, z)
            z -= p / dp
            if abs(p / dp) < 1e-15:
                break
        p, dp = _legendre(n, z)
        t[i] = 0.5 * (1.0 - z)
        w[i] = 1.0 / ((1.0 - z * z) * dp * dp)
    return t, w


@numba.njit(cache=True)
def polygon_monomial_integrals(xy: np.ndarray, x_E: np.ndarray, h_E: float, degree: int) -> np.ndarray:
    """Exact integrals over E of all scaled monomials of degree <= ``degree``.

    m_a is homogeneous of degree d in x - x_E, so div((x - x_E) m_a) = (2 + d) m_a and the
    divergence theorem gives

        int_E m_a dx = 1/(2 + d) sum_edges ((x_i - x_E) . n_e) int_e m_a ds,

    with (x - x_E) . n_e constant on each straight edge; the edge integrals use
    Gauss-Legendre with degree//2 + 1 points (exact).

    Parameters
    ----------
    xy : (N, 2) float64
        Vertices, counter-clockwise.
    x_E : (2,) float64
        Centroid (any reference point works; it must be the one of the monomials).
    h_E : float
        Diameter (scaling of the monomials).
    degree : int
        Maximal degree.

    Returns
    -------
    (n_monomials(degree),) float64
        int_E m_a dx, in physical units (area times a dimensionless number).
    """
    n = n_monomials(degree)
    t, w = gauss_legendre(degree // 2 + 1)
    N = xy.shape[0]
    edge_sum = np.zeros(n)
    m = np.empty(n)
    dm_dx = np.empty(n)
    dm_dy = np.empty(n)
    x = np.empty(2)
    for i in range(N):
        x0 = xy[i]
        x1 = xy[(i + 1) % N]
        # |e| n_e = (dy, -dx) for a counter-clockwise boundary
        flux = (x0[0] - x_E[0]) * (x1[1] - x0[1]) - (x0[1] - x_E[1]) * (x1[0] - x0[0])
        for g in range(t.size):
            x[0] = x0[0] + t[g] * (x1[0] - x0[0])
            x[1] = x0[1] + t[g] * (x1[1] - x0[1])
            evaluate_monomials(x, x_E, h_E, degree, m, dm_dx, dm_dy)
            for a in range(n):
                edge_sum[a] += w[g] * flux * m[a]
    integrals = np.empty(n)
    a = 0
    for d in range(degree + 1):
        for _ in range(d + 1):
            integrals[a] = edge_sum[a] / (2 + d)
            a += 1
    return integrals
