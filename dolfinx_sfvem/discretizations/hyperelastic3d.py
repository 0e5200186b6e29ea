"""The finite-strain SFVEM element on one polyhedron: energy, residual and consistent tangent.

The 3D counterpart of the polygon loops of :mod:`dolfinx_sfvem.discretizations.assemble` (docs/method.md §8.x):
at the element's quadrature points x_q the projected derivatives of the n_d scalar basis
functions (:mod:`dolfinx_sfvem.discretizations.projection3d`)

    dphi[j, a]     = m(x_q) . Pi_m[j, :, a]            (d phi_a / dX_j)
    d2phi[j, k, a] = d_k m(x_q) . Pi_m[j, :, a]        (d/dX_k of the projected d phi_a / dX_j)

give F = I + sum_a u[:, a] (x) dphi[:, a] and G_ijk = sum_a u[i, a] d2phi[j, k, a], and the
compiled pointwise kernels of the energy (:mod:`dolfinx_sfvem.discretizations.compiled_energy`, ``dim=3``) give
Psi, P, T and D, A, B there (paper Eqs. 30, 32). With the table rows
Phi[a, q, :] = [dphi[0..d-1, a], d2phi[j, k, a] at d + d j + k] (nphi = d + d² rows when the
energy uses G, d otherwise) the element quantities are (Eqs. 48, 52, 56)

    W        = sum_q w_q Psi_q
    R[i, a]  = sum_q w_q sum_al S_q[i, al] Phi[a, q, al],   S = [P_ij, T_ijk]
    K[(i, a), (m, b)] = sum_q w_q Phi[a, q, :] . C_q[i, :, m, :] Phi[b, q, :],
    C[i, al, m, be] = [[D_ijmn, A_mnr,ij], [A_ijk,mn, B_ijk,mnr]].

The loops read the dimension d from the displacement's shape; the row layout of the table is
the 2D one of :func:`dolfinx_sfvem.discretizations.assemble.basis_derivative_tables` for d = 2.

Element vectors and matrices are component-major, as
:func:`~dolfinx_sfvem.discretizations.elasticity.linear_elastic_stiffness_3d`: unknown ``i n_d + a`` is component
i of DOF a (the local DOF order of :mod:`dolfinx_sfvem.discretizations.projection3d`).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numba
import numpy as np
import numpy.typing as npt

from dolfinx_sfvem._compat import call_kernel, kernel_scratch
from dolfinx_sfvem.discretizations.assemble import CONTRACT
from dolfinx_sfvem.discretizations.compiled_energy import EnergyKernels, compile_kernels
from dolfinx_sfvem.physics.energy import Energy
from dolfinx_sfvem.discretizations.monomials3d import evaluate_monomials3, n_monomials3
from dolfinx_sfvem.mesh.polyhedron import energy_quadrature
from dolfinx_sfvem.discretizations.projection3d import PolyhedronProjections, polyhedron_projections


#: quadrature points per product in :func:`element_tangent` (bounds its work arrays)
CHUNK = 256


@numba.njit(cache=True)
def basis_table(x_q, centroid, diameter, l, Pi_m, nphi):
    """Phi (n_d, n_q, nphi) of one polyhedron: the projected first derivatives of its basis
    functions, and (nphi = 12) their derivatives, at the points x_q (n_q, 3) (module docstring)."""
    nl, nd = Pi_m.shape[1], Pi_m.shape[2]
    m = np.empty(n_monomials3(max(l, 2)))
    dm = np.empty((3, m.size))
    table = np.zeros((nd, x_q.shape[0], nphi))
    for q in range(x_q.shape[0]):
        evaluate_monomials3(x_q[q], centroid, diameter, l, m, dm)
        for j in range(3):
            for a in range(nd):
                s = 0.0
                for b in range(nl):
                    s += m[b] * Pi_m[j, b, a]
                table[a, q, j] = s
                if nphi > 3:
                    for k in range(3):
                        s = 0.0
                        for b in range(nl):
                            s += dm[k, b] * Pi_m[j, b, a]
                        table[a, q, 3 + 3 * j + k] = s
    return table


@numba.njit(cache=True)
def _determinant(c, F_at, d):
    """det F of the row-major F (d, d) at c[F_at:], d = 2 or 3."""
    if d == 2:
        return c[F_at] * c[F_at + 3] - c[F_at + 1] * c[F_at + 2]
    return (c[F_at] * (c[F_at + 4] * c[F_at + 8] - c[F_at + 5] * c[F_at + 7])
            - c[F_at + 1] * (c[F_at + 3] * c[F_at + 8] - c[F_at + 5] * c[F_at + 6])
            + c[F_at + 2] * (c[F_at + 3] * c[F_at + 7] - c[F_at + 4] * c[F_at + 6]))


@numba.njit(cache=True, fastmath=CONTRACT)
def _set_deformation(table, q, u, c, F_at, G_at):
    """Write F = I + grad u and G (row-major) of point q into the constants; return J = det F."""
    d, nd = u.shape
    nphi = table.shape[2]
    for i in range(d):
        for al in range(nphi):
            s = 0.0
            for a in range(nd):
                s += u[i, a] * table[a, q, al]
            if al < d:
                c[F_at + d * i + al] = s + (1.0 if i == al else 0.0)
            else:
                c[G_at + d * d * i + al - d] = s
    return _determinant(c, F_at, d)


@numba.njit(cache=True, fastmath=CONTRACT)
def element_residual(kernel, c, F_at, G_at, P_at, T_at, table, w_q, u):
    """Energy, residual (Eq. 52) and smallest J of one element.

    Parameters
    ----------
    kernel
        The compiled residual kernel ([Psi, P(d²), T(d³)], or [Psi, P]).
    c : (n_constants,) float64
        Its constants, parameters packed (F and G are written here).
    F_at, G_at, P_at, T_at : int
        Offsets of F and G in c, of P and T in the kernel output (T_at unused when the table
        has d rows per point).
    table : (n_d, n_q, nphi) float64
        :func:`basis_table`.
    w_q : (n_q,) float64
        Quadrature weights.
    u : (d, n_d) float64
        The element's displacement DOFs.

    Returns
    -------
    energy : float
    R : (d, n_d) float64
    min_J : float
    """
    d, nd = u.shape
    nq, nphi = table.shape[1], table.shape[2]
    out = np.zeros(1 + d * d + (d ** 3 if nphi > d else 0))
    scratch = kernel_scratch()
    S = np.empty((d, nphi))
    R = np.zeros((d, nd))
    energy = 0.0
    min_J = np.inf
    for q in range(nq):
        J = _set_deformation(table, q, u, c, F_at, G_at)
        if not J > min_J:
            min_J = J
        out[:] = 0.0
        call_kernel(kernel, out, c, scratch)
        w = w_q[q]
        energy += w * out[0]
        for i in range(d):
            for al in range(nphi):
                S[i, al] = w * (out[P_at + d * i + al] if al < d else out[T_at + d * d * i + al - d])
        for i in range(d):
            for a in range(nd):
                s = 0.0
                for al in range(nphi):
                    s += S[i, al] * table[a, q, al]
                R[i, a] += s
    return energy, R, min_J


@numba.njit(cache=True, fastmath=CONTRACT)
def element_tangent(kernel, c, F_at, G_at, D_at, A_at, B_at, table, w_q, u):
    """The consistent tangent (Eq. 56) of one element, (d n_d, d n_d) component-major.

    ``kernel`` is the compiled tangent kernel ([D(d⁴), A(d⁵), B(d⁶)], or [D]); D_at, A_at, B_at
    its offsets (A_at, B_at unused when the table has d rows per point); the other arguments as
    in :func:`element_residual`. Per component pair (i, m), Z = C_im Phi at the points of a chunk
    of :data:`CHUNK`, then K_im += Phi Z^T as one product over them (the chunk's table as
    (n_d, CHUNK nphi)); K_mi = K_im^T.
    """
    d, nd = u.shape
    nq, nphi = table.shape[1], table.shape[2]
    d2, d3 = d * d, d * d * d
    out = np.zeros(d2 * d2 + ((d2 * d3 + d3 * d3) if nphi > d else 0))
    scratch = kernel_scratch()
    n_chunk = min(nq, CHUNK)
    C = np.empty((d, d, n_chunk, nphi, nphi))      # w_q C[i, al, m, be] at [i, m, q - q0, al, be]
    Phi = np.empty((nd, n_chunk * nphi))
    Z = np.empty((nd, n_chunk * nphi))
    K = np.zeros((d * nd, d * nd))
    for q0 in range(0, nq, n_chunk):
        n = min(n_chunk, nq - q0)
        for p in range(n):
            q = q0 + p
            _set_deformation(table, q, u, c, F_at, G_at)
            out[:] = 0.0
            call_kernel(kernel, out, c, scratch)
            w = w_q[q]
            for i in range(d):
                for m in range(d):
                    for al in range(nphi):
                        for be in range(nphi):
                            if al < d and be < d:        # D_ijmn
                                v = out[D_at + d3 * i + d2 * al + d * m + be]
                            elif be < d:                 # A_ijk,mn, (j, k) = al - d
                                v = out[A_at + d2 * d2 * i + d2 * (al - d) + d * m + be]
                            elif al < d:                 # A_mnr,ij, (n, r) = be - d
                                v = out[A_at + d2 * d2 * m + d2 * (be - d) + d * i + al]
                            else:                        # B_ijk,mnr
                                v = out[B_at + d2 * d3 * i + d3 * (al - d) + d2 * m + be - d]
                            C[i, m, p, al, be] = w * v
            for b in range(nd):
                for al in range(nphi):
                    Phi[b, p * nphi + al] = table[b, q, al]
        if n < n_chunk:
            Phi[:, n * nphi:] = 0.0
        for i in range(d):
            for m in range(i, d):
                for b in range(nd):
                    for p in range(n):
                        for al in range(nphi):
                            s = 0.0
                            for be in range(nphi):
                                s += C[i, m, p, al, be] * Phi[b, p * nphi + be]
                            Z[b, p * nphi + al] = s
                    Z[b, n * nphi:] = 0.0
                K[i * nd:(i + 1) * nd, m * nd:(m + 1) * nd] += Phi @ Z.T
    for i in range(d):                                   # K_mi = K_im^T
        for m in range(i + 1, d):
            K[m * nd:(m + 1) * nd, i * nd:(i + 1) * nd] = K[i * nd:(i + 1) * nd, m * nd:(m + 1) * nd].T
    return K


@dataclass(frozen=True)
class HyperelasticPolyhedron:
    """One polyhedron with a hyperelastic energy Psi(F, G): its element energy, residual and tangent.

    Build it with :func:`hyperelastic_polyhedron`. Displacements ``u`` are (3, n_d): the DOFs of
    each component in the order of :mod:`dolfinx_sfvem.discretizations.projection3d`.

    Attributes
    ----------
    projections : PolyhedronProjections
    kernels : EnergyKernels
        The energy's 3D kernels.
    constants : (n_constants,) float64
        The kernels' constants with the energy's parameters.
    x_q, w_q : (n_q, 3), (n_q,) float64
        The energy quadrature (exact for degree 2 l by default).
    table : (n_d, n_q, nphi) float64
        :func:`basis_table`.
    """

    projections: PolyhedronProjections
    kernels: EnergyKernels
    constants: npt.NDArray[np.float64]
    x_q: npt.NDArray[np.float64]
    w_q: npt.NDArray[np.float64]
    table: npt.NDArray[np.float64]

    def _u(self, u: npt.ArrayLike) -> npt.NDArray[np.float64]:
        u = np.ascontiguousarray(u, dtype=np.float64).reshape(3, -1)
        if u.shape[1] != self.projections.n_dofs:
            raise ValueError(f"u has {u.shape[1]} DOFs per component, the element {self.projections.n_dofs}")
        return u

    def residual(self, u: npt.ArrayLike) -> tuple[float, npt.NDArray[np.float64], float]:
        """(energy int_E Psi, residual dW/du (3, n_d), smallest J at the quadrature points) at u."""
        k = self.kernels
        return element_residual(k.residual, self.constants.copy(), k.F_offset, k.G_offset, k.residual_offsets["P"],
                                k.residual_offsets.get("T", -1), self.table, self.w_q, self._u(u))

    def energy(self, u: npt.ArrayLike) -> float:
        """int_E Psi(F, G) by the element's quadrature."""
        return self.residual(u)[0]

    def tangent(self, u: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """d²W/du² (3 n_d, 3 n_d), component-major."""
        k = self.kernels
        off = k.tangent_offsets
        return element_tangent(k.tangent, self.constants.copy(), k.F_offset, k.G_offset, off["D"], off.get("A", -1),
                               off.get("B", -1), self.table, self.w_q, self._u(u))


def hyperelastic_polyhedron(points: npt.ArrayLike, faces: Sequence[npt.ArrayLike], energy: Energy,
                            params: Mapping[str, float] | None = None, l: int | None = None,
                            degree: int | None = None, quadrature: str = "auto") -> HyperelasticPolyhedron:
    """The finite-strain element of one polyhedron (module docstring).

    Parameters
    ----------
    points, faces
        The polyhedron (:mod:`~dolfinx_sfvem.mesh.polyhedron`: vertices (n_v, 3), outward cyclic faces).
    energy
        Psi(F, G); its kernels are compiled in 3D (FFCx, once per energy structure).
    params
        Parameter values; default the energy's own.
    l
        Degree of the gradient projection; default the smallest sufficient one.
    degree
        Degree of exactness of the energy quadrature; default 2 l (exact for the linearized energy).
    quadrature
        Its rule (:func:`~dolfinx_sfvem.mesh.polyhedron.energy_quadrature`): "auto" (tensor rule on boxes,
        sub-tetrahedra elsewhere), "tetrahedra" or "compressed".
    """
    projections = polyhedron_projections(points, faces, l)
    kernels = compile_kernels(energy, dim=3)
    constants = kernels.pack_constants(energy.params if params is None else params)
    x_q, w_q = energy_quadrature(points, faces, 2 * projections.l if degree is None else degree, quadrature)
    nphi = 12 if kernels.uses_gradient else 3
    table = basis_table(np.ascontiguousarray(x_q), projections.centroid, projections.diameter, projections.l,
                        np.ascontiguousarray(projections.Pi_m), nphi)
    return HyperelasticPolyhedron(projections, kernels, constants, x_q, w_q, table)

