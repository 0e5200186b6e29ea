"""Compiled loops over the polyhedra of a mesh: residual, tangent, projected fields, body force.

The mesh-level counterpart of :mod:`dolfinx_sfvem.discretizations.hyperelastic3d` (one element), as
:mod:`dolfinx_sfvem.discretizations.assemble` is for polygons: each loop walks the local polyhedra of a region,
gathers their DOFs from the nodal array u (n_local_nodes, 3), calls the element functions and
scatters into the nodal residual (n_local_nodes, 3) or into the COO values of the tangent
(node-major: local unknown ``3 a + i`` is component i of the polyhedron's DOF a, the layout of
:meth:`~dolfinx_sfvem.discretizations.polyhedral_space.PolyhedralSpace.create_matrix`).
"""
from __future__ import annotations

import typing

import numba
import numpy as np

from dolfinx_sfvem.discretizations.hyperelastic3d import basis_table, element_residual, element_tangent
from dolfinx_sfvem.discretizations.monomials3d import evaluate_monomials3


class PolyhedronTables(typing.NamedTuple):
    """What the mesh loops read of every local polyhedron e (a NamedTuple: numba takes it as one
    argument).

    Attributes
    ----------
    dof_off : (n + 1,) int64
        Polyhedron e's DOFs are ``dofs[dof_off[e]:dof_off[e + 1]]`` (n_d of them, the order of
        :mod:`~dolfinx_sfvem.discretizations.projection3d`).
    dofs : (dof_off[-1],) int64
        Local node of every DOF.
    q_off : (n + 1,) int64
        Polyhedron e's quadrature points are ``q_off[e]:q_off[e + 1]``.
    w_q : (q_off[-1],) float64
        Quadrature weights [volume].
    nphi : (n,) int64
        Rows of the basis table per point (3, or 12 where the energy uses G).
    phi_off : (n + 1,) int64
        Offsets of the tables in ``Phi``; the table of e is (n_d, n_q, nphi[e]).
    Phi : (phi_off[-1],) float64
        :func:`basis_table` of every polyhedron.
    """
    dof_off: np.ndarray
    dofs: np.ndarray
    q_off: np.ndarray
    w_q: np.ndarray
    nphi: np.ndarray
    phi_off: np.ndarray
    Phi: np.ndarray


@numba.njit(cache=True)
def basis_tables(dof_off, q_off, x_q, l, centroid, diameter, pim_off, Pi_m, nphi, phi_off):
    """:func:`basis_table` of every polyhedron, flattened in the order of ``phi_off``."""
    Phi = np.empty(phi_off[-1])
    for e in range(dof_off.size - 1):
        nd = dof_off[e + 1] - dof_off[e]
        nl = (l[e] + 1) * (l[e] + 2) * (l[e] + 3) // 6
        block = Pi_m[pim_off[e]:pim_off[e + 1]].reshape(3, nl, nd)
        table = basis_table(x_q[q_off[e]:q_off[e + 1]], centroid[e], diameter[e], l[e], block, nphi[e])
        Phi[phi_off[e]:phi_off[e + 1]] = table.ravel()
    return Phi


@numba.njit(cache=True)
def _table(t, e):
    """The basis table (n_d, n_q, nphi) of polyhedron e (a view)."""
    nd = t.dof_off[e + 1] - t.dof_off[e]
    nq = t.q_off[e + 1] - t.q_off[e]
    return t.Phi[t.phi_off[e]:t.phi_off[e + 1]].reshape(nd, nq, t.nphi[e])


@numba.njit(cache=True)
def _element_values(t, e, u):
    """The displacement DOFs (3, n_d) of polyhedron e from the local nodal array u (n_nodes, 3)."""
    d0, nd = t.dof_off[e], t.dof_off[e + 1] - t.dof_off[e]
    ue = np.empty((3, nd))
    for a in range(nd):
        for i in range(3):
            ue[i, a] = u[t.dofs[d0 + a], i]
    return ue


@numba.njit(cache=True)
def residual_loop(kernel, c, F_at, G_at, P_at, T_at, cells, t, u, R, stats):
    """R (n_nodes, 3) += dW/du of ``cells`` (Eq. 52); stats = [energy, min J, cell of min J] updated."""
    for e in cells:
        energy, Re, min_J = element_residual(kernel, c, F_at, G_at, P_at, T_at, _table(t, e),
                                             t.w_q[t.q_off[e]:t.q_off[e + 1]], _element_values(t, e, u))
        stats[0] += energy
        if not min_J > stats[1]:
            stats[1] = min_J
            stats[2] = e
        d0 = t.dof_off[e]
        for a in range(Re.shape[1]):
            for i in range(3):
                R[t.dofs[d0 + a], i] += Re[i, a]


