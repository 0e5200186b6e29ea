"""Projections of the order-2 SFVEM on one polyhedron: Pi^nabla_2 and Pi^0_l nabla (docs/method.md §8).

Degrees of freedom
------------------
Polyhedron E with n_v vertices, n_e edges (:func:`~dolfinx_sfvem.mesh.polyhedron.polyhedron_edges`:
sorted pairs, lexicographic), n_f outward faces; per scalar component the n_d = n_v + n_e + n_f + 1
DOFs

    v~ = [v(x_0..x_{n_v-1}), v(m_e) for each edge, (1/|f|) int_f v for each face, (1/|E|) int_E v].

On a face f the trace of v is an order-2 virtual function of the face (the 2D space): its
2 N_f + 1 DOFs (vertex values, side midpoints, mean) are DOFs of E, and the 2D projections are
computed in the face's plane coordinates.

Enhanced spaces: every integral of v times a polynomial that the DOFs do not give is defined
through a projection, on a face ``int_f v q := int_f Pi^nabla_{k_f,f} v q`` (q of any degree; the
mean is kept, q = 1 is the DOF), in the cell ``int_E v q := int_E Pi^nabla_2 v q`` for q in
P_{l-1}(E). Both are exact when v is a quadratic polynomial. Pi^nabla_{k_f,f} is the face's H^1
projection of the smallest degree k_f >= 2 that sees every face DOF (:func:`face_h1_projection`):
with Pi^nabla_{2,f} in its place (6 numbers for 2 N_f + 1 DOFs) the face DOFs are partly invisible
to the cell and no l gives the rank (the unit cube: 18 zero-strain modes at every l up to 8;
docs/method.md §8).

Results
-------
``Pi_nabla`` (10, n_d)
    The H^1 projection onto P_2(E) in the scaled monomials of :mod:`dolfinx_sfvem.discretizations.monomials3d`.
``Pi_m`` (3, n_l, n_d), n_l = (l+1)(l+2)(l+3)/6
    The L^2 projection of the gradient onto [P_l(E)]^3: dv/dx_c (x) = m(x) . Pi_m[c] v~,
    and d2v/dx_c dx_d = (dm/dx_d)(x) . Pi_m[c] v~ (as paper Eqs. 43, 45 in 2D).
``Q`` (3, n_l, n_d)
    The same in the L^2(E)-orthonormal basis: int_E (Pi dv/dx_c)(Pi dw/dx_d) = (Q[c] v~) . (Q[d] w~).

l is chosen per polyhedron by the rank condition as in 2D: this module gives a polyhedron to the
dimension-generic :mod:`~dolfinx_sfvem.discretizations.cell_projection` (its ``select_l`` and
``build_cells``) through the overloads of ``prepare_cell`` (for :class:`PolyhedronCells`) and
``cell_system`` (for :class:`PolyhedronSystem`).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np
import numpy.typing as npt
from numba.extending import overload

from dolfinx_sfvem.discretizations.cell_projection import (
    GEOMETRY_STATUS, OK, RANK_TOL, Projections, build_cell_projections, cell_system, cholesky, count_zero_eigenvalues,
    is_tuple_of, orthonormal_moments, prepare_cell, projection_error, select_l)
from dolfinx_sfvem.discretizations.monomials import (
    evaluate_monomials, exponents, monomial_index, n_monomials, polygon_monomial_integrals)
from dolfinx_sfvem.discretizations.monomials3d import evaluate_monomials3, exponents3, monomial_index3, n_monomials3
from dolfinx_sfvem.mesh.polyhedron import (
    _edges, _geometry, face_frame, face_quadrature, face_triangles, faces_csr, map_triangle_rule,
    monomial_integrals_from_faces, plane_coordinates, polyhedron_quadrature, validate_polyhedron)
from dolfinx_sfvem.discretizations.projection import pi_nabla_2, polygon_geometry, projection_system
from dolfinx_sfvem.discretizations.quadrature import triangle_rule

#: smallest and largest l tried by the automatic choice (docs/method.md §8; l_min = 3 as in 2D)
L_MIN, L_MAX = 3, 10

#: largest degree of a face projection Pi^nabla_{k_f,f} (docs/method.md §8)
K_FACE_MAX = 8


# --------------------------------------------------------------------------- face spaces
@numba.njit(cache=True)
def face_h1_projection(xy, x_f, h_f, area, Pi_nabla_f, k, tol):
    """The face's H^1 projection Pi^nabla_{k,f} onto P_k(f) (2D scaled monomials of degree k), and
    the dimension of its kernel on the face DOFs modulo the mean.

    int_f grad(Pi v) . grad p = int_f grad v . grad p for p in P_k(f), and equal means. With
    grad p in [P_{k-1}(f)]^2 the right side is the 2D gradient moment of
    :func:`dolfinx_sfvem.discretizations.projection.projection_system` at degree k - 1 (exact edge traces, the face
    interior moments through Pi^nabla_{2,f}): with D_c the derivative matrices
    (d m_b/dx_c = sum_a D_c[a, b] m_a), G = sum_c D_c^T M D_c and B = sum_c D_c^T R[c].

    Parameters
    ----------
    xy : (N, 2) float64
        The face's vertices in plane coordinates, counter-clockwise.
    x_f, h_f, area
        Its centroid (2,), diameter and area.
    Pi_nabla_f : (6, 2N+1) float64
        :func:`dolfinx_sfvem.discretizations.projection.pi_nabla_2` of the face.
    k : int
        Degree, >= 2.
    tol : float
        Relative singular-value tolerance of the kernel count.

    Returns
    -------
    Pi : (n_monomials(k), 2N+1) float64
        Pi^nabla_{k,f} v = sum_a m_a (Pi v~)_a in the face's scaled monomials.
    nullity : int
        dim ker(v~ -> grad Pi^nabla_{k,f} v): 1 (the constants) when the projection sees every
        face DOF, -1 if the P_{k-1} mass matrix is singular.
    """
    nd = xy.shape[0] * 2 + 1
    M, R = projection_system(xy, x_f, h_f, Pi_nabla_f, k - 1)
    n_lo, n_hi = n_monomials(k - 1), n_monomials(k)
    alpha = exponents(k)
    D = np.zeros((2, n_lo, n_hi))
    for b in range(1, n_hi):
        p, q = alpha[b, 0], alpha[b, 1]
        if p > 0:
            D[0, monomial_index(p - 1, q), b] = p / h_f
        if q > 0:
            D[1, monomial_index(p, q - 1), b] = q / h_f
    G = D[0].T @ M @ D[0] + D[1].T @ M @ D[1]
    B = D[0].T @ R[0] + D[1].T @ R[1]
    integrals = polygon_monomial_integrals(xy, x_f, h_f, k)
    for b in range(n_hi):
        G[0, b] = integrals[b] / area
    B[0, :] = 0.0
    B[0, nd - 1] = 1.0
    L, ok = cholesky(G[1:, 1:].copy())
    if not ok:
        return np.zeros((n_hi, nd)), -1
    Q = orthonormal_moments(L, B[1:].reshape(1, n_hi - 1, nd))[0]
    return np.linalg.solve(G, B), count_zero_eigenvalues(Q.T @ Q, tol ** 2)


@numba.njit(cache=True)
def face_spaces(points, offsets, vertices, edges, k_max, tol):
    """Per face its projection Pi^nabla_{k_f,f} (docs/method.md §8), in its plane coordinates, with
    k_f the smallest degree in [2, k_max] whose projection sees every face DOF, and the places of
    the face's DOFs in v~.

    Returns
    -------
    origins : (n_f, 3) float64
        The face's first vertex, origin of its plane coordinates.
    bases : (n_f, 2, 3) float64
        (t_1, t_2) of the face (:func:`~dolfinx_sfvem.mesh.polyhedron.face_frame`).
    centres : (n_f, 2) float64
        The face centroid in plane coordinates, centre of the face's 2D scaled monomials.
    diameters : (n_f,) float64
        The face diameter, their scale.
    degrees : (n_f,) int64
        k_f; -1 for a face where no k <= k_max is enough (the caller raises).
    Pi_offsets : (n_f + 1,) int64
    Pi_flat : float64
        Face f's Pi^nabla_{k_f,f}, (n_monomials(k_f), 2 N_f + 1) in C order, at
        Pi_flat[Pi_offsets[f]:Pi_offsets[f+1]].
    dof_offsets : (n_f + 1,) int64
    dofs : int64
        dofs[dof_offsets[f] + j] is the index in v~ of the face's 2D DOF j (its vertices, its side
        midpoints, its mean).
    """
    n_v = points.shape[0]
    n_e = edges.shape[0]
    n_f = offsets.size - 1
    keys = edges[:, 0] * n_v + edges[:, 1]
    origins = np.empty((n_f, 3))
    bases = np.empty((n_f, 2, 3))
    centres = np.empty((n_f, 2))
    diameters = np.empty(n_f)
    degrees = np.full(n_f, -1, dtype=np.int64)
    dof_offsets = np.zeros(n_f + 1, dtype=np.int64)
    for f in range(n_f):
        dof_offsets[f + 1] = dof_offsets[f] + 2 * (offsets[f + 1] - offsets[f]) + 1
    Pi_offsets = np.zeros(n_f + 1, dtype=np.int64)
    Pi_flat = np.empty(n_monomials(k_max) * dof_offsets[-1])
    dofs = np.empty(dof_offsets[-1], dtype=np.int64)
    for f in range(n_f):
        face = vertices[offsets[f]:offsets[f + 1]]
        N = face.size
        X = points[face]
        _, _, t1, t2 = face_frame(X)
        bases[f, 0], bases[f, 1], origins[f] = t1, t2, X[0]
        xy = plane_coordinates(X, X[0], t1, t2)
        area, x_f, h_f = polygon_geometry(xy)
        centres[f], diameters[f] = x_f, h_f
        Pi_2 = pi_nabla_2(xy, x_f, h_f, area)
        Pi = Pi_2
        for k in range(2, k_max + 1):
            Pi, nullity = face_h1_projection(xy, x_f, h_f, area, Pi_2, k, tol)
            if nullity == 1:
                degrees[f] = k
                break
        Pi_offsets[f + 1] = Pi_offsets[f] + Pi.size
        Pi_flat[Pi_offsets[f]:Pi_offsets[f + 1]] = Pi.ravel()
        first = dof_offsets[f]
        for i in range(N):
            a, b = face[i], face[(i + 1) % N]
            dofs[first + i] = a
            dofs[first + N + i] = n_v + np.searchsorted(keys, min(a, b) * n_v + max(a, b))
        dofs[first + 2 * N] = n_v + n_e + f
    return origins, bases, centres, diameters, degrees, Pi_offsets, Pi_flat[:Pi_offsets[-1]].copy(), dof_offsets, dofs


@numba.njit(cache=True)
def face_basis_values(x_q, point_face, n_d, origins, bases, centres, diameters, degrees, Pi_offsets, Pi_flat,
                      dof_offsets, dofs):
    """Phi (n_q, n_d): Phi[q] v~ = (Pi^nabla_{k_f,f} v)(x_q) on the face f of point q (enhanced face space)."""
    Phi = np.zeros((x_q.shape[0], n_d))
    n_max = n_monomials(max(degrees.max(), 2))
    m = np.empty(n_max)
    dm_dx = np.empty(n_max)
    dm_dy = np.empty(n_max)
    xi = np.empty(2)
    for q in range(x_q.shape[0]):
        f = point_face[q]
        xi[0] = np.dot(x_q[q] - origins[f], bases[f, 0])
        xi[1] = np.dot(x_q[q] - origins[f], bases[f, 1])
        evaluate_monomials(xi, centres[f], diameters[f], degrees[f], m, dm_dx, dm_dy)
        n_face = dof_offsets[f + 1] - dof_offsets[f]
        n_k = n_monomials(degrees[f])
        Pi = Pi_flat[Pi_offsets[f]:Pi_offsets[f + 1]].reshape(n_k, n_face)
        for j in range(n_face):
            value = 0.0
            for b in range(n_k):
                value += m[b] * Pi[b, j]
            Phi[q, dofs[dof_offsets[f] + j]] += value
    return Phi


# --------------------------------------------------------------------------- Pi^nabla_2 and Pi^0_l nabla
@numba.njit(cache=True)
def _face_rule(triangles, triangle_face, rule_points, rule_weights, rule_offsets, degree):
    """The face rule of one degree from a table of triangle rules (rule_offsets by degree)."""
    r = slice(rule_offsets[degree], rule_offsets[degree + 1])
    x_q, w_q = map_triangle_rule(triangles, rule_points[r], rule_weights[r])
    n_r = rule_offsets[degree + 1] - rule_offsets[degree]
    point_face = np.empty(w_q.size, dtype=np.int64)
    for t in range(triangle_face.size):
        point_face[t * n_r:(t + 1) * n_r] = triangle_face[t]
    return x_q, w_q, point_face


@numba.njit(cache=True)
def pi_nabla_2_3d(volume, x_E, h_E, normals, face_centroids, x_q, w_q, point_face, Phi, n_d):
    """Pi^nabla_2 on the polyhedron, (10, n_d): G Pi_nabla = B.

    Rows a >= 1: int_E grad(Pi v) . grad m_a = int_E grad v . grad m_a
    = -Lap(m_a) |E| mean(v) + sum_f int_f (dm_a/dn_f) Pi^nabla_{k_f,f} v (enhanced face space; dm_a/dn_f
    is linear, so the face rule (x_q, w_q, point_face, Phi) must be exact for degree 1 + max k_f). Row 0: equal
    means. G from the monomial integrals up to degree 2 (the same face rule).
    """
    integrals = monomial_integrals_from_faces(x_q, w_q, point_face, normals, face_centroids, x_E, h_E, 2)
    alpha = exponents3(2)
    G = np.zeros((10, 10))
    B = np.zeros((10, n_d))
    for b in range(10):
        G[0, b] = integrals[b] / volume
    B[0, n_d - 1] = 1.0
    for a in range(1, 10):
        for b in range(1, 10):
            for c in range(3):
                if alpha[a, c] * alpha[b, c] > 0:
                    e = alpha[a] + alpha[b]
                    e[c] -= 2
                    G[a, b] += alpha[a, c] * alpha[b, c] * integrals[monomial_index3(e[0], e[1], e[2])] / h_E ** 2
        laplacian = 0.0
        for c in range(3):
            laplacian += alpha[a, c] * (alpha[a, c] - 1) / h_E ** 2
        B[a, n_d - 1] = -laplacian * volume
    m = np.empty(10)
    dm = np.empty((3, 10))
    for q in range(w_q.size):
        n = normals[point_face[q]]
        evaluate_monomials3(x_q[q], x_E, h_E, 2, m, dm)
        for a in range(1, 10):
            flux = w_q[q] * (dm[0, a] * n[0] + dm[1, a] * n[1] + dm[2, a] * n[2])
            for k in range(n_d):
                B[a, k] += flux * Phi[q, k]
    return np.linalg.solve(G, B)


@numba.njit(cache=True)
def projection_system_3d(system, l):
    """Mass matrix M (n_l, n_l) and right sides R (3, n_l, n_d) of Pi^0_l nabla on a polyhedron: M Pi_m[c] = R[c].

        (r_c)_a = sum_f n_f,c int_f m_a Pi^nabla_{k_f,f} v - int_E (dm_a/dx_c) Pi^nabla_2 v

    (int_E grad v . p = -int_E v div p + sum_f int_f v p . n_f with the enhanced face and cell
    spaces). The face rule is exact for degree max(2l, l + max k_f): M needs the monomial
    integrals up to 2l, the face terms degree l + k_f. The face terms go through the small moment
    matrices F_f = int_f m m_f^T (3D monomials of degree l against the face's 2D ones of degree
    k_f): R[c][:, face DOFs] += n_f,c F_f Pi^nabla_{k_f,f}.

    Parameters
    ----------
    system : PolyhedronSystem
        The polyhedron (:func:`prepare_polyhedron`).
    l : int
        Degree of the projection, >= 1.
    """
    x_E, h_E, Pi_nabla, normals, face_centroids = (system.centroid, system.diameter, system.Pi_nabla, system.normals,
                                                   system.face_centroids)
    face_data = system.face_data
    n_d = Pi_nabla.shape[1]
    origins, bases, centres, diameters, degrees, Pi_offsets, Pi_flat, dof_offsets, dofs = face_data
    x_q, w_q, point_face = _face_rule(system.triangles, system.triangle_face, system.rule_points, system.rule_weights,
                                      system.rule_offsets, max(2 * l, l + degrees.max()))
    nl = n_monomials3(l)
    integrals = monomial_integrals_from_faces(x_q, w_q, point_face, normals, face_centroids, x_E, h_E, 2 * l)
    alpha = exponents3(l)
    M = np.empty((nl, nl))
    for a in range(nl):
        for b in range(nl):
            e = alpha[a] + alpha[b]
            M[a, b] = integrals[monomial_index3(e[0], e[1], e[2])]
    n_f = degrees.size
    n_k = n_monomials(degrees.max())
    F = np.zeros((n_f, nl, n_k))
    m = np.empty(nl)
    dm = np.empty((3, nl))
    m_f = np.empty(n_k)
    dm_dx = np.empty(n_k)
    dm_dy = np.empty(n_k)
    xi = np.empty(2)
    for q in range(w_q.size):
        f = point_face[q]
        evaluate_monomials3(x_q[q], x_E, h_E, l, m, dm)
        xi[0] = np.dot(x_q[q] - origins[f], bases[f, 0])
        xi[1] = np.dot(x_q[q] - origins[f], bases[f, 1])
        evaluate_monomials(xi, centres[f], diameters[f], degrees[f], m_f, dm_dx, dm_dy)
        for a in range(nl):
            wm = w_q[q] * m[a]
            for b in range(n_monomials(degrees[f])):
                F[f, a, b] += wm * m_f[b]
    R = np.zeros((3, nl, n_d))
    for f in range(n_f):
        n_face = dof_offsets[f + 1] - dof_offsets[f]
        n_kf = n_monomials(degrees[f])
        S = F[f, :, :n_kf].copy() @ Pi_flat[Pi_offsets[f]:Pi_offsets[f + 1]].reshape(n_kf, n_face)
        for j in range(n_face):
            k = dofs[dof_offsets[f] + j]
            for c in range(3):
                for a in range(nl):
                    R[c, a, k] += normals[f, c] * S[a, j]
    # cell term: - int_E (dm_a/dx_c) m_b (Pi_nabla v~)_b, dm_a/dx_c = alpha_ac m_(a - e_c) / h_E
    alpha_2 = exponents3(2)
    for a in range(nl):
        for c in range(3):
            if alpha[a, c] == 0:
                continue
            for b in range(10):
                e = alpha[a] + alpha_2[b]
                e[c] -= 1
                moment = alpha[a, c] / h_E * integrals[monomial_index3(e[0], e[1], e[2])]
                for k in range(n_d):
                    R[c, a, k] -= moment * Pi_nabla[b, k]
    return M, R


# geometry failure of a polyhedron: a face whose DOFs no face projection of degree <= k_max sees all of
FACE_BLIND = GEOMETRY_STATUS


class PolyhedronSystem(NamedTuple):
    """What :func:`projection_system_3d` needs of one polyhedron (the ``cell_system`` of a polyhedron).

    Attributes
    ----------
    centroid : (3,) float64
        x_E.
    diameter : float
        h_E.
    Pi_nabla : (10, n_d) float64
        :func:`pi_nabla_2_3d`.
    normals : (n_f, 3) float64
        Outward unit normals of the faces.
    face_centroids : (n_f, 3) float64
    triangles : (n_t, 3, 3) float64
        The faces' triangles (:func:`~dolfinx_sfvem.mesh.polyhedron.face_triangles`).
    triangle_face : (n_t,) int64
        The face of each triangle.
    face_data : tuple
        :func:`face_spaces`.
    rule_points, rule_weights, rule_offsets
        The triangle rules by degree (:func:`triangle_rule_table`).
    """

    centroid: np.ndarray
    diameter: float
    Pi_nabla: np.ndarray
    normals: np.ndarray
    face_centroids: np.ndarray
    triangles: np.ndarray
    triangle_face: np.ndarray
    face_data: tuple
    rule_points: np.ndarray
    rule_weights: np.ndarray
    rule_offsets: np.ndarray


@numba.njit(cache=True)
def prepare_polyhedron(points, offsets, vertices, edges, rule_points, rule_weights, rule_offsets, k_max, tol):
    """Geometry, face spaces and Pi_nabla of one polyhedron.

    Parameters
    ----------
    points : (n_v, 3) float64
    offsets, vertices : int64
        CSR of the faces (local vertex numbers, outward).
    edges : (n_e, 2) int64
        The edges in DOF order.
    rule_points, rule_weights, rule_offsets
        The triangle rules by degree (:func:`triangle_rule_table`), to degree max(2 l_to, l_to + k_max).
    k_max : int
        Largest face degree k_f.
    tol : float
        Relative singular-value tolerance of the face spaces.

    Returns
    -------
    status : int
        OK, or :data:`FACE_BLIND` (then Pi_nabla is zero).
    volume : float
    system : PolyhedronSystem
    """
    volume, x_E, h_E, _, normals, face_centroids, _ = _geometry(points, offsets, vertices)
    triangles, triangle_face = face_triangles(points, offsets, vertices)
    face_data = face_spaces(points, offsets, vertices, edges, k_max, tol)
    degrees = face_data[4]
    n_d = points.shape[0] + edges.shape[0] + offsets.size - 1 + 1
    status = OK
    Pi_nabla = np.zeros((10, n_d))
    if degrees.min() < 0:
        status = FACE_BLIND
    else:
        x_q, w_q, point_face = _face_rule(triangles, triangle_face, rule_points, rule_weights, rule_offsets,
                                          1 + degrees.max())
        Phi = face_basis_values(x_q, point_face, n_d, *face_data)
        Pi_nabla = pi_nabla_2_3d(volume, x_E, h_E, normals, face_centroids, x_q, w_q, point_face, Phi, n_d)
    return status, volume, PolyhedronSystem(x_E, h_E, Pi_nabla, normals, face_centroids, triangles, triangle_face,
                                            face_data, rule_points, rule_weights, rule_offsets)


@numba.njit(cache=True)
def build_polyhedron(points, offsets, vertices, edges, rule_points, rule_weights, rule_offsets, l_from, l_to,
                     k_max, tol):
    """All of one polyhedron in one compiled call: :func:`prepare_polyhedron`, then
    :func:`~dolfinx_sfvem.discretizations.cell_projection.select_l` in [l_from, l_to].

    Returns
    -------
    status : int
        OK, FACE_BLIND, or select_l's status.
    volume : float
    system : PolyhedronSystem
    l, gradient_nullity, strain_nullity : int
    Q, Pi_m : (3, n_l, n_d) float64
        As select_l gives them; (3, 0, n_d) for a FACE_BLIND polyhedron.
    """
    status, volume, system = prepare_polyhedron(points, offsets, vertices, edges, rule_points, rule_weights,
                                                rule_offsets, k_max, tol)
    n_d = system.Pi_nabla.shape[1]
    l, gradient_nullity, strain_nullity, Q, Pi_m = l_from, -1, -1, np.zeros((3, 0, n_d)), np.zeros((3, 0, n_d))
    if status == OK:
        status, l, gradient_nullity, strain_nullity, Q, Pi_m = select_l(system, 3, l_from, l_to, tol)
    return status, volume, system, l, gradient_nullity, strain_nullity, Q, Pi_m


@overload(cell_system)
def _cell_system_polyhedron(system, l):
    if is_tuple_of(system, PolyhedronSystem):
        return lambda system, l: projection_system_3d(system, l)


# --------------------------------------------------------------------------- Python interface
def triangle_rule_table(max_degree: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The triangle rules of degrees 0..max_degree stacked: points, weights, offsets (by degree)."""
    rules = [triangle_rule(max(d, 1)) for d in range(max_degree + 1)]
    offsets = np.cumsum([0] + [w.size for _, w in rules]).astype(np.int64)
    return np.vstack([p for p, _ in rules]), np.concatenate([w for _, w in rules]), offsets


