"""Linear-elastic SFVEM element stiffness of one polygon (plane strain, paper Eqs. 43, 49-50) or
one polyhedron (3D, docs/method.md §8).

The element is stabilisation-free: K = int_E B^T C B with B built from the L^2 projection
Pi^0_l grad only. It is the reference for the rank test (docs/method.md §3: exactly 3 zero
eigenvalues in 2D, 6 in 3D, the rigid motions) and for the patch test of the vector element.
"""
from __future__ import annotations

import numba
import numpy as np
import numpy.typing as npt

from dolfinx_sfvem.discretizations.cell_projection import cholesky, gradient_projection, orthonormal_moments
from dolfinx_sfvem.discretizations.monomials import n_monomials
from dolfinx_sfvem.discretizations.projection import (
    build_projections, pi_nabla_2, polygon_geometry, projection_system, validate_polygon)
from dolfinx_sfvem.discretizations.projection3d import polyhedron_projections


def plane_strain_elasticity(young: float, poisson: float) -> npt.NDArray[np.float64]:
    """Voigt matrix C (3, 3) of plane strain: [s_xx, s_yy, s_xy] = C [e_xx, e_yy, 2 e_xy]."""
    if not young > 0.0:
        raise ValueError(f"Young's modulus must be positive, got {young}")
    if not -1.0 < poisson < 0.5:
        raise ValueError(f"Poisson's ratio must lie in (-1, 0.5) for plane strain, got {poisson}")
    factor = young / ((1.0 + poisson) * (1.0 - 2.0 * poisson))
    return factor * np.array([[1.0 - poisson, poisson, 0.0],
                              [poisson, 1.0 - poisson, 0.0],
                              [0.0, 0.0, 0.5 - poisson]])


@numba.njit(cache=True)
def _element_stiffness(xy: np.ndarray, l: int, C: np.ndarray) -> tuple[np.ndarray, bool]:
    """K = sum_ij C_ij P_i^T M P_j, exact; False if the P_l mass matrix is singular.

    With m(x) the monomials of degree <= l, the Voigt strain is B(x) u~ = [m^T P_0, m^T P_1,
    m^T P_2] u~ (Eqs. 49-50) with P_0 = [Pi_m[0], 0], P_1 = [0, Pi_m[1]],
    P_2 = [Pi_m[1], Pi_m[0]], so int_E B^T C B = sum_ij C_ij P_i^T (int_E m m^T) P_j.
    """
    area, x_E, h_E = polygon_geometry(xy)
    M, R = projection_system(xy, x_E, h_E, pi_nabla_2(xy, x_E, h_E, area), l)
    L, mass_ok = cholesky(M)
    nd = R.shape[2]
    K = np.zeros((2 * nd, 2 * nd))
    if not mass_ok:
        return K, False
    Pi_m = gradient_projection(L, orthonormal_moments(L, R))
    P = np.zeros((3, n_monomials(l), 2 * nd))
    P[0, :, :nd] = Pi_m[0]
    P[1, :, nd:] = Pi_m[1]
    P[2, :, :nd] = Pi_m[1]
    P[2, :, nd:] = Pi_m[0]
    for i in range(3):
        for j in range(3):
            K += C[i, j] * (P[i].T @ (M @ P[j]))
    return K, True


def linear_elastic_stiffness(vertices: npt.ArrayLike, young: float, poisson: float,
                             l: int | None = None) -> tuple[npt.NDArray[np.float64], int]:
    """Plane-strain linear-elastic SFVEM stiffness of one polygon, K = int_E B^T C B (no stabilisation).

    Parameters
    ----------
    vertices : (N, 2) float
        The N >= 3 vertices, counter-clockwise (a clockwise polygon is an error).
    young, poisson : float
        Young's modulus (> 0) and Poisson's ratio (in (-1, 0.5)).
    l : int, optional
        Degree of the gradient projection. Default: the automatic choice of
        :func:`~dolfinx_sfvem.discretizations.projection.build_projections`. A given l is used as is, also
        when it is rank-deficient, so that the spurious zero-energy modes can be counted
        (docs/method.md §3 table).

    Returns
    -------
    K : (2(2N+1), 2(2N+1)) float64
        Stiffness in the DOF order [u_x(x_0), ..., u_x(x_{N-1}), u_x(m_0), ..., u_x(m_{N-1}),
        ``(1/|E|) int_E u_x``, then the same 2N+1 DOFs of u_y], x_i the vertices and m_i the
        midpoint of edge i (from x_i to x_{i+1}). Integrated exactly (polynomial integrand).
    l : int
        The degree used.

    Raises
    ------
    ValueError
        Fewer than 3 vertices, clockwise or degenerate polygon, bad material parameters,
        l < 1, or a numerically singular P_l mass matrix.
    """
    xy = np.ascontiguousarray(vertices, dtype=np.float64)
    validate_polygon(xy)
    C = plane_strain_elasticity(young, poisson)
    N = xy.shape[0]
    if l is None:
        l = int(build_projections(xy, [0, N], np.arange(N)).l[0])
    elif int(l) != l or l < 1:
        raise ValueError(f"l must be an integer >= 1, got {l!r}")
    K, mass_ok = _element_stiffness(xy, int(l), C)
    if not mass_ok:
        raise ValueError(f"the P_{l} monomial mass matrix of the polygon is numerically singular; "
                         "the polygon is too thin or degenerate for this degree")
    return K, int(l)


