"""Geometry of one polygon given as a closed vertex loop ``xy`` of shape (N, 2).

Edge i runs from vertex i to vertex i + 1 (mod N). Every routine that decides
"touching", "on", "inside" or "degenerate" takes an absolute length tolerance
``tol``: two geometric objects closer than ``tol`` touch, a triangle whose
smallest height is at most ``tol`` is degenerate. :class:`~dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh`
passes ``RTOL`` times the diagonal of the mesh's bounding box; the Python
wrappers here default to ``RTOL`` times the polygon's diameter.

Everything that runs per polygon or per edge is ``numba.njit`` so that the mesh
module can call it from its compiled loops.
"""
from __future__ import annotations

import numba
import numpy as np
import numpy.typing as npt

#: Relative tolerance: multiplied by a length scale (mesh bounding-box diagonal or
#: polygon diameter) it gives the absolute distance below which points coincide.
RTOL = 1e-10

#: ``sub_triangulation`` status values
FAN, EARS, FAILED = 0, 1, -1


# --------------------------------------------------------------------------- primitives
@numba.njit(cache=True)
def _cross(ax: float, ay: float, bx: float, by: float) -> float:
    return ax * by - ay * bx


@numba.njit(cache=True)
def point_segment_distance(p: npt.NDArray, a: npt.NDArray, b: npt.NDArray) -> float:
    """Euclidean distance from point ``p`` (2,) to the closed segment [a, b]."""
    dx = b[0] - a[0]
    dy = b[1] - a[1]
    length2 = dx * dx + dy * dy
    t = 0.0
    if length2 > 0.0:
        t = min(1.0, max(0.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / length2))
    return np.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


@numba.njit(cache=True)
def segment_distance(a: npt.NDArray, b: npt.NDArray, c: npt.NDArray, d: npt.NDArray) -> float:
    """Distance between the closed segments [a, b] and [c, d]: 0 if they cross."""
    o1 = _cross(b[0] - a[0], b[1] - a[1], c[0] - a[0], c[1] - a[1])
    o2 = _cross(b[0] - a[0], b[1] - a[1], d[0] - a[0], d[1] - a[1])
    o3 = _cross(d[0] - c[0], d[1] - c[1], a[0] - c[0], a[1] - c[1])
    o4 = _cross(d[0] - c[0], d[1] - c[1], b[0] - c[0], b[1] - c[1])
    if o1 * o2 < 0.0 and o3 * o4 < 0.0:
        return 0.0
    return min(min(point_segment_distance(a, c, d), point_segment_distance(b, c, d)),
               min(point_segment_distance(c, a, b), point_segment_distance(d, a, b)))


@numba.njit(cache=True)
def _line_distance(p: npt.NDArray, a: npt.NDArray, b: npt.NDArray) -> float:
    """Signed distance of ``p`` from the line a -> b, positive on the left."""
    return _cross(b[0] - a[0], b[1] - a[1], p[0] - a[0], p[1] - a[1]) / np.hypot(b[0] - a[0], b[1] - a[1])


# --------------------------------------------------------------------------- measures
@numba.njit(cache=True)
def signed_area(xy: npt.NDArray[np.float64]) -> float:
    """Signed area of the loop ``xy`` (N, 2): positive when counter-clockwise."""
    n = xy.shape[0]
    s = 0.0
    for i in range(1, n - 1):  # relative to vertex 0 against cancellation far from the origin
        s += _cross(xy[i, 0] - xy[0, 0], xy[i, 1] - xy[0, 1], xy[i + 1, 0] - xy[0, 0], xy[i + 1, 1] - xy[0, 1])
    return 0.5 * s


