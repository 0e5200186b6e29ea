"""SFVEM polygon loops: energy, residual (paper Eq. 52) and tangent (Eq. 56).

For every polygon E and quadrature point x_q the projected gradients of the 2N+1 scalar
basis functions are (Eq. 43 and Eq. 45)

    dphi[j, a]    = m(x_q) · Pi_m[j, :, a]              (∂φ_a/∂X_j)
    d2phi[j, k, a] = ∂_k m(x_q) · Pi_m[j, :, a]          (∂/∂X_k of the projected ∂φ_a/∂X_j)

so that F = I + Σ_a u_a ⊗ dphi[:, a] and G_ijk = Σ_a u_ia d2phi[j, k, a] (not symmetrised
in j, k). The compiled pointwise energy kernels (``compiled_energy.py``) return P, T and D, A, B
(Eqs. 30-32); here they are contracted with the B1 = dphi and B2 = d2phi operators
(Eqs. 49-51). Instead of the paper's matrix forms (Eqs. 53-54, C.1-C.3) the operators are
kept per displacement component: with Φ = [dphi; d2phi] (6 × nd) and, for the component
pair (i, m), the 6 × 6 block

    C_im = [[D_ijmn,  A_mnpij ],
            [A_ijkmn, B_ijkmnp]],

the tangent is K[(i,a),(m,b)] = Σ_q w_q Φ[:, a]ᵀ C_im Φ[:, b] — Eq. 56 term by term.

Element vectors and matrices are node-major: local unknown ``2 a + i`` is component i
of the a-th DOF of the polygon.
"""
from __future__ import annotations

import typing

import numba
import numpy as np

from dolfinx_sfvem._compat import call_kernel, kernel_scratch
from dolfinx_sfvem.discretizations.monomials import evaluate_monomials

#: fast-math flags of the contraction loops: FMA and reassociated sums (vectorisable);
#: NaN/Inf semantics unchanged (the J check must see NaN)
CONTRACT = {"contract", "reassoc"}


class PolygonTables(typing.NamedTuple):
    """What the energy loops read of every local polygon e (a NamedTuple: numba takes it as one
    argument).

    Attributes
    ----------
    dof_off : (n_polygons + 1,) int64
        Polygon e's DOFs are ``dofs[dof_off[e]:dof_off[e + 1]]`` (nd = 2N + 1 of them).
    dofs : (dof_off[-1],) int
        Local node of every polygon DOF (vertices, edge midpoints, then the mean).
    phi_off : (n_polygons + 1,) int64
        Offsets of the polygons' basis derivative tables in ``Phi``.
    Phi : (phi_off[-1],)
        Basis derivative tables of :func:`basis_derivative_tables` (Eqs. 43, 45).
    q_off : (n_polygons + 1,) int64
        Polygon e's quadrature points are ``q_off[e]:q_off[e + 1]``.
    w_q : (q_off[-1],)
        Quadrature weights [area].
    """
    dof_off: np.ndarray
    dofs: np.ndarray
    phi_off: np.ndarray
    Phi: np.ndarray
    q_off: np.ndarray
    w_q: np.ndarray


@numba.njit(cache=True)
def _projected_derivatives(x, xE, hE, l, Pi_m, m, dm, dphi, d2phi):
    """dphi (2, nd) and d2phi (2, 2, nd) of all basis functions at the point x (Eqs. 43, 45)."""
    evaluate_monomials(x, xE, hE, l, m, dm[0], dm[1])
    nl, nd = Pi_m.shape[1], Pi_m.shape[2]
    for j in range(2):
        for a in range(nd):
            s = 0.0
            s0 = 0.0
            s1 = 0.0
            for b in range(nl):
                p = Pi_m[j, b, a]
                s += m[b] * p
                s0 += dm[0, b] * p
                s1 += dm[1, b] * p
            dphi[j, a] = s
            d2phi[j, 0, a] = s0
            d2phi[j, 1, a] = s1


@numba.njit(cache=True)
def _polygon_block(Pi_m_flat, pim_off, e, l, nd):
    nl = (l + 1) * (l + 2) // 2
    return Pi_m_flat[pim_off[e]:pim_off[e + 1]].reshape(2, nl, nd)