@dataclass(frozen=True)
class PolyhedronProjections:
    """Pi^nabla_2 and Pi^0_l nabla of one polyhedron (module docstring for the DOF order).

    Attributes
    ----------
    l : int
        Degree of the gradient projection.
    volume : float
    centroid : (3,) float64
        x_E, centre of the scaled monomials.
    diameter : float
        h_E, their scale.
    edges : (n_e, 2) int64
        The edges in DOF order.
    face_degrees : (n_f,) int64
        k_f, the degree of each face's projection Pi^nabla_{k_f,f}.
    Pi_nabla : (10, n_d) float64
    Pi_m : (3, n_l, n_d) float64
    Q : (3, n_l, n_d) float64
        Pi_m in the L^2(E)-orthonormal basis (Q^T Q products are exact integrals).
    """

    l: int
    volume: float
    centroid: npt.NDArray[np.float64]
    diameter: float
    edges: npt.NDArray[np.int64]
    face_degrees: npt.NDArray[np.int64]
    Pi_nabla: npt.NDArray[np.float64]
    Pi_m: npt.NDArray[np.float64]
    Q: npt.NDArray[np.float64]

    @property
    def n_dofs(self) -> int:
        """Scalar DOFs n_d."""
        return self.Pi_nabla.shape[1]


