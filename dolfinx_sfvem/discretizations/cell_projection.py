"""The SFVEM projections of any cell, polygon or polyhedron: the rank check, the choice of l, the loop
over the cells and their :class:`Projections` (docs/method.md §3, §8).

What differs between the dimensions is the geometry: :mod:`~dolfinx_sfvem.discretizations.projection`
(polygons) and :mod:`~dolfinx_sfvem.discretizations.projection3d` (polyhedra) give, per cell, its
Pi^nabla_2 and the system M Pi_m[c] = R[c] of Pi^0_l nabla. What is the same lives here, once:

* the rank check of that system in the L^2(E)-orthonormal basis (:func:`rank_of_projection`);
* the l loop (:func:`select_l`): the smallest l in [l_from, l_to] for which the projected gradient
  sees only the constants and the projected small strain only the d(d+1)/2 rigid motions;
* the compiled loop over many cells (:func:`build_cells`) and its checked front end
  (:func:`build_cell_projections`), which names the first failing cell (:func:`projection_error`).

A dimension joins by two numba overloads, chosen by the type of its namedtuples:
``prepare_cell(mesh, cell, tol)`` for its mesh tuple and ``cell_system(system, l)`` for its cell
tuple (the stubs below say what they return).

Shapes: d the dimension, n_d the scalar DOFs of a cell, n_l = dim P_l (:func:`n_monomials_in`).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
import numpy.typing as npt
from numba.core import types

#: Relative tolerance on singular values (sigma <= RANK_TOL * sigma_max counts as zero) of the
#: projected-gradient operators in the L^2(E)-orthonormal polynomial basis, applied as
#: RANK_TOL^2 to the eigenvalues of their Gram matrices. Measured on the test polygons for
#: l = 2..10: exact null-space modes at lambda / lambda_max <= 1e-15 (sigma <= 3e-8), the smallest
#: genuine ones at lambda / lambda_max >= 7e-6 (sigma >= 2.6e-3); RANK_TOL^2 = 9e-12 lies
#: between with more than three orders of magnitude on both sides. Genuinely weak modes below
#: RANK_TOL do occur: an edge shorter than about 1e-5 h_E, or collinear vertices a few per cent
#: of h_E apart (sigma ~ 1e-6 for three hanging nodes 0.02 h_E apart at l = 6); such a cell
#: gets a larger l or, beyond l_max, an error.
RANK_TOL = 3e-6

#: Smallest admissible relative Cholesky pivot of the monomial mass matrix, d_j / M_jj (the
#: squared sine of the angle between m_j and the span of the monomials before it). Honest
#: polygons stay above 1e-7 up to l = 10; below 1e-12 the orthonormalised moments lose more than
#: 6 digits, so null-space modes could no longer be told from RANK_TOL (thin, rotated slivers).
MASS_PIVOT_TOL = 1e-12

#: status of a cell after the l choice; a dimension's geometry failures take codes from GEOMETRY_STATUS on
OK, SINGULAR_MASS, RANK_DEFICIENT, GEOMETRY_STATUS = 0, 1, 2, 3


# --------------------------------------------------------------------------- the rank check
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
        The right sides of the cell's system (``cell_system``), D = 2 on a polygon, 3 on a polyhedron.

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


# --------------------------------------------------------------------------- the dimensions' parts
def prepare_cell(mesh: Any, cell: int, tol: float) -> tuple[int, np.ndarray, float, Any]:
    """One cell of a mesh made ready for the l choice (overloaded per dimension, by the type of ``mesh``).

    Parameters
    ----------
    mesh : namedtuple
        The mesh arrays of a dimension (``PolygonCells`` or ``PolyhedronCells``).
    cell : int
        The cell's index in the mesh.
    tol : float
        Relative singular-value tolerance (:data:`RANK_TOL`), for checks of the cell's own.

    Returns
    -------
    status : int
        :data:`OK`, or a geometry failure (a code >= :data:`GEOMETRY_STATUS` of the dimension's own).
    vertices : (n_v,) int64
        The cell's global vertex numbers in its local DOF order.
    measure : float
        Area or volume |E|.
    system : namedtuple
        What ``cell_system`` needs; its fields ``centroid`` (d,), ``diameter`` and ``Pi_nabla``
        (dim P_2, n_d) are read here too (meaningless unless status is OK).
    """
    raise NotImplementedError("prepare_cell is compiled only, for the mesh tuple of a dimension")


def cell_system(system: Any, l: int) -> tuple[np.ndarray, np.ndarray]:
    """The projection system of one cell at degree l (overloaded per dimension, by the type of ``system``).

    Returns
    -------
    M : (n_l, n_l) float64
        The P_l monomial mass matrix of the cell.
    R : (d, n_l, n_d) float64
        The right sides, M Pi_m[c] = R[c] (paper Eqs. 41-42 in 2D, docs/method.md §8 in 3D).
    """
    raise NotImplementedError("cell_system is compiled only, for the cell tuple of a dimension")


def is_tuple_of(numba_type: Any, cls: type) -> bool:
    """Whether ``numba_type`` is the numba type of the namedtuple class ``cls`` (an overload's test)."""
    return isinstance(numba_type, types.BaseNamedTuple) and numba_type.instance_class is cls


# --------------------------------------------------------------------------- the l choice
@numba.njit(cache=True)
def n_monomials_in(l: int, d: int) -> int:
    """dim P_l in d variables, (l+1)...(l+d) / d!."""
    n = 1
    for i in range(1, d + 1):
        n = n * (l + i) // i
    return n


@numba.njit(cache=True)
def select_l(system, d: int, l_from: int, l_to: int, tol: float):
    """Smallest sufficient l in [l_from, l_to] for one cell (docs/method.md §3, §8), and its Pi_m.

    l is sufficient when the projected small strain u~ -> sym Pi^0_l grad u has exactly the
    r = d(d+1)/2 rigid motions in its null space (3 in 2D, 6 in 3D) *and* the projected gradient
    v~ -> Pi^0_l grad v only the constants. The strain criterion is the strict one and the one that
    matters: a non-constant scalar null-space mode v gives the non-rigid, strain-free field (v, 0),
    so strain-sufficient implies gradient-sufficient, but not conversely (the U-shaped octagon of the
    tests at l = 3: gradient nullity 1, strain nullity 5). docs/method.md's table counts zero
    eigenvalues of the linear-elastic stiffness, i.e. the strain null space. Checking both costs
    little and guards the implication against tolerance artefacts. The null space shrinks as l grows
    (P_l is contained in P_{l+1}), so the first sufficient l is the smallest. An l with
    r n_l < d n_d - r cannot be sufficient (too few strain components) and is skipped without
    computing, unless it is l_to.

    Parameters
    ----------
    system : namedtuple
        The cell's tuple for ``cell_system`` (from ``prepare_cell``); n_d = system.Pi_nabla.shape[1].
    d : int
        Dimension, 2 or 3.
    l_from, l_to : int
        Range of l tried, 1 <= l_from <= l_to.
    tol : float
        Relative singular-value tolerance (:data:`RANK_TOL`).

    Returns
    -------
    status : int
        :data:`OK`, :data:`SINGULAR_MASS` (the P_l mass matrix is numerically singular,
        :func:`cholesky`) or :data:`RANK_DEFICIENT` (no l in the range is sufficient).
    l : int
        The first sufficient l; else l_to, or the l whose mass matrix is singular.
    gradient_nullity, strain_nullity : int
        Null-space dimensions at l (:func:`null_space_dimensions`); both -1 if the mass matrix is singular.
    Q : (d, n_l, n_d) float64
        :func:`orthonormal_moments` at l.
    Pi_m : (d, n_l, n_d) float64
        :func:`gradient_projection` at l; (d, 0, n_d) unless status is OK.
    """
    r = d * (d + 1) // 2
    n_d = system.Pi_nabla.shape[1]
    l = l_from
    while True:
        if r * n_monomials_in(l, d) < d * n_d - r and l < l_to:
            l += 1  # rank(sym Pi grad) <= r n_l < d n_d - r: insufficient by counting alone
            continue
        M, R = cell_system(system, l)
        L, Q, gradient_nullity, strain_nullity = rank_of_projection(M, R, tol)
        if gradient_nullity == -1 or (gradient_nullity == 1 and strain_nullity == r) or l == l_to:
            break
        l += 1
    if gradient_nullity == -1:
        return SINGULAR_MASS, l, gradient_nullity, strain_nullity, Q, np.zeros((d, 0, n_d))
    if gradient_nullity != 1 or strain_nullity != r:
        return RANK_DEFICIENT, l, gradient_nullity, strain_nullity, Q, np.zeros((d, 0, n_d))
    return OK, l, gradient_nullity, strain_nullity, Q, gradient_projection(L, Q)


# --------------------------------------------------------------------------- many cells
@numba.njit(cache=True)
def _append(flat, offsets, j, block):
    """Put block (1D) at flat[offsets[j]:], set offsets[j + 1]; returns flat, grown if it was too short."""
    end = offsets[j] + block.size
    if end > flat.size:
        grown = np.empty(max(2 * flat.size, end), dtype=flat.dtype)
        grown[:offsets[j]] = flat[:offsets[j]]
        flat = grown
    flat[offsets[j]:end] = block
    offsets[j + 1] = end
    return flat


@numba.njit(cache=True)
def build_cells(mesh, cells, d, l_from, l_to, tol):
    """One compiled loop over the given cells: status, l, nullities, geometry, vertices, Pi_nabla, Pi_m.

    Parameters
    ----------
    mesh : namedtuple
        The mesh tuple of a dimension (``prepare_cell``).
    cells : (n,) int64
        The cells to build, in the order of the result.
    d : int
        Dimension.
    l_from, l_to : (n,) int64
        Range of l per built cell (:func:`select_l`).
    tol : float
        Relative singular-value tolerance.

    Returns
    -------
    status : (n,) int64
        :data:`OK`, :data:`SINGULAR_MASS`, :data:`RANK_DEFICIENT` or the dimension's geometry code.
    l : (n,) int64
    nullities : (n, 2) int64
        Gradient and strain nullity at l.
    centroid : (n, d) float64
    diameter, measure : (n,) float64
    vertex_offsets, vertices : (n+1,), int64
        CSR of the cells' global vertex numbers in local DOF order.
    Pi_nabla_offsets, Pi_nabla : (n+1,) int64, float64
        Pi_nabla of cell j, (dim P_2, n_d_j) in C order (zeros after a geometry failure).
    Pi_m_offsets, Pi_m : (n+1,) int64, float64
        Pi_m of cell j, (d, n_l_j, n_d_j) in C order (empty unless status is OK).
    """
    n = cells.size
    status = np.zeros(n, dtype=np.int64)
    l = np.zeros(n, dtype=np.int64)
    nullities = np.zeros((n, 2), dtype=np.int64)
    centroid = np.zeros((n, d))
    diameter = np.zeros(n)
    measure = np.zeros(n)
    vertex_offsets = np.zeros(n + 1, dtype=np.int64)
    Pi_nabla_offsets = np.zeros(n + 1, dtype=np.int64)
    Pi_m_offsets = np.zeros(n + 1, dtype=np.int64)
    vertices = np.empty(8 * n + 8, dtype=np.int64)  # all three grow when needed
    Pi_nabla = np.empty(64 * n + 64)
    Pi_m = np.empty(256 * n + 256)
    for j in range(n):
        status[j], cell_vertices, measure[j], system = prepare_cell(mesh, cells[j], tol)
        centroid[j] = system.centroid
        diameter[j] = system.diameter
        vertices = _append(vertices, vertex_offsets, j, cell_vertices)
        Pi_nabla = _append(Pi_nabla, Pi_nabla_offsets, j, system.Pi_nabla.ravel())
        if status[j] != OK:
            Pi_m_offsets[j + 1] = Pi_m_offsets[j]
            continue
        status[j], l[j], nullities[j, 0], nullities[j, 1], _, Pi_m_j = select_l(system, d, l_from[j], l_to[j], tol)
        Pi_m = _append(Pi_m, Pi_m_offsets, j, Pi_m_j.ravel())
    return (status, l, nullities, centroid, diameter, measure, vertex_offsets, vertices[:vertex_offsets[n]].copy(),
            Pi_nabla_offsets, Pi_nabla[:Pi_nabla_offsets[n]].copy(), Pi_m_offsets, Pi_m[:Pi_m_offsets[n]].copy())


@dataclass(frozen=True)
class Projections:
    """Pi^nabla_2 and Pi^0_l nabla of a set of cells (polygons, d = 2, or polyhedra, d = 3), flattened
    for the compiled loops.

    Cell j (0..n-1, in the order built) has n_d_j scalar DOFs in the order of its dimension's module
    (:mod:`~dolfinx_sfvem.discretizations.projection`, :mod:`~dolfinx_sfvem.discretizations.projection3d`)
    and n_l_j = dim P_{l_j} monomials ((l+1)(l+2)/2 in 2D, (l+1)(l+2)(l+3)/6 in 3D).

    Attributes
    ----------
    l : (n,) int64
        Degree of the gradient projection per cell.
    centroid : (n, d) float64
        x_E, the centre of the scaled monomials.
    diameter : (n,) float64
        h_E, their scale.
    measure : (n,) float64
        |E|, the area of a polygon, the volume of a polyhedron.
    vertex_offsets : (n+1,) int64
    vertices : (vertex_offsets[-1],) int64
        The global vertex numbers of cell j in its local DOF order (counter-clockwise around a
        polygon, increasing in a polyhedron): ``vertices_of(j)``.
    Pi_nabla_offsets : (n+1,) int64
    Pi_nabla : (Pi_nabla_offsets[-1],) float64
        Pi_nabla of cell j, (dim P_2, n_d_j) in C order: ``Pi_nabla_of(j)``.
    Pi_m_offsets : (n+1,) int64
    Pi_m : (Pi_m_offsets[-1],) float64
        Pi_m of cell j, (d, n_l_j, n_d_j) in C order: ``Pi_m_of(j)``.
    """

    l: npt.NDArray[np.int64]
    centroid: npt.NDArray[np.float64]
    diameter: npt.NDArray[np.float64]
    measure: npt.NDArray[np.float64]
    vertex_offsets: npt.NDArray[np.int64]
    vertices: npt.NDArray[np.int64]
    Pi_nabla_offsets: npt.NDArray[np.int64]
    Pi_nabla: npt.NDArray[np.float64]
    Pi_m_offsets: npt.NDArray[np.int64]
    Pi_m: npt.NDArray[np.float64]

    @property
    def dim(self) -> int:
        """d, 2 or 3."""
        return self.centroid.shape[1]

    @property
    def n_cells(self) -> int:
        """n, the number of cells built."""
        return self.l.size

    def vertices_of(self, j: int) -> npt.NDArray[np.int64]:
        """Global vertex numbers of cell j, (n_v_j,), in its local DOF order (a view)."""
        return self.vertices[self.vertex_offsets[j]:self.vertex_offsets[j + 1]]

    def Pi_nabla_of(self, j: int) -> npt.NDArray[np.float64]:
        """Pi_nabla of cell j, (dim P_2, n_d_j): (6, n_d_j) in 2D, (10, n_d_j) in 3D (a view)."""
        return self.Pi_nabla[self.Pi_nabla_offsets[j]:self.Pi_nabla_offsets[j + 1]].reshape(
            math.comb(2 + self.dim, self.dim), -1)

    def Pi_m_of(self, j: int) -> npt.NDArray[np.float64]:
        """Pi_m of cell j, (d, dim P_l_j, n_d_j) (a view)."""
        block = self.Pi_m[self.Pi_m_offsets[j]:self.Pi_m_offsets[j + 1]]
        return block.reshape(self.dim, math.comb(int(self.l[j]) + self.dim, self.dim), -1)

    def histogram(self) -> dict[int, int]:
        """Number of cells per degree l, {l: count}, increasing l."""
        values, counts = np.unique(self.l, return_counts=True)
        return {int(v): int(c) for v, c in zip(values, counts)}

    def summary(self) -> str:
        """One line: the number of cells and the distribution of l."""
        parts = ", ".join(f"l={k}: {c} ({100.0 * c / self.n_cells:.1f}%)" for k, c in self.histogram().items())
        return f"SFVEM projections of {self.n_cells} {'polygons' if self.dim == 2 else 'polyhedra'}; {parts}"


# --------------------------------------------------------------------------- checks and errors
def l_range(l: int | npt.ArrayLike | None, n: int, l_min: int, l_max: int) -> tuple[np.ndarray, np.ndarray]:
    """Per built cell the range [l_from, l_to] searched by :func:`select_l`, (n,) int64 each: [l_min,
    l_max] without ``l``, else [l, l] with ``l`` an int or one int per built cell (n,)."""
    if not 1 <= l_min <= l_max:
        raise ValueError(f"need 1 <= l_min <= l_max, got l_min={l_min}, l_max={l_max}")
    if l is None:
        return np.full(n, l_min, dtype=np.int64), np.full(n, l_max, dtype=np.int64)
    l_given = np.asarray(l)
    if not np.issubdtype(l_given.dtype, np.integer) or l_given.ndim > 1 or l_given.ndim == 1 and l_given.size != n:
        raise ValueError(f"l must be an int or one int per built cell ({n}), got {l!r}")
    l_given = np.broadcast_to(l_given.astype(np.int64), (n,)).copy()
    bad = np.flatnonzero((l_given < 1) | (l_given > l_max))
    if bad.size:
        raise ValueError(f"l={l_given[bad[0]]} (built cell {bad[0]}) is outside [1, l_max={l_max}]; "
                         "raise l_max to allow it")
    return l_given, l_given


def projection_error(cell: int, status: int, l: int, nullities: npt.ArrayLike, d: int, l_given: bool, l_max: int,
                     sufficient_above: Callable[[int], int | None]) -> ValueError:
    """The error for a cell whose projection failed at l (status :data:`SINGULAR_MASS` or :data:`RANK_DEFICIENT`).

    Parameters
    ----------
    cell : int
        The cell's number in its mesh, named as ``cell N:``.
    status, l : int
        From :func:`select_l`.
    nullities : (2,) int
        Gradient and strain nullity at l.
    d : int
        Dimension (the d(d+1)/2 rigid motions expected).
    l_given : bool
        Whether l was given (then l is called rank-deficient) or searched up to l_max.
    l_max : int
        The largest l allowed.
    sufficient_above : callable
        ``sufficient_above(l)``: the smallest sufficient l in [l + 1, l_max] for the cell, or None;
        called for a given rank-deficient l < l_max, to name the l to use instead.
    """
    if status == SINGULAR_MASS:
        return ValueError(f"cell {cell}: the P_{l} monomial mass matrix is numerically singular (relative Cholesky "
                          f"pivot < {MASS_PIVOT_TOL:g}); the cell is too thin or degenerate for scaled monomials of "
                          f"degree {l}")
    deficiency = (f"{nullities[1]} zero-strain modes where the {d * (d + 1) // 2} rigid motions are expected, "
                  f"gradient null space {nullities[0]} where 1 is expected")
    tolerance = f"relative SVD tolerance {RANK_TOL:g}"
    if not l_given:
        return ValueError(f"cell {cell}: no l <= l_max={l_max} is sufficient: {deficiency} at l={l} ({tolerance}); "
                          "degenerate cell or l_max too small")
    smallest = sufficient_above(l) if l < l_max else None
    better = (f"the smallest sufficient l is {smallest}" if smallest is not None
              else f"no l <= l_max={l_max} is sufficient")
    return ValueError(f"cell {cell}: l={l} is rank-deficient ({deficiency}; {tolerance}); {better}")


def build_cell_projections(mesh: Any, cells: npt.NDArray[np.int64], d: int, l: int | npt.ArrayLike | None,
                           l_min: int, l_max: int, geometry_error: Callable[[int, int], ValueError]) -> Projections:
    """:func:`build_cells` with the checks: the l range, and the error naming the first failing cell.

    Parameters
    ----------
    mesh : namedtuple
        The mesh tuple of a dimension (``prepare_cell``).
    cells : (n,) int64
        The cells to build; the result is indexed 0..n-1 in this order.
    d : int
        Dimension.
    l : int or (n,) int, optional
        Degree of the gradient projection for all cells or per built cell; it must be sufficient.
        Default: per cell the smallest sufficient l in [l_min, l_max] (:func:`select_l`).
    l_min, l_max : int
        Range of the automatic choice; l_max also bounds a given l.
    geometry_error : callable
        ``geometry_error(cell, status)``: the dimension's error for a geometry failure of a cell.

    Raises
    ------
    ValueError
        For the first failing cell: its geometry error, or :func:`projection_error`.
    """
    l_from, l_to = l_range(l, cells.size, l_min, l_max)
    (status, l_used, nullities, centroid, diameter, measure, vertex_offsets, vertices, Pi_nabla_offsets, Pi_nabla,
     Pi_m_offsets, Pi_m) = build_cells(mesh, cells, d, l_from, l_to, RANK_TOL)
    failed = np.flatnonzero(status != OK)
    if failed.size:
        j = int(failed[0])
        cell, l_j = int(cells[j]), int(l_used[j])
        if status[j] >= GEOMETRY_STATUS:
            raise geometry_error(cell, int(status[j]))

        def sufficient_above(l_j: int) -> int | None:
            again = build_cells(mesh, cells[j:j + 1], d, np.array([l_j + 1]), np.array([l_max]), RANK_TOL)
            return int(again[1][0]) if again[0][0] == OK else None

        raise projection_error(cell, int(status[j]), l_j, nullities[j], d, l is not None, l_max, sufficient_above)
    return Projections(l_used, centroid, diameter, measure, vertex_offsets, vertices, Pi_nabla_offsets, Pi_nabla,
                       Pi_m_offsets, Pi_m)