@numba.njit(cache=True)
def _gather(u, dofs, d0, nd):
    """Nodal values (nd, 2) of one polygon from the local array u (n_local_nodes, 2)."""
    ue = np.empty((nd, 2))
    for a in range(nd):
        ue[a, 0] = u[dofs[d0 + a], 0]
        ue[a, 1] = u[dofs[d0 + a], 1]
    return ue


@numba.njit(cache=True)
def _monomial_scratch(l):
    """Work arrays for the monomials (and derivatives) of the largest degree in ``l`` (at least 2)."""
    k = max(l.max() if l.size else 2, 2)
    n = (k + 1) * (k + 2) // 2
    return np.empty(n), np.empty((2, n))


@numba.njit(cache=True)
def basis_derivative_tables(dof_off, l, xE, hE, pim_off, Pi_m, q_off, x_q, nphi, phi_off):
    """Φ = [dphi; d2phi] (Eqs. 43, 45) of every polygon at its quadrature points.

    Parameters
    ----------
    nphi : (n_polygons,) int64
        Rows per point: 2 (first derivatives, energies without gradient) or 6.
    phi_off : (n_polygons + 1,) int64
        Offsets of the tables, ``phi_off[e + 1] - phi_off[e] = nd(e) n_q(e) nphi[e]``.

    Returns
    -------
    Phi : (phi_off[-1],) float64
        Polygon e's table at ``Phi[phi_off[e]:phi_off[e + 1]]``, shape (nd(e), n_q(e), nphi[e])
        row-major; row α of point q is ``[∂_0φ, ∂_1φ, ∂_0∂_0φ, ∂_1∂_0φ, ∂_0∂_1φ, ∂_1∂_1φ][α]``:
        α = 2 + 2j + k is ∂_k of the projected ∂_jφ (d2phi[j, k]).
    """
    Phi = np.empty(phi_off[-1])
    m, dm = _monomial_scratch(l)
    for e in range(dof_off.size - 1):
        nd = dof_off[e + 1] - dof_off[e]
        Pi = _polygon_block(Pi_m, pim_off, e, l[e], nd)
        dphi = np.empty((2, nd))
        d2phi = np.empty((2, 2, nd))
        nq = q_off[e + 1] - q_off[e]
        table = _table(Phi, phi_off, e, nd, nq * nphi[e]).reshape(nd, nq, nphi[e])
        for q in range(nq):
            _projected_derivatives(x_q[q_off[e] + q], xE[e], hE[e], l[e], Pi, m, dm, dphi, d2phi)
            for a in range(nd):
                table[a, q, 0] = dphi[0, a]
                table[a, q, 1] = dphi[1, a]
                if nphi[e] == 6:
                    for j in range(2):
                        for k in range(2):
                            table[a, q, 2 + 2 * j + k] = d2phi[j, k, a]
    return Phi


@numba.njit(cache=True)
def _table(Phi, phi_off, e, nd, n):
    """Polygon e's basis derivative table as (nd, n_q nphi)."""
    return Phi[phi_off[e]:phi_off[e + 1]].reshape(nd, n)


@numba.njit(cache=True, fastmath=CONTRACT)
def _gradients(ue, table):
    """∇u and ∇∇u at all points of a polygon: ``grad[i, k] = Σ_a u_ai Φ[a, k]``, (2, n_q nphi)."""
    nd, n = table.shape
    grad = np.zeros((2, n))
    for a in range(nd):
        u0, u1 = ue[a, 0], ue[a, 1]
        for k in range(n):
            grad[0, k] += u0 * table[a, k]
            grad[1, k] += u1 * table[a, k]
    return grad


@numba.njit(cache=True)
def _set_deformation(grad, q, nphi, c, F_at, G_at):
    """Write F = I + ∇u and G_ijk = ∂F_ij/∂X_k (row-major) of point q into the constants; return J.

    G is left alone when ``nphi`` is 2 (energy without gradient).
    """
    for i in range(2):
        for al in range(nphi):
            s = grad[i, q * nphi + al]
            if al < 2:
                c[F_at + 2 * i + al] = s + (1.0 if i == al else 0.0)
            else:
                c[G_at + 4 * i + al - 2] = s
    return c[F_at] * c[F_at + 3] - c[F_at + 1] * c[F_at + 2]


@numba.njit(cache=True, fastmath=CONTRACT)
def _dot_rows(X, a, Y, b):
    """Σ_k X[a, k] Y[b, k]."""
    s = 0.0
    for k in range(X.shape[1]):
        s += X[a, k] * Y[b, k]
    return s