def polyhedron_projections(points: npt.ArrayLike, faces: Sequence[npt.ArrayLike], l: int | None = None,
                           l_min: int = L_MIN, l_max: int = L_MAX) -> PolyhedronProjections:
    """Pi^nabla_2 and Pi^0_l nabla of one polyhedron.

    Parameters
    ----------
    points : (n_v, 3) float
        Vertices.
    faces : sequence of int arrays
        Local vertex indices of each face, cyclic, normal (right-hand rule) outward.
    l : int, optional
        Degree of the gradient projection; it must be sufficient. Default: the smallest
        sufficient l in [l_min, l_max] (:func:`~dolfinx_sfvem.discretizations.cell_projection.select_l`).
    l_min, l_max : int
        Range of the automatic choice.

    Raises
    ------
    ValueError
        Bad polyhedron (:func:`~dolfinx_sfvem.mesh.polyhedron.validate_polyhedron`), a face no face
        projection sees; as ``cell 0: ...``
        (:func:`~dolfinx_sfvem.discretizations.cell_projection.projection_error`) a given l that is
        rank-deficient, no sufficient l <= l_max, or a numerically singular P_l mass matrix.
    """
    validate_polyhedron(points, faces)
    if l is not None and (int(l) != l or not 1 <= l <= l_max):
        raise ValueError(f"l must be an integer in [1, l_max={l_max}], got {l!r}")
    if not 1 <= l_min <= l_max:
        raise ValueError(f"need 1 <= l_min <= l_max, got l_min={l_min}, l_max={l_max}")
    l_from, l_to = (int(l), int(l)) if l is not None else (l_min, l_max)
    points = np.ascontiguousarray(points, dtype=np.float64)
    offsets, vertices = faces_csr(faces)
    edges = _edges(offsets, vertices)
    table = triangle_rule_table(max(2 * l_max, l_max + K_FACE_MAX))

    def build(l_from: int, l_to: int) -> tuple:
        return build_polyhedron(points, offsets, vertices, edges, *table, l_from, l_to, K_FACE_MAX, RANK_TOL)

    status, volume, system, l_used, gradient_nullity, strain_nullity, Q, Pi_m = build(l_from, l_to)
    degrees = system.face_data[4]
    if status == FACE_BLIND:
        f = int(np.argmin(degrees))
        raise ValueError(f"face {f}: no face projection of degree <= {K_FACE_MAX} sees all of its DOFs "
                         "(degenerate face: a side shorter than about 1e-5 of its diameter?)")
    if status != OK:
        def sufficient_above(l: int) -> int | None:
            again = build(l + 1, l_max)
            return int(again[3]) if again[0] == OK else None

        raise projection_error(0, status, int(l_used), (gradient_nullity, strain_nullity), 3, l is not None, l_max,
                               sufficient_above)
    return PolyhedronProjections(int(l_used), float(volume), system.centroid, float(system.diameter), edges, degrees,
                                 system.Pi_nabla, Pi_m, Q)