def isotropic_elasticity(young: float, poisson: float) -> npt.NDArray[np.float64]:
    """Voigt matrix C (6, 6) of 3D isotropic Hooke's law:
    [s_xx, s_yy, s_zz, s_yz, s_xz, s_xy] = C [e_xx, e_yy, e_zz, 2 e_yz, 2 e_xz, 2 e_xy]."""
    if not young > 0.0:
        raise ValueError(f"Young's modulus must be positive, got {young}")
    if not -1.0 < poisson < 0.5:
        raise ValueError(f"Poisson's ratio must lie in (-1, 0.5), got {poisson}")
    mu = young / (2.0 * (1.0 + poisson))
    lam = young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson))
    C = np.zeros((6, 6))
    C[:3, :3] = lam
    C[np.arange(3), np.arange(3)] += 2.0 * mu
    C[np.arange(3, 6), np.arange(3, 6)] = mu
    return C


#: Voigt strain rows in 3D: (component, derivative) pairs summed into e_xx, e_yy, e_zz, 2e_yz, 2e_xz, 2e_xy
_VOIGT_3D = (((0, 0),), ((1, 1),), ((2, 2),), ((1, 2), (2, 1)), ((0, 2), (2, 0)), ((0, 1), (1, 0)))


def linear_elastic_stiffness_3d(points: npt.ArrayLike, faces, young: float, poisson: float,
                                l: int | None = None) -> tuple[npt.NDArray[np.float64], int]:
    """Linear-elastic SFVEM stiffness of one polyhedron, K = int_E B^T C B (no stabilisation).

    With Q the projected gradient in the L^2(E)-orthonormal basis
    (:class:`~dolfinx_sfvem.discretizations.projection3d.PolyhedronProjections`), the Voigt strain row i is
    B_i = sum over its (component c, derivative d) pairs of Q[d] acting on the DOFs of u_c, and
    K = sum_ij C_ij B_i^T B_j exactly (polynomial integrand, orthonormal basis).

    Parameters
    ----------
    points : (n_v, 3) float
        Vertices.
    faces : sequence of int arrays
        Cyclic faces with outward normals (:mod:`~dolfinx_sfvem.mesh.polyhedron`).
    young, poisson : float
        Young's modulus (> 0) and Poisson's ratio (in (-1, 0.5)).
    l : int, optional
        Degree of the gradient projection; default the smallest sufficient one
        (:func:`~dolfinx_sfvem.discretizations.projection3d.polyhedron_projections`).

    Returns
    -------
    K : (3 n_d, 3 n_d) float64
        Stiffness in the DOF order [the n_d DOFs of u_x, then of u_y, then of u_z], each in the
        order of :mod:`dolfinx_sfvem.discretizations.projection3d`.
    l : int
        The degree used.

    Raises
    ------
    ValueError
        Bad polyhedron, bad material parameters, or an l that is not sufficient.
    """
    C = isotropic_elasticity(young, poisson)
    P = polyhedron_projections(points, faces, l=l)
    return stiffness_from_gradient_projection_3d(P.Q, C), P.l


def stiffness_from_gradient_projection_3d(Q: npt.NDArray[np.float64], C: npt.NDArray[np.float64]
                                          ) -> npt.NDArray[np.float64]:
    """K = int_E B^T C B of one polyhedron from its projected gradient (no stabilisation).

    Parameters
    ----------
    Q : (3, n_l, n_d) float64
        Pi^0_l grad in the L^2(E)-orthonormal basis
        (:class:`~dolfinx_sfvem.discretizations.projection3d.PolyhedronProjections`).
    C : (6, 6) float64
        Voigt elasticity matrix (:func:`isotropic_elasticity`).

    Returns
    -------
    K : (3 n_d, 3 n_d) float64
        In the DOF order of :func:`linear_elastic_stiffness_3d`.
    """
    nl, nd = Q.shape[1:]
    B = np.zeros((6, nl, 3 * nd))
    for i, pairs in enumerate(_VOIGT_3D):
        for c, d in pairs:
            B[i, :, c * nd:(c + 1) * nd] += Q[d]
    CB = np.tensordot(C, B, axes=(1, 0))  # (6, nl, 3 nd): CB_i = sum_j C_ij B_j
    return B.reshape(6 * nl, 3 * nd).T @ CB.reshape(6 * nl, 3 * nd)
