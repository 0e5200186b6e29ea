"""Scaled monomials on a polyhedron (numba), the 3D counterpart of :mod:`dolfinx_sfvem.discretizations.monomials`.

On a polyhedron E with centroid x_E and diameter h_E the scaled monomials are

    m_a(x) = xi^p eta^q zeta^r,     (xi, eta, zeta) = (x - x_E) / h_E,     alpha_a = (p, q, r),

in graded order: degree d = p + q + r first, then s = q + r, then r:

    1, xi, eta, zeta, xi^2, xi eta, xi zeta, eta^2, eta zeta, zeta^2, xi^3, ...

so the monomial with exponent (p, q, r) has the index d(d+1)(d+2)/6 + s(s+1)/2 + r, and a
polynomial of degree <= k has n_monomials3(k) = (k+1)(k+2)(k+3)/6 of them. The product m_a m_b
is the monomial with exponent alpha_a + alpha_b: integrals of products are lookups in the vector
of monomial integrals (:func:`dolfinx_sfvem.mesh.polyhedron.polyhedron_monomial_integrals`).
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def n_monomials3(k: int) -> int:
    """Number of monomials of degree <= k in 3D, (k+1)(k+2)(k+3)/6 (0 for k < 0)."""
    return (k + 1) * (k + 2) * (k + 3) // 6 if k >= 0 else 0


@numba.njit(cache=True)
def monomial_index3(p: int, q: int, r: int) -> int:
    """Index of xi^p eta^q zeta^r in the graded order."""
    d = p + q + r
    s = q + r
    return d * (d + 1) * (d + 2) // 6 + s * (s + 1) // 2 + r


@numba.njit(cache=True)
def exponents3(k: int) -> np.ndarray:
    """Exponents (n_monomials3(k), 3) int64 of the monomials of degree <= k: row a is (p, q, r)."""
    alpha = np.empty((n_monomials3(k), 3), dtype=np.int64)
    a = 0
    for d in range(k + 1):
        for s in range(d + 1):
            for r in range(s + 1):
                alpha[a, 0] = d - s
                alpha[a, 1] = s - r
                alpha[a, 2] = r
                a += 1
    return alpha


@numba.njit(cache=True)
def evaluate_monomials3(x: np.ndarray, x_E: np.ndarray, h_E: float, k: int, m: np.ndarray,
                        dm: np.ndarray) -> None:
    """Values and physical gradients of all scaled monomials of degree <= k at one point.

    Parameters
    ----------
    x : (3,) float64
        The point.
    x_E : (3,) float64
        Centroid of the polyhedron.
    h_E : float
        Diameter of the polyhedron.
    k : int
        Maximal degree.
    m : (>= n_monomials3(k),) float64, written
        m_a(x).
    dm : (3, >= n_monomials3(k)) float64, written
        dm_a/dx_c(x), including the factor 1/h_E.
    """
    xi = np.empty(3)
    for c in range(3):
        xi[c] = (x[c] - x_E[c]) / h_E
    m[0] = 1.0
    for c in range(3):
        dm[c, 0] = 0.0
    a = 1
    for d in range(1, k + 1):
        for s in range(d + 1):
            for r in range(s + 1):
                p, q = d - s, s - r
                # build from the degree-(d-1) monomial that lowers the first non-zero power
                if p > 0:
                    m[a] = xi[0] * m[monomial_index3(p - 1, q, r)]
                elif q > 0:
                    m[a] = xi[1] * m[monomial_index3(p, q - 1, r)]
                else:
                    m[a] = xi[2] * m[monomial_index3(p, q, r - 1)]
                dm[0, a] = p * m[monomial_index3(p - 1, q, r)] / h_E if p > 0 else 0.0
                dm[1, a] = q * m[monomial_index3(p, q - 1, r)] / h_E if q > 0 else 0.0
                dm[2, a] = r * m[monomial_index3(p, q, r - 1)] / h_E if r > 0 else 0.0
                a += 1


@numba.njit(cache=True)
def monomial_matrix3(x: np.ndarray, x_E: np.ndarray, h_E: float, k: int) -> np.ndarray:
    """All scaled monomials of degree <= k at the points x (n, 3): V (n_monomials3(k), n)."""
    V = np.empty((n_monomials3(k), x.shape[0]))
    dm = np.empty((3, V.shape[0]))
    for q in range(x.shape[0]):
        evaluate_monomials3(x[q], x_E, h_E, k, V[:, q], dm)
    return V