@numba.njit(cache=True, fastmath=CONTRACT)
def residual_loop(kernel, c, F_at, G_at, P_at, T_at, uses_gradient, polygons, tables, u, R, stats):
    """Add the residual (Eq. 52) of ``polygons`` to ``R`` and accumulate diagnostics.

    Parameters
    ----------
    kernel
        Compiled pointwise residual kernel returning [Ψ, P(4), T(8)] (or [Ψ, P]).
    c : (n_constants,)
        Constants of the kernel (parameters already packed; F, G written here).
    polygons : (n,) int64
        Local polygon indices of one material region.
    tables : PolygonTables
        Their DOFs, basis derivative tables (nphi = 6 if ``uses_gradient`` else 2 for these
        polygons) and quadrature weights.
    u, R : (n_local_nodes, 2)
        Local (owned + ghost) nodal displacements and residual.
    stats : (3,)
        In/out: [energy Σ w Ψ, min J, local polygon index of min J].
    """
    dof_off, dofs, phi_off, Phi, q_off, w_q = tables
    out = np.zeros(13)
    scratch = kernel_scratch()
    nphi = 6 if uses_gradient else 2
    for e in polygons:
        d0 = dof_off[e]
        nd = dof_off[e + 1] - d0
        nq = q_off[e + 1] - q_off[e]
        table = _table(Phi, phi_off, e, nd, nq * nphi)
        grad = _gradients(_gather(u, dofs, d0, nd), table)
        S = np.empty((2, nq * nphi))        # w [P_ij, T_ijk] per point, in the rows of Φ
        for q in range(nq):
            J = _set_deformation(grad, q, nphi, c, F_at, G_at)
            if not (J > stats[1]):
                stats[1] = J
                stats[2] = e
            out[:] = 0.0
            call_kernel(kernel, out, c, scratch)
            w = w_q[q_off[e] + q]
            stats[0] += w * out[0]
            for i in range(2):
                for al in range(nphi):
                    S[i, q * nphi + al] = w * (out[P_at + 2 * i + al] if al < 2 else out[T_at + 4 * i + al - 2])
        # R_ai += Σ_q w (P_ij ∂_jφ_a + T_ijk ∂_k∂_jφ_a)
        for a in range(nd):
            R[dofs[d0 + a], 0] += _dot_rows(table, a, S, 0)
            R[dofs[d0 + a], 1] += _dot_rows(table, a, S, 1)


@numba.njit(cache=True)
def _tangent_blocks(out, D_at, A_at, B_at, uses_gradient, w, q, CC):
    """w C_im (module docstring) of point q from the tangent kernel output.

    ``CC[p, q]`` (nphi, nphi) for the component pairs p = 0, 1, 2 ↔ (i, m) = (0, 0), (0, 1), (1, 1).
    """
    for p, (i, mm) in enumerate(((0, 0), (0, 1), (1, 1))):
        for j in range(2):
            for n in range(2):
                CC[p, q, j, n] = w * out[D_at + 8 * i + 4 * j + 2 * mm + n]
        if uses_gradient:
            for j in range(2):
                for k in range(2):
                    for n in range(2):
                        CC[p, q, 2 + 2 * j + k, n] = w * out[A_at + 16 * i + 8 * j + 4 * k + 2 * mm + n]
                        CC[p, q, n, 2 + 2 * j + k] = w * out[A_at + 16 * mm + 8 * j + 4 * k + 2 * i + n]
                        for r in range(2):
                            CC[p, q, 2 + 2 * j + k, 2 + 2 * n + r] = \
                                w * out[B_at + 32 * i + 16 * j + 8 * k + 4 * mm + 2 * n + r]


@numba.njit(cache=True, fastmath=CONTRACT)
def _apply_C(CC, p, table, W, nphi):
    """W[b, (q, α)] = Σ_β CC[p, q, α, β] Φ[b, (q, β)] for all nodes b and points q.

    ``nphi`` must be a literal (2 or 6): one compiled, fully unrolled version each.
    """
    numba.literally(nphi)
    nd = table.shape[0]
    for q in range(CC.shape[1]):
        k0 = q * nphi
        for b in range(nd):
            for al in range(nphi):
                s = 0.0
                for be in range(nphi):
                    s += CC[p, q, al, be] * table[b, k0 + be]
                W[b, k0 + al] = s