@numba.njit(cache=True)
def centroid(xy: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Area centroid (2,) of the loop ``xy`` (N, 2); the vertex mean if the area is zero."""
    n = xy.shape[0]
    s = 0.0
    cx = 0.0
    cy = 0.0
    for i in range(1, n - 1):
        ax = xy[i, 0] - xy[0, 0]
        ay = xy[i, 1] - xy[0, 1]
        bx = xy[i + 1, 0] - xy[0, 0]
        by = xy[i + 1, 1] - xy[0, 1]
        w = _cross(ax, ay, bx, by)
        s += w
        cx += w * (ax + bx)
        cy += w * (ay + by)
    c = np.empty(2)
    if s == 0.0:
        c[0] = xy[:, 0].mean()
        c[1] = xy[:, 1].mean()
    else:
        c[0] = xy[0, 0] + cx / (3.0 * s)
        c[1] = xy[0, 1] + cy / (3.0 * s)
    return c


@numba.njit(cache=True)
def diameter(xy: npt.NDArray[np.float64]) -> float:
    """Largest distance between two vertices of ``xy`` (N, 2)."""
    n = xy.shape[0]
    h = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            h = max(h, np.hypot(xy[i, 0] - xy[j, 0], xy[i, 1] - xy[j, 1]))
    return h


@numba.njit(cache=True)
def boundary_distance(p: npt.NDArray, xy: npt.NDArray[np.float64]) -> float:
    """Distance from point ``p`` (2,) to the boundary of the loop ``xy`` (N, 2)."""
    n = xy.shape[0]
    d = np.inf
    for i in range(n):
        d = min(d, point_segment_distance(p, xy[i], xy[(i + 1) % n]))
    return d


@numba.njit(cache=True)
def point_location(p: npt.NDArray, xy: npt.NDArray[np.float64], tol: float) -> int:
    """1 if ``p`` (2,) is inside the simple polygon ``xy`` farther than ``tol`` from its
    boundary, 0 if within ``tol`` of the boundary, -1 outside."""
    if boundary_distance(p, xy) <= tol:
        return 0
    n = xy.shape[0]
    inside = False
    for i in range(n):
        a = xy[i]
        b = xy[(i + 1) % n]
        if (a[1] > p[1]) != (b[1] > p[1]):
            x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
            if x > p[0]:
                inside = not inside
    return 1 if inside else -1


# --------------------------------------------------------------------------- simplicity
@numba.njit(cache=True)
def self_intersection(xy: npt.NDArray[np.float64], tol: float) -> tuple[int, int]:
    """First pair of edges (i, j), i <= j, that touch; (-1, -1) if the loop is simple.

    Non-adjacent edges touch when their distance is at most ``tol`` (crossing,
    touching, a vertex on an edge). Adjacent edges touch when they fold back onto
    each other (a spike). An edge shorter than ``tol`` is reported as (i, i).
    """
    n = xy.shape[0]
    for i in range(n):
        if np.hypot(xy[(i + 1) % n, 0] - xy[i, 0], xy[(i + 1) % n, 1] - xy[i, 1]) <= tol:
            return i, i
    for i in range(n):
        a = xy[i]
        b = xy[(i + 1) % n]
        for j in range(i + 1, n):
            c = xy[j]
            d = xy[(j + 1) % n]
            if j == i + 1:  # shared vertex b == c
                touch = point_segment_distance(d, a, b) <= tol or point_segment_distance(a, c, d) <= tol
            elif i == 0 and j == n - 1:  # shared vertex a == d
                touch = point_segment_distance(c, a, b) <= tol or point_segment_distance(b, c, d) <= tol
            else:
                touch = segment_distance(a, b, c, d) <= tol
            if touch:
                return i, j
    return -1, -1


def _default_tol(xy: npt.NDArray[np.float64], tol: float | None) -> float:
    return RTOL * diameter(xy) if tol is None else float(tol)


# --------------------------------------------------------------------------- triangulation
@numba.njit(cache=True)
def _sees_all_edges(xy: npt.NDArray[np.float64], c: npt.NDArray, tol: float) -> bool:
    """Whether ``c`` lies farther than ``tol`` to the left of every edge line, i.e.
    strictly inside the visibility region, so that the fan from ``c`` is a valid triangulation."""
    n = xy.shape[0]
    for i in range(n):
        if not _line_distance(c, xy[i], xy[(i + 1) % n]) > tol:  # also rejects NaN (zero-length edge)
            return False
    return True


@numba.njit(cache=True)
def visibility_region(xy: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The visibility region (set of points seeing the whole polygon) of the CCW loop ``xy`` (N, 2).

    Intersection of the left half-planes of all edges, by clipping the bounding
    box (Sutherland-Hodgman). Returns a convex CCW loop (K, 2), K = 0 if empty.
    """
    n = xy.shape[0]
    cur = np.empty((n + 4, 2))
    nxt = np.empty((n + 4, 2))
    lo0, hi0 = xy[:, 0].min(), xy[:, 0].max()
    lo1, hi1 = xy[:, 1].min(), xy[:, 1].max()
    cur[0, 0], cur[0, 1] = lo0, lo1
    cur[1, 0], cur[1, 1] = hi0, lo1
    cur[2, 0], cur[2, 1] = hi0, hi1
    cur[3, 0], cur[3, 1] = lo0, hi1
    m = 4
    for e in range(n):
        a = xy[e]
        b = xy[(e + 1) % n]
        k = 0
        for i in range(m):
            p = cur[i]
            q = cur[(i + 1) % m]
            dp = _cross(b[0] - a[0], b[1] - a[1], p[0] - a[0], p[1] - a[1])
            dq = _cross(b[0] - a[0], b[1] - a[1], q[0] - a[0], q[1] - a[1])
            if dp >= 0.0:
                nxt[k] = p
                k += 1
            if (dp > 0.0 and dq < 0.0) or (dp < 0.0 and dq > 0.0):
                s = dp / (dp - dq)
                nxt[k, 0] = p[0] + s * (q[0] - p[0])
                nxt[k, 1] = p[1] + s * (q[1] - p[1])
                k += 1
        cur, nxt = nxt, cur
        m = k
        if m == 0:
            break
    return cur[:m].copy()


@numba.njit(cache=True)
def _ear_quality(xy: npt.NDArray[np.float64], p: int, v: int, q: int, nxt: npt.NDArray[np.int64],
                 tol: float) -> float:
    """Shape quality 2|T| / sum(edge^2) of the ear (p, v, q), or -1 if it is not a valid ear
    (reflex or degenerate at ``v``, or another remaining vertex within ``tol`` of it)."""
    ux, uy = xy[v, 0] - xy[p, 0], xy[v, 1] - xy[p, 1]
    wx, wy = xy[q, 0] - xy[p, 0], xy[q, 1] - xy[p, 1]
    l1 = ux * ux + uy * uy
    l2 = (xy[q, 0] - xy[v, 0]) ** 2 + (xy[q, 1] - xy[v, 1]) ** 2
    l3 = wx * wx + wy * wy
    area2 = _cross(ux, uy, wx, wy)
    if area2 <= tol * np.sqrt(max(l1, max(l2, l3))):  # smallest height <= tol
        return -1.0
    j = nxt[q]
    while j != p:
        x = xy[j]
        if (_line_distance(x, xy[p], xy[v]) >= -tol and _line_distance(x, xy[v], xy[q]) >= -tol
                and _line_distance(x, xy[q], xy[p]) >= -tol):
            return -1.0
        j = nxt[j]
    return area2 / (l1 + l2 + l3)


@numba.njit(cache=True)
def ear_clipping(xy: npt.NDArray[np.float64], tol: float):
    """Ear clipping, best-shaped ear first. Returns (ok, triangles (N-2, 3), diagonals (N-3, 2))."""
    n = xy.shape[0]
    tri = np.empty((n - 2, 3), dtype=np.int64)
    diag = np.empty((max(n - 3, 0), 2), dtype=np.int64)
    nxt = np.empty(n, dtype=np.int64)
    prv = np.empty(n, dtype=np.int64)
    for i in range(n):
        nxt[i] = (i + 1) % n
        prv[i] = (i - 1) % n
    start = 0
    for k in range(n - 2):
        best = -1
        best_q = -1.0
        v = start
        for _ in range(n - k):
            qv = _ear_quality(xy, prv[v], v, nxt[v], nxt, tol)
            if qv > best_q:
                best, best_q = v, qv
            v = nxt[v]
        if best < 0:
            return False, tri, diag
        p, q = prv[best], nxt[best]
        tri[k, 0], tri[k, 1], tri[k, 2] = p, best, q
        if k < n - 3:
            diag[k, 0], diag[k, 1] = p, q
        nxt[p] = q
        prv[q] = p
        start = q
    return True, tri, diag


@numba.njit(cache=True)
def sub_triangulation(xy: npt.NDArray[np.float64], tol: float):
    """Sub-triangulation of the simple CCW polygon ``xy`` (N, 2) (compiled core of :func:`sub_triangulate`).

    Returns
    -------
    status : int
        ``FAN``, ``EARS`` or ``FAILED``.
    centre : (2,) float64
        Fan centre (meaningful for ``FAN`` only).
    triangles : (n_t, 3) int64
        CCW triangles; index N is the fan centre.
    a, b : int
        End points of the segment whose midpoint hosts the interior DOF.
    """
    n = xy.shape[0]
    c = centroid(xy)
    fan = _sees_all_edges(xy, c, tol)
    if not fan:
        region = visibility_region(xy)
        if region.shape[0] >= 3:
            c = centroid(region)
            fan = _sees_all_edges(xy, c, tol)
    if fan:
        tri = np.empty((n, 3), dtype=np.int64)
        for i in range(n):
            tri[i, 0], tri[i, 1], tri[i, 2] = n, i, (i + 1) % n
        return FAN, c, tri, n, n
    ok, tri, diag = ear_clipping(xy, tol)
    if not ok or diag.shape[0] == 0:
        return FAILED, c, tri, -1, -1
    best, depth = 0, -1.0
    mid = np.empty(2)
    for k in range(diag.shape[0]):
        mid[:] = 0.5 * (xy[diag[k, 0]] + xy[diag[k, 1]])
        d = boundary_distance(mid, xy)
        if d > depth:
            best, depth = k, d
    return EARS, c, tri, diag[best, 0], diag[best, 1]


def sub_triangulate(xy: npt.ArrayLike, tol: float | None = None
                    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Sub-triangulate a simple counter-clockwise polygon.

    A fan from the centroid if it lies strictly inside the visibility region (farther than
    ``tol`` from every edge line), else a fan from the visibility region's centroid if that
    does, else ear clipping (best-shaped ear first). Every polygon edge (i, i+1)
    is an edge of exactly one sub-triangle; all sub-triangles are CCW with smallest
    height > ``tol``.

    Parameters
    ----------
    xy : (N, 2)
        Vertices, counter-clockwise.
    tol
        Length tolerance; default ``RTOL`` times the diameter.

    Returns
    -------
    extra : (m, 2) float64, m in {0, 1}
        The fan centre, if any.
    triangles : (n_t, 3) int64
        Indices into ``vstack(xy, extra)``; n_t = N for a fan, N - 2 for ear clipping.
    interior : (2,) int64
        (a, b) whose midpoint hosts the interior DOF: (N, N) for a fan, the end points of
        the interior diagonal deepest inside the polygon for ear clipping.

    Raises
    ------
    ValueError
        If no such triangulation is found (degenerate, clockwise or non-simple input).
    """
    xy = np.ascontiguousarray(xy, dtype=np.float64)
    if xy.ndim != 2 or xy.shape[0] < 3 or xy.shape[1] != 2:
        raise ValueError(f"polygon vertices must have shape (N >= 3, 2), got {xy.shape}")
    status, centre, tri, a, b = sub_triangulation(xy, _default_tol(xy, tol))
    if status == FAILED:
        raise ValueError("polygon cannot be sub-triangulated (degenerate, clockwise or self-intersecting)")
    extra = centre.reshape(1, 2) if status == FAN else np.empty((0, 2))
    return extra, tri, np.array([a, b], dtype=np.int64)