def interpolation_dofs(points: npt.ArrayLike, faces: Sequence[npt.ArrayLike],
                       function: Callable[[npt.NDArray[np.float64]], npt.NDArray[np.float64]],
                       degree: int) -> npt.NDArray[np.float64]:
    """The DOFs v~ of a function: values at the vertices and edge midpoints, face and cell means
    with rules exact for ``degree`` (exact DOFs of a polynomial of that degree).

    ``function`` maps points (n, 3) to values (n,), or (n, k) for k components; the result is
    (n_d,), or (k, n_d).
    """
    points = np.asarray(points, dtype=np.float64)
    edges = _edges(*faces_csr(faces))
    x_f, w_f, face = face_quadrature(points, faces, degree)
    x_c, w_c = polyhedron_quadrature(points, faces, degree)
    on_faces, in_cell = function(x_f), function(x_c)
    areas = np.bincount(face, w_f)
    face_means = np.stack([np.bincount(face, w_f * column) / areas for column in np.atleast_2d(on_faces.T)], axis=-1)
    dofs = np.concatenate([np.atleast_2d(function(points).T).T, np.atleast_2d(function(points[edges].mean(axis=1)).T).T,
                           face_means, np.atleast_2d(w_c @ in_cell / w_c.sum())])
    return dofs.T if np.ndim(on_faces) == 2 else dofs[:, 0]