@numba.njit(cache=True, fastmath=CONTRACT)
def tangent_loop(kernel, c, F_at, G_at, D_at, A_at, B_at, uses_gradient, polygons, tables, u, values, coo_off,
                 accumulate):
    """Write (``accumulate`` False) or add (True) the tangent (Eq. 56) of ``polygons`` into the
    COO value array.

    The element matrix of local polygon e is stored row-major, node-major, at
    ``values[coo_off[e]:coo_off[e] + (2 nd)²]``. Per component pair (i, m) and with
    W_b = Σ_q w_q C_im(x_q) Φ_b(x_q), K[(a, i), (b, m)] = Σ_(q, α) Φ[a, (q, α)] W[b, (q, α)]:
    one dot product over all points per entry. K is a Hessian: the pair (1, 0) and the
    entries b < a of the pairs (0, 0) and (1, 1) are mirrored, not integrated. ``tables``
    (:class:`PolygonTables`) and ``u`` as in :func:`residual_loop`.
    """
    dof_off, dofs, phi_off, Phi, q_off, w_q = tables
    out = np.zeros(112)
    scratch = kernel_scratch()
    nphi = 6 if uses_gradient else 2
    for e in polygons:
        d0 = dof_off[e]
        nd = dof_off[e + 1] - d0
        nq = q_off[e + 1] - q_off[e]
        table = _table(Phi, phi_off, e, nd, nq * nphi)
        grad = _gradients(_gather(u, dofs, d0, nd), table)
        CC = np.empty((3, nq, nphi, nphi))
        for q in range(nq):
            _set_deformation(grad, q, nphi, c, F_at, G_at)
            out[:] = 0.0
            call_kernel(kernel, out, c, scratch)
            _tangent_blocks(out, D_at, A_at, B_at, uses_gradient, w_q[q_off[e] + q], q, CC)
        block = values[coo_off[e]:coo_off[e] + 4 * nd * nd].reshape(nd, 2, nd, 2)
        W = np.empty((nd, nq * nphi))
        for p, (i, mm) in enumerate(((0, 0), (0, 1), (1, 1))):
            if nphi == 6:                   # literal sizes: unrolled C Φ products
                _apply_C(CC, p, table, W, 6)
            else:
                _apply_C(CC, p, table, W, 2)
            for a in range(nd):
                for b in range(a if i == mm else 0, nd):
                    K = _dot_rows(table, a, W, b)
                    if not accumulate:
                        block[a, i, b, mm] = K
                        block[b, mm, a, i] = K
                    elif a == b and i == mm:
                        block[a, i, a, i] += K
                    else:
                        block[a, i, b, mm] += K
                        block[b, mm, a, i] += K


@numba.njit(cache=True)
def coo_pattern(dof_off, dofs, global_node, coo_off, bs=2):
    """Global row/column indices of the dense node-major element blocks, in element order
    (``bs`` components per node: unknown ``bs * global node + i``)."""
    n = coo_off[-1]
    rows = np.empty(n, dtype=np.int32)
    cols = np.empty(n, dtype=np.int32)
    for e in range(dof_off.size - 1):
        d0, d1 = dof_off[e], dof_off[e + 1]
        nd = d1 - d0
        pos = coo_off[e]
        for a in range(nd):
            for i in range(bs):
                r = bs * global_node[dofs[d0 + a]] + i
                for b in range(nd):
                    for mm in range(bs):
                        rows[pos] = r
                        cols[pos] = bs * global_node[dofs[d0 + b]] + mm
                        pos += 1
    return rows, cols


