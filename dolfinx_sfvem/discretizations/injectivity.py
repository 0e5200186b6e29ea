"""Injectivity guard: is the deformed map of every element one-to-one, judged from its nodes?

J = det F at the quadrature points does not see every fold: a vertex pushed across the
opposite side of its element can leave J > 0 at all of them. The guard therefore looks at
the deformed boundary of each element (polygon or FEM cell), the closed polyline through
its vertices and edge midpoints ``y = X + u``,

    v_0, m_0, v_1, m_1, ..., v_{N-1}, m_{N-1}     (2N points, the degree-2 edge traces),

and calls a solid element *folded* when that polyline has lost the orientation of the reference
boundary (signed area of the deformed polyline times that of the reference one <= 0): a folded
element makes the state inadmissible, like J <= 0. A solid element whose polyline crosses itself
(two non-adjacent segments intersect) while keeping its orientation is *kinked*: counted and
reported, not rejected, because a point load crushes the solid elements around its node that way
(the paper's box, docs/contact.md). Third-medium elements are not checked: squeezed to J ~ 1e-3
between solids in contact, their strongly curved edges make the straight polyline a poor
picture of them (its area turns negative with J > 0 at every quadrature point, measured on the
FEM box), and what matters there, the solids' overlap, is :mod:`dolfinx_sfvem.physics.contact`'s job.
Both discretizations call :func:`folded_elements` on every trial state (the line search and the
cut-back treat a fold like J <= 0) and on every converged state.
"""
from __future__ import annotations

import numba
import numpy as np
from mpi4py import MPI


@numba.njit(cache=True)
def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


@numba.njit(cache=True)
def _orientation(px, py, qx, qy, rx, ry):
    """Sign of the turn p -> q -> r: +1 left, -1 right, 0 collinear (exact zero only)."""
    d = _cross(qx - px, qy - py, rx - px, ry - py)
    return 1 if d > 0.0 else (-1 if d < 0.0 else 0)


@numba.njit(cache=True)
def _on_segment(ax, ay, bx, by, cx, cy):
    """Whether c, collinear with a and b, lies in the bounding box of [a, b]."""
    return min(ax, bx) <= cx <= max(ax, bx) and min(ay, by) <= cy <= max(ay, by)


@numba.njit(cache=True)
def segments_cross(px, py, qx, qy, rx, ry, sx, sy) -> bool:
    """Whether the closed segments [p, q] and [r, s] have a point in common (coordinates as
    scalars: the guard's inner loop makes no array views)."""
    if max(px, qx) < min(rx, sx) or max(rx, sx) < min(px, qx) or \
            max(py, qy) < min(ry, sy) or max(ry, sy) < min(py, qy):
        return False                        # disjoint bounding boxes: no common point (the common case)
    o1, o2 = _orientation(px, py, qx, qy, rx, ry), _orientation(px, py, qx, qy, sx, sy)
    o3, o4 = _orientation(rx, ry, sx, sy, px, py), _orientation(rx, ry, sx, sy, qx, qy)
    if o1 != o2 and o3 != o4:
        return True
    return ((o1 == 0 and _on_segment(px, py, qx, qy, rx, ry)) or (o2 == 0 and _on_segment(px, py, qx, qy, sx, sy))
            or (o3 == 0 and _on_segment(rx, ry, sx, sy, px, py)) or (o4 == 0 and _on_segment(rx, ry, sx, sy, qx, qy)))


@numba.njit(cache=True)
def _signed_area(y, loop, k0, n):
    """Twice the signed area of the closed polyline y[loop[k0:k0 + n]]."""
    a = 0.0
    for k in range(n):
        i, j = loop[k0 + k], loop[k0 + (k + 1) % n]
        a += _cross(y[i, 0], y[i, 1], y[j, 0], y[j, 1])
    return a


@numba.njit(cache=True)
def _self_crossing(y, loop, k0, n):
    """Whether two non-adjacent segments of the closed polyline y[loop[k0:k0 + n]] meet."""
    for a in range(n):
        i, j = loop[k0 + a], loop[k0 + (a + 1) % n]
        px, py, qx, qy = y[i, 0], y[i, 1], y[j, 0], y[j, 1]
        for b in range(a + 2, n - 1 if a == 0 else n):      # a = 0, b = n - 1: adjacent through the closing segment
            r, s = loop[k0 + b], loop[k0 + (b + 1) % n]
            if segments_cross(px, py, qx, qy, y[r, 0], y[r, 1], y[s, 0], y[s, 1]):
                return True
    return False


@numba.njit(cache=True)
def folded_elements(loop_offsets, loop, X, u, elements, solid):
    """Folded and kinked elements among ``elements`` (see the module docstring).

    Parameters
    ----------
    loop_offsets : (n_elements + 1,) int64
        Element e's boundary nodes are ``loop[loop_offsets[e]:loop_offsets[e + 1]]``.
    loop : (loop_offsets[-1],) int64
        Node indices, alternating vertex and edge midpoint, in the order of the boundary
        (either orientation; the reference orientation is what must be kept).
    X, u : (n_nodes, 2) float64
        Reference coordinates and displacements of the nodes.
    elements : (m,) int64
        The elements to check.
    solid : (n_elements,) bool
        Whether element e belongs to a solid (checked) or to the third medium (not checked).

    Returns
    -------
    folded, kinked : (m,) bool
        Whether each of ``elements`` (solid) has turned over, and whether it crosses itself.
    """
    y = X + u
    folded = np.zeros(elements.size, dtype=np.bool_)
    kinked = np.zeros(elements.size, dtype=np.bool_)
    for i, e in enumerate(elements):
        k0, n = loop_offsets[e], loop_offsets[e + 1] - loop_offsets[e]
        if solid[e]:
            folded[i] = _signed_area(y, loop, k0, n) * _signed_area(X, loop, k0, n) <= 0.0
            kinked[i] = not folded[i] and _self_crossing(y, loop, k0, n)
    return folded, kinked


def gather_count(comm: MPI.Comm, mask: np.ndarray, global_index: np.ndarray) -> tuple[int, int]:
    """Number of marked elements over all ranks and the largest global index among them (-1 if
    none), from each rank's ``mask`` (m,) over its elements with global indices ``global_index`` (m,)."""
    last = int(global_index[mask].max(initial=-1))
    return comm.allreduce(int(np.count_nonzero(mask)), op=MPI.SUM), comm.allreduce(last, op=MPI.MAX)