# --------------------------------------------------------------------------- many polyhedra
@numba.njit(cache=True)
def local_polyhedron(points, face_offsets, face_vertices, cell_faces, cell_face_signs):
    """One cell of a mesh in the element's input form: its vertices in increasing global number,
    its faces (in the cell's order, outward) in that local numbering, its edges.

    Parameters
    ----------
    points : (n_points, 3) float64
    face_offsets, face_vertices : int64
        CSR of the mesh's faces (global vertex numbers, each face stored once).
    cell_faces : (n_f,) int64
        The cell's faces.
    cell_face_signs : (n_f,) int64
        +1 if the stored face's normal points out of the cell, -1 if it is to be reversed.

    Returns
    -------
    vertices : (n_v,) int64
        Global numbers of the local vertices, increasing (so the local edge order, sorted pairs,
        is the order of the global pairs too).
    local_points : (n_v, 3) float64
    offsets, local_faces : int64
        CSR of the cell's faces in local numbers, outward.
    edges : (n_e, 2) int64
        Local edges, sorted pairs in lexicographic order.
    """
    n_f = cell_faces.size
    offsets = np.zeros(n_f + 1, dtype=np.int64)
    for i in range(n_f):
        f = cell_faces[i]
        offsets[i + 1] = offsets[i] + face_offsets[f + 1] - face_offsets[f]
    global_faces = np.empty(offsets[-1], dtype=np.int64)
    for i in range(n_f):
        f = cell_faces[i]
        face = face_vertices[face_offsets[f]:face_offsets[f + 1]]
        N = face.size
        for k in range(N):
            global_faces[offsets[i] + k] = face[k] if cell_face_signs[i] > 0 else face[N - 1 - k]
    vertices = np.unique(global_faces)
    local_faces = np.searchsorted(vertices, global_faces)
    n_v = vertices.size
    keys = np.empty(offsets[-1], dtype=np.int64)
    for i in range(n_f):
        for k in range(offsets[i], offsets[i + 1]):
            a = local_faces[k]
            b = local_faces[k + 1] if k + 1 < offsets[i + 1] else local_faces[offsets[i]]
            keys[k] = min(a, b) * n_v + max(a, b)
    keys = np.unique(keys)
    edges = np.empty((keys.size, 2), dtype=np.int64)
    for e in range(keys.size):
        edges[e, 0], edges[e, 1] = keys[e] // n_v, keys[e] % n_v
    return vertices, points[vertices], offsets, local_faces, edges