@numba.njit(cache=True)
def tangent_loop(kernel, c, F_at, G_at, D_at, A_at, B_at, cells, t, u, values, coo_off, add):
    """The element tangents (Eq. 56) of ``cells`` into the COO values, node-major ((3 a + i) rows of
    :meth:`PolyhedralSpace.create_matrix`); written, or added when ``add`` (energy terms)."""
    for e in cells:
        K = element_tangent(kernel, c, F_at, G_at, D_at, A_at, B_at, _table(t, e),
                            t.w_q[t.q_off[e]:t.q_off[e + 1]], _element_values(t, e, u))
        nd = K.shape[0] // 3
        pos = coo_off[e]
        for a in range(nd):
            for i in range(3):
                for b in range(nd):
                    for m in range(3):
                        v = K[i * nd + a, m * nd + b]
                        if add:
                            values[pos] += v
                        else:
                            values[pos] = v
                        pos += 1


@numba.njit(cache=True)
def gradient_at(t, e, q, ue, grad):
    """grad (3, 3) = Pi^0_l grad u of polyhedron e at its quadrature point q (DOFs ue (3, n_d))."""
    table = _table(t, e)
    for i in range(3):
        for j in range(3):
            s = 0.0
            for a in range(ue.shape[1]):
                s += ue[i, a] * table[a, q, j]
            grad[i, j] = s


@numba.njit(cache=True)
def _pi_nabla(pin_off, Pi_nabla, e, nd):
    return Pi_nabla[pin_off[e]:pin_off[e + 1]].reshape(10, nd)


@numba.njit(cache=True)
def projected_fields(t, x_q, centroid, diameter, pin_off, Pi_nabla, u, u_q, grad_q):
    """Pi^nabla_2 u (n_q, 3) and Pi^0_l grad u (n_q, 3, 3) at the quadrature points of every
    polyhedron (docs/method.md §8)."""
    m = np.empty(10)
    dm = np.empty((3, 10))
    for e in range(t.dof_off.size - 1):
        ue = _element_values(t, e, u)
        nd = ue.shape[1]
        Pn = _pi_nabla(pin_off, Pi_nabla, e, nd)
        coefficients = ue @ Pn.T                          # (3, 10): u's projection in monomials
        for q in range(t.q_off[e + 1] - t.q_off[e]):
            k = t.q_off[e] + q
            evaluate_monomials3(x_q[k], centroid[e], diameter[e], 2, m, dm)
            for i in range(3):
                s = 0.0
                for b in range(10):
                    s += coefficients[i, b] * m[b]
                u_q[k, i] = s
            gradient_at(t, e, q, ue, grad_q[k])


@numba.njit(cache=True)
def load_loop(t, x_q, centroid, diameter, pin_off, Pi_nabla, f_q, F):
    """F (n_nodes, 3) += int_E f . Pi^nabla_2 v dE of every polyhedron (f_q (n_q, 3) at the
    quadrature points)."""
    m = np.empty(10)
    dm = np.empty((3, 10))
    for e in range(t.dof_off.size - 1):
        d0, nd = t.dof_off[e], t.dof_off[e + 1] - t.dof_off[e]
        Pn = _pi_nabla(pin_off, Pi_nabla, e, nd)
        moments = np.zeros((3, 10))                       # int_E f_i m_b
        for k in range(t.q_off[e], t.q_off[e + 1]):
            evaluate_monomials3(x_q[k], centroid[e], diameter[e], 2, m, dm)
            for i in range(3):
                for b in range(10):
                    moments[i, b] += t.w_q[k] * f_q[k, i] * m[b]
        Fe = moments @ Pn
        for a in range(nd):
            for i in range(3):
                F[t.dofs[d0 + a], i] += Fe[i, a]


@numba.njit(cache=True)
def deformation_at(points, cell, t, l, centroid, diameter, pim_off, Pi_m, u, F, G):
    """F = I + Pi^0_l grad u (n, 3, 3) and its gradient G (n, 3, 3, 3) at ``points`` (n, 3), each in
    the polyhedron ``cell`` (n,) (local index)."""
    for p in range(points.shape[0]):
        e = cell[p]
        nd = t.dof_off[e + 1] - t.dof_off[e]
        nl = (l[e] + 1) * (l[e] + 2) * (l[e] + 3) // 6
        block = Pi_m[pim_off[e]:pim_off[e + 1]].reshape(3, nl, nd)
        table = basis_table(points[p:p + 1], centroid[e], diameter[e], l[e], block, 12)
        ue = _element_values(t, e, u)
        for i in range(3):
            for j in range(3):
                s = 1.0 if i == j else 0.0
                for a in range(nd):
                    s += ue[i, a] * table[a, 0, j]
                F[p, i, j] = s
                for k in range(3):
                    s = 0.0
                    for a in range(nd):
                        s += ue[i, a] * table[a, 0, 3 + 3 * j + k]
                    G[p, i, j, k] = s
