"""Named boundaries of a mesh (the physical curves of a 2D gmsh model, the physical surfaces of a 3D
one) as markers of points, the form in which boundary conditions and face loads take them.

A mesh's ``boundary_names`` maps a name to its facets as vertex indices into the mesh's points:
segments (m, 2) in 2D, triangles (m, 3) or quadrilaterals (m, 4, cyclic order) in 3D.
:func:`facet_marker` turns them into a function of coordinates that is true on the facets: the
geometry, not the vertices, so that it selects every node a discretization puts there (edge
midpoints, face centres, the SFVEM's face centroids and the fan triangles of its faces, the
vertices a local refinement adds on a named curve) and works on any mesh of the same domain.

A quadrilateral is taken as the four triangles from the mean of its vertices to its sides (the
whole face when it is planar; on a non-planar one the nodes of the Q2 face: vertices, side
midpoints, centre), together with its two triangles along the diagonal through its vertex of
smallest index (how the SFVEM takes a non-planar face).
"""
from __future__ import annotations

import typing

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

#: distance within which a point lies on a facet, relative to the diameter of the named facets' box
RTOL = 1e-8


def facet_pieces(points: npt.NDArray[np.float64], facets: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
    """The segments (2D) or triangles (3D) that :func:`on_facets` tests.

    Parameters
    ----------
    points : (n, d) float
    facets : (m, 2 | 3 | 4) int
        Vertex indices: segments, triangles or quadrilaterals in cyclic order.

    Returns
    -------
    (p, 2 | 3, d) float64
        Corner coordinates of every piece (a quadrilateral gives 6, module docstring).
    """
    facets = np.asarray(facets, dtype=np.int64)
    x = np.asarray(points, dtype=np.float64)[facets]
    if facets.shape[1] in (2, 3):
        return x
    centre = np.repeat(x.mean(axis=1, keepdims=True), 4, axis=1)
    fan = np.stack([centre, x, np.roll(x, -1, axis=1)], axis=2).reshape(-1, 3, x.shape[2])
    first = np.argmin(facets, axis=1)
    turned = x[np.arange(len(x))[:, None], (first[:, None] + np.arange(4)) % 4]
    split = turned[:, [0, 1, 2, 0, 2, 3]].reshape(-1, 3, x.shape[2])
    return np.concatenate([fan, split])


def on_facets(x: npt.ArrayLike, pieces: npt.NDArray[np.float64], tol: float) -> npt.NDArray[np.bool_]:
    """Whether each point lies within ``tol`` of one of the ``pieces`` (:func:`facet_pieces`).

    Parameters
    ----------
    x : (d, n)
        Coordinates, one point per column (a marker's argument; extra rows beyond d are ignored).
    pieces : (p, 2 | 3, d)
        Segments or triangles.

    Returns
    -------
    (n,) bool
    """
    d = pieces.shape[2]
    x = np.asarray(x, dtype=np.float64)[:d].T
    selected = np.zeros(len(x), dtype=bool)
    if not len(x) or not len(pieces):
        return selected
    centre = pieces.mean(axis=1)
    radius = np.linalg.norm(pieces - centre[:, None], axis=2).max() + tol
    near = cKDTree(centre).query_ball_point(x, radius)
    point = np.repeat(np.arange(len(x)), [len(n) for n in near])
    piece = np.fromiter((k for n in near for k in n), dtype=np.int64, count=point.size)
    a, v = pieces[piece, 0], x[point] - pieces[piece, 0]
    if pieces.shape[1] == 2:
        e = pieces[piece, 1] - a
        t = np.clip(np.einsum("ij,ij->i", v, e) / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
        distance = np.linalg.norm(v - t[:, None] * e, axis=1)
    else:
        e1, e2 = pieces[piece, 1] - a, pieces[piece, 2] - a
        gram = np.stack([np.stack([np.einsum("ij,ij->i", e1, e1), np.einsum("ij,ij->i", e1, e2)], axis=1),
                         np.stack([np.einsum("ij,ij->i", e1, e2), np.einsum("ij,ij->i", e2, e2)], axis=1)], axis=1)
        rhs = np.stack([np.einsum("ij,ij->i", v, e1), np.einsum("ij,ij->i", v, e2)], axis=1)
        s, t = np.linalg.solve(gram, rhs[..., None])[..., 0].T if point.size else (np.zeros(0), np.zeros(0))
        # inside the triangle up to tol (barycentric coordinates scaled by the sides' lengths)
        slack = tol / np.sqrt(np.minimum(np.einsum("ij,ij->i", e1, e1), np.einsum("ij,ij->i", e2, e2)))
        inside = (s >= -slack) & (t >= -slack) & (s + t <= 1.0 + slack)
        distance = np.where(inside, np.linalg.norm(v - s[:, None] * e1 - t[:, None] * e2, axis=1), np.inf)
    selected[point[distance <= tol]] = True
    return selected


def facet_marker(points: npt.ArrayLike, facets: npt.ArrayLike, label: str, nodes: npt.ArrayLike | None = None
                 ) -> typing.Callable[[np.ndarray], np.ndarray]:
    """A marker ``f(x)`` ((d, n) -> (n,) bool) true on the ``facets`` (module docstring), named
    ``label`` (its ``__name__``, which summary.json records).

    Parameters
    ----------
    points : (n, d) float
    facets : (m, 2 | 3 | 4) int
        Vertex indices into ``points``.
    nodes : (k, d) float, optional
        Further points the marker takes as on the facets (within its tolerance): the nodes of
        curved facets off the flat ones through their vertices
        (:meth:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh.facet_nodes`).
    """
    pieces = facet_pieces(np.asarray(points, dtype=np.float64), np.asarray(facets, dtype=np.int64))
    corners = pieces.reshape(-1, pieces.shape[2])
    tol = RTOL * float(np.linalg.norm(np.ptp(corners, axis=0))) if len(corners) else 0.0
    tree = cKDTree(np.asarray(nodes, dtype=np.float64)) if nodes is not None and len(nodes) else None

    def marker(x: np.ndarray) -> np.ndarray:
        selected = on_facets(x, pieces, tol)
        if tree is not None:
            distance, _ = tree.query(np.asarray(x, dtype=np.float64)[:pieces.shape[2]].T)
            selected |= distance <= tol
        return selected
    marker.__name__ = label
    return marker


def boundary_names_check(names: typing.Mapping[str, npt.ArrayLike], n_points: int, sizes: tuple[int, ...]
                         ) -> dict[str, npt.NDArray[np.int64]]:
    """``boundary_names`` as name -> (m, k) int64 arrays; ValueError for a facet of another size than
    ``sizes`` or an index outside [0, n_points)."""
    out = {}
    for name, facets in names.items():
        facets = np.array(facets, dtype=np.int64, ndmin=2)
        if facets.shape[1] not in sizes or (facets.size and (facets.min() < 0 or facets.max() >= n_points)):
            raise ValueError(f"boundary {name!r}: facets must be an (m, {' or '.join(map(str, sizes))}) array of "
                             f"point indices in [0, {n_points}), got shape {facets.shape}")
        out[str(name)] = facets
    return out