class PolyhedronCells(NamedTuple):
    """The cells of a polyhedral mesh as cells of :func:`~dolfinx_sfvem.discretizations.cell_projection.build_cells`
    (the arrays of :func:`build_projections_3d`), with the triangle rules and the largest face degree.

    Attributes
    ----------
    points : (n_points, 3) float64
    face_offsets, face_vertices : int64
        CSR of the faces (global vertex numbers, each face stored once).
    cell_offsets, cell_faces, cell_face_signs : int64
        CSR of the cells' faces, +1 where the stored normal points out of the cell.
    rule_points, rule_weights, rule_offsets
        :func:`triangle_rule_table`, to degree max(2 l_max, l_max + k_max).
    k_max : int
        Largest face degree k_f (:data:`K_FACE_MAX`).
    """

    points: np.ndarray
    face_offsets: np.ndarray
    face_vertices: np.ndarray
    cell_offsets: np.ndarray
    cell_faces: np.ndarray
    cell_face_signs: np.ndarray
    rule_points: np.ndarray
    rule_weights: np.ndarray
    rule_offsets: np.ndarray
    k_max: int


@numba.njit(cache=True)
def _prepare_polyhedron_cell(mesh, c, tol):
    """``prepare_cell`` of cell c: (status, global vertices, volume, PolyhedronSystem)."""
    faces = mesh.cell_faces[mesh.cell_offsets[c]:mesh.cell_offsets[c + 1]]
    signs = mesh.cell_face_signs[mesh.cell_offsets[c]:mesh.cell_offsets[c + 1]]
    vertices, X, offsets, local_faces, edges = local_polyhedron(mesh.points, mesh.face_offsets, mesh.face_vertices,
                                                                faces, signs)
    status, volume, system = prepare_polyhedron(X, offsets, local_faces, edges, mesh.rule_points, mesh.rule_weights,
                                                mesh.rule_offsets, mesh.k_max, tol)
    return status, vertices, volume, system