@numba.njit(cache=True)
def projected_fields(polygons, dof_off, dofs, l, xE, hE, pim_off, Pi_m, pin_off, Pi_nabla, q_off, x_q, u,
                     u_q, grad_q):
    """Π^∇_2 u (Eq. 36) and Π⁰_l ∇u (Eq. 43) at the quadrature points of ``polygons``.

    Parameters
    ----------
    u : (n_local_nodes, 2)
        Nodal DOF values.
    u_q : (n_q, 2), grad_q : (n_q, 2, 2)
        Output at the points ``x_q[q_off[e]:q_off[e + 1]]`` of every polygon e;
        ``grad_q[q, i, j] = ∂u_i/∂X_j``.
    """
    m, dm = _monomial_scratch(l)
    for e in polygons:
        d0, d1 = dof_off[e], dof_off[e + 1]
        nd = d1 - d0
        ue = _gather(u, dofs, d0, nd)
        Pi = _polygon_block(Pi_m, pim_off, e, l[e], nd)
        Pn = Pi_nabla[pin_off[e]:pin_off[e + 1]].reshape(6, nd)
        dphi = np.empty((2, nd))
        d2phi = np.empty((2, 2, nd))
        for q in range(q_off[e], q_off[e + 1]):
            _projected_derivatives(x_q[q], xE[e], hE[e], l[e], Pi, m, dm, dphi, d2phi)
            evaluate_monomials(x_q[q], xE[e], hE[e], 2, m, dm[0], dm[1])
            for i in range(2):
                s = 0.0
                for a in range(nd):
                    phi = 0.0
                    for b in range(6):
                        phi += m[b] * Pn[b, a]
                    s += phi * ue[a, i]
                u_q[q, i] = s
                for j in range(2):
                    g = 0.0
                    for a in range(nd):
                        g += dphi[j, a] * ue[a, i]
                    grad_q[q, i, j] = g


@numba.njit(cache=True)
def load_loop(polygons, dof_off, dofs, xE, hE, pin_off, Pi_nabla, q_off, x_q, w_q, f_q, F):
    """Add the load vector ∫_E f · Π^∇_2 v dΩ (body force of Eq. 1) of ``polygons`` to F.

    ``f_q`` (n_q, 2) is the body force at the quadrature points; F (n_local_nodes, 2).
    """
    m = np.empty(6)
    dmx = np.empty(6)
    dmy = np.empty(6)
    for e in polygons:
        d0, d1 = dof_off[e], dof_off[e + 1]
        nd = d1 - d0
        Pn = Pi_nabla[pin_off[e]:pin_off[e + 1]].reshape(6, nd)
        for q in range(q_off[e], q_off[e + 1]):
            evaluate_monomials(x_q[q], xE[e], hE[e], 2, m, dmx, dmy)
            for a in range(nd):
                phi = 0.0
                for b in range(6):
                    phi += m[b] * Pn[b, a]
                F[dofs[d0 + a], 0] += w_q[q] * f_q[q, 0] * phi
                F[dofs[d0 + a], 1] += w_q[q] * f_q[q, 1] * phi


@numba.njit(cache=True)
def first_piola_at(kernel, c, F_at, G_at, P_at, uses_gradient, polygon, x, dof_off, dofs, l, xE, hE, pim_off, Pi_m,
                   u, F, P):
    """First Piola stress P = ∂Ψ/∂F (Eq. 30) at the points ``x`` (n, 2) of the local polygons
    ``polygon`` (n,), with F = I + Π⁰_l∇u and G its derivative there (Eqs. 43, 45), into P (n, 2, 2)
    and F (n, 2, 2).

    ``kernel`` is the residual kernel of the polygons' energy (output [Ψ, P(4), T(8)] or [Ψ, P]),
    ``c`` its constants with the parameters packed."""
    out = np.zeros(13)
    scratch = kernel_scratch()
    m, dm = _monomial_scratch(l)
    for n in range(x.shape[0]):
        e = polygon[n]
        d0 = dof_off[e]
        nd = dof_off[e + 1] - d0
        ue = _gather(u, dofs, d0, nd)
        dphi = np.empty((2, nd))
        d2phi = np.empty((2, 2, nd))
        _projected_derivatives(x[n], xE[e], hE[e], l[e], _polygon_block(Pi_m, pim_off, e, l[e], nd), m, dm,
                               dphi, d2phi)
        for i in range(2):
            for j in range(2):
                s = 0.0
                for a in range(nd):
                    s += ue[a, i] * dphi[j, a]
                c[F_at + 2 * i + j] = s + (1.0 if i == j else 0.0)
                if uses_gradient:
                    for k in range(2):
                        g = 0.0
                        for a in range(nd):
                            g += ue[a, i] * d2phi[j, k, a]
                        c[G_at + 4 * i + 2 * j + k] = g
        out[:] = 0.0
        call_kernel(kernel, out, c, scratch)
        for i in range(2):
            for j in range(2):
                P[n, i, j] = out[P_at + 2 * i + j]
                F[n, i, j] = c[F_at + 2 * i + j]
