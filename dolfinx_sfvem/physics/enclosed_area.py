"""The area enclosed by a polygon's deformed boundary trace, with its gradient and Hessian.

J = det F is a null Lagrangian: ∫_E det F dX is the area of the deformed element,

    ∫_E J dX = |φ(E)| = (1/2) ∮_∂E x × dx,

a function of the boundary trace alone. An order-2 SFVEM displacement is quadratic on every
edge, so a deformed edge [a, m, b] (vertex, midpoint node, vertex; counter-clockwise) is the
curve x(t) = m + t (b − a)/2 + t² ((a + b)/2 − m), t ∈ [−1, 1], and x × x' is a cubic in t
(2-point Gauss is exact). Integrated in closed form, its part of the enclosed area is

    A_[a,m,b] = (2/3) m × (b − a) − (1/6) a × b        (a straight edge: (1/2) a × b, the shoelace),

with u × v = u_x v_y − u_y v_x. The area is a quadratic form of the nodal positions: its gradient
is linear in them and its Hessian constant. Summed over the polygons of a region, the edges
inside the region cancel (each is traversed once each way) and what remains is the area enclosed
by the region's deformed boundary, exact for any nodal displacement.

The SFVEM evaluates the cavity pressure's energy −p ∫ (J − 1) dΩ this way
(:class:`~dolfinx_sfvem.physics.energy.VolumeWork`, docs/guide/loads.md), where the projected gradient
Π⁰_l ∇u would make ∫ det F depend on the polygon's interior modes.

Node order of a polygon with N sides (``dofs[dof_off[e]:dof_off[e + 1]]``, 2N + 1 nodes): its
vertices v_0 ... v_{N−1}, its edge midpoints m_0 ... m_{N−1} (m_k between v_k and v_{k+1}), its
interior node (not part of the trace).
"""
from __future__ import annotations

import numba


@numba.njit(cache=True)
def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


@numba.njit(cache=True)
def edge_area(a, m, b):
    """A_[a,m,b] (module docstring) of the deformed edge with end points a, b and midpoint node m (2,)."""
    return (2.0 / 3.0) * _cross(m[0], m[1], b[0] - a[0], b[1] - a[1]) - (1.0 / 6.0) * _cross(a[0], a[1], b[0], b[1])


@numba.njit(cache=True)
def area_force_loop(polygons, dof_off, dofs, X, u, scale, R):
    """Add ``scale`` ∂A_e/∂x of ``polygons`` to ``R`` and return Σ_e A_e(X + u) − A_e(X).

    Parameters
    ----------
    polygons : (n,) int64
        Local polygon indices.
    dof_off, dofs : int64 arrays
        Nodes of every polygon (module docstring).
    X, u : (n_local_nodes, 2)
        Reference coordinates and displacements of the local nodes.
    scale : float
        Factor of the gradient (e.g. −p for the energy −p (A − A_0)).
    R : (n_local_nodes, 2)
        In/out: nodal forces.
    """
    change = 0.0
    for e in polygons:
        d0 = dof_off[e]
        N = (dof_off[e + 1] - d0 - 1) // 2
        for k in range(N):
            ia, im, ib = dofs[d0 + k], dofs[d0 + N + k], dofs[d0 + (k + 1) % N]
            a, m, b = X[ia] + u[ia], X[im] + u[im], X[ib] + u[ib]
            change += edge_area(a, m, b) - edge_area(X[ia], X[im], X[ib])
            # ∂(u × v)/∂u = (v_y, −v_x), ∂(u × v)/∂v = (−u_y, u_x)
            R[ia, 0] += scale * ((2.0 / 3.0) * m[1] - (1.0 / 6.0) * b[1])
            R[ia, 1] += scale * (-(2.0 / 3.0) * m[0] + (1.0 / 6.0) * b[0])
            R[ib, 0] += scale * (-(2.0 / 3.0) * m[1] + (1.0 / 6.0) * a[1])
            R[ib, 1] += scale * ((2.0 / 3.0) * m[0] - (1.0 / 6.0) * a[0])
            R[im, 0] += scale * (2.0 / 3.0) * (b[1] - a[1])
            R[im, 1] += scale * -(2.0 / 3.0) * (b[0] - a[0])
    return change


@numba.njit(cache=True)
def _add_cross_hessian(block, i, j, s):
    """block += s ∂²(x_i × x_j)/∂x_i∂x_j and its transpose (nodes i ≠ j of a node-major
    (nd, 2, nd, 2) block)."""
    block[i, 0, j, 1] += s
    block[i, 1, j, 0] -= s
    block[j, 1, i, 0] += s
    block[j, 0, i, 1] -= s


@numba.njit(cache=True)
def area_tangent_loop(polygons, dof_off, scale, values, coo_off):
    """Add ``scale`` ∂²A_e/∂x² (constant) of ``polygons`` to their node-major dense blocks of the
    COO value array, ``values[coo_off[e]:coo_off[e] + (2 nd)²]`` (the layout of
    :func:`~dolfinx_sfvem.discretizations.assemble.tangent_loop`)."""
    for e in polygons:
        nd = dof_off[e + 1] - dof_off[e]
        N = (nd - 1) // 2
        block = values[coo_off[e]:coo_off[e] + 4 * nd * nd].reshape(nd, 2, nd, 2)
        for k in range(N):
            a, m, b = k, N + k, (k + 1) % N
            # A = (2/3) (m × b − m × a) − (1/6) a × b
            _add_cross_hessian(block, m, b, scale * (2.0 / 3.0))
            _add_cross_hessian(block, m, a, -scale * (2.0 / 3.0))
            _add_cross_hessian(block, a, b, -scale * (1.0 / 6.0))