@overload(prepare_cell)
def _prepare_cell_polyhedron(mesh, cell, tol):
    if is_tuple_of(mesh, PolyhedronCells):
        return lambda mesh, cell, tol: _prepare_polyhedron_cell(mesh, cell, tol)


def build_projections_3d(points: npt.ArrayLike, face_offsets: npt.ArrayLike, face_vertices: npt.ArrayLike,
                         cell_offsets: npt.ArrayLike, cell_faces: npt.ArrayLike, cell_face_signs: npt.ArrayLike,
                         cells: npt.ArrayLike | None = None, l: int | npt.ArrayLike | None = None, l_min: int = L_MIN,
                         l_max: int = L_MAX) -> Projections:
    """Pi^nabla_2 and Pi^0_l nabla of the cells of a polyhedral mesh (one compiled loop).

    The mesh arrays are those of :class:`~dolfinx_sfvem.mesh.polyhedron_mesh.PolyhedronMesh`: each face stored once
    with global vertex numbers, the cells as CSR of faces with a sign per (cell, face), +1 when
    the stored normal points out of the cell. The mesh is assumed valid (its constructor checks
    it); what only the element can tell is checked here.

    Parameters
    ----------
    points : (n_points, 3) float
    face_offsets : (n_faces + 1,) int
    face_vertices : (face_offsets[-1],) int
    cell_offsets : (n_cells + 1,) int
    cell_faces, cell_face_signs : (cell_offsets[-1],) int
    cells : (n,) int, optional
        The cells to build (default all); the result is indexed 0..n-1 in this order.
    l : int or (n,) int, optional
        Degree of the gradient projection, for all cells or per built cell (must be sufficient);
        default the smallest sufficient per cell.
    l_min, l_max : int
        Range of the automatic choice.

    Returns
    -------
    Projections
        Of the polyhedra (d = 3), their volumes as ``measure``.

    Raises
    ------
    ValueError
        Naming the first cell (``cell N: ...``) with a face no face projection sees, whose mass matrix
        is singular, or for which no l (or the given l) is sufficient
        (:func:`~dolfinx_sfvem.discretizations.cell_projection.projection_error`).
    """
    def indices(a: npt.ArrayLike) -> npt.NDArray[np.int64]:
        return np.ascontiguousarray(a, dtype=np.int64)

    mesh = PolyhedronCells(np.ascontiguousarray(points, dtype=np.float64), indices(face_offsets),
                           indices(face_vertices), indices(cell_offsets), indices(cell_faces), indices(cell_face_signs),
                           *triangle_rule_table(max(2 * l_max, l_max + K_FACE_MAX)), K_FACE_MAX)
    cells = np.arange(mesh.cell_offsets.size - 1) if cells is None else np.ascontiguousarray(cells, dtype=np.int64)

    def face_blind(c: int, status: int) -> ValueError:
        return ValueError(f"cell {c}: a face where no projection of degree <= {K_FACE_MAX} sees all of its DOFs")

    return build_cell_projections(mesh, cells, 3, l, l_min, l_max, face_blind)
