"""Voronoi polyhedra clipped to a box (scipy.spatial.Voronoi, i.e. Qhull)."""
from __future__ import annotations

from collections.abc import Mapping

import numba
import numpy as np
import numpy.typing as npt
from scipy.spatial import Voronoi

from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh, plane_coordinates
from dolfinx_sfvem.meshing.short_edges import collapse_short_edges

#: default shortest edge kept, relative to the diameter of every cell holding it
MIN_EDGE = 1e-2


@numba.njit(cache=True)
def _counter_clockwise(points, offsets, vertices, normals):
    """Every convex face's vertices sorted by angle around their mean, counter-clockwise about its
    normal ``normals[f]`` (n_f, 3) (unit); returns the reordered vertex array."""
    out = vertices.copy()
    for f in range(offsets.size - 1):
        verts = vertices[offsets[f]:offsets[f + 1]]
        mean = np.zeros(3)
        for v in verts:
            mean += points[v] / verts.size
        xy = plane_coordinates(points, verts, mean, normals[f])
        out[offsets[f]:offsets[f + 1]] = verts[np.argsort(np.arctan2(xy[:, 1], xy[:, 0]))]
    return out


def _with_images(seeds: np.ndarray, lower: np.ndarray, upper: np.ndarray, reach: float) -> np.ndarray:
    """The seeds followed by the mirror images, across each face of the box, of the seeds closer
    than ``reach`` to it."""
    images = [seeds]
    for d in range(3):
        for plane in (lower[d], upper[d]):
            image = seeds[np.abs(seeds[:, d] - plane) < reach]
            image[:, d] = 2.0 * plane - image[:, d]
            images.append(image)
    return np.concatenate(images)


def _inside(diagram: Voronoi, n: int, lower: np.ndarray, upper: np.ndarray) -> bool:
    """The Voronoi regions of the first ``n`` generators are bounded and inside the box."""
    regions = [diagram.regions[r] for r in diagram.point_region[:n]]
    vertices = np.concatenate([np.asarray(r, dtype=np.int64) for r in regions])
    if np.any(vertices < 0):
        return False
    tol = 1e-12 * float(np.linalg.norm(upper - lower))
    x = diagram.vertices[vertices]
    return bool(np.all((x >= lower - tol) & (x <= upper + tol)))


def voronoi_box(seeds: npt.ArrayLike, lower: npt.ArrayLike, upper: npt.ArrayLike, tags: npt.ArrayLike | None = None,
                region_names: Mapping[str, int] | None = None, min_edge: float = MIN_EDGE) -> PolyhedronMesh:
    """The Voronoi cells of ``seeds`` clipped to the box [lower, upper], their short edges collapsed.

    The seeds near the six faces of the box are mirrored across them and the Voronoi diagram of the
    seeds and images computed (scipy.spatial.Voronoi). Inside the box a seed is nearer to every
    point than its mirror images, so the images cut nothing there, and the cell of a seed is
    exactly its clipped cell as soon as it lies inside the box (its own images bound it by the
    faces): seeds within three mean spacings of a face are mirrored first, twice as far while some
    cell reaches out of the box (all seeds at last, when every cell is the clipped one). Cell ``c``
    belongs to seed ``c``; a face between two seeds points out of the lower one's cell.
    Coordinates within 1e-12 of the box's planes (relative to its diagonal) are put on them.

    Random seeds give nearly cospherical ones, and Voronoi edges of 1e-5 of their cell's diameter
    (also where a Voronoi vertex lies near a box plane) on which the element fails or is
    ill-conditioned. Every edge shorter than ``min_edge`` times the diameter of a cell holding it
    is collapsed (:mod:`~dolfinx_sfvem.meshing.short_edges`): its ends merged into one of
    them (onto the box's planes where one of them is on one), faces left with fewer than 3
    vertices dropped, and the faces that the merge bends split into flat pieces (triangles at the
    moved vertex): a merged vertex cannot lie on all the planes of its faces, and the element needs
    flat faces. Each face is still stored once, shared by its two cells; the cells stay within
    about ``min_edge`` diameters of the Voronoi cells, slightly non-convex where a face was split.
    ``min_edge = 1e-2`` (the default) left no failing cell on 20 random sets of 216 and 512 seeds
    and the rate-study meshes; 1e-3 and 3e-3 leave cells with tiny triangular faces of sides
    3-4e-3 of their diameter on which the element fails. ``min_edge = 0`` gives the exact clipped
    Voronoi cells: convex polyhedra.

    Parameters
    ----------
    seeds : (n, 3) array_like of float
        Distinct points strictly inside the box (n >= 1).
    lower, upper : (3,) array_like of float
        Corners of the box (upper > lower).
    tags, region_names
        Region tag of every seed's cell (default 0) and names of tags.
    min_edge : float
        Shortest edge kept, relative to the diameter of every cell holding it (>= 0; 0: no
        collapse).

    Raises
    ------
    ValueError
        For seeds outside the box or on its boundary, repeated seeds, a bad box, a negative
        ``min_edge``, a collapse that pinches a face (``min_edge`` too large for the seeds), or
        (from the mesh's validation) degenerate cells of nearly coincident seeds.
    """
    seeds = np.asarray(seeds, dtype=np.float64)
    lower, upper = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    if lower.shape != (3,) or upper.shape != (3,) or np.any(upper <= lower):
        raise ValueError(f"voronoi_box: lower and upper must be 3 coordinates with upper > lower, got {lower}, {upper}")
    if seeds.ndim != 2 or seeds.shape[1] != 3 or seeds.shape[0] < 1:
        raise ValueError(f"voronoi_box: seeds must have shape (n, 3) with n >= 1, got {seeds.shape}")
    outside = np.flatnonzero(np.any((seeds <= lower) | (seeds >= upper) | ~np.isfinite(seeds), axis=1))
    if outside.size:
        raise ValueError(f"voronoi_box: seed {outside[0]} {seeds[outside[0]]} is not strictly inside the box")
    _, first, count = np.unique(seeds, axis=0, return_index=True, return_counts=True)
    if np.any(count > 1):
        raise ValueError(f"voronoi_box: seed {first[np.argmax(count > 1)]} is repeated")
    if not np.isfinite(min_edge) or min_edge < 0:
        raise ValueError(f"voronoi_box: min_edge must be a number >= 0, got {min_edge!r}")
    n = seeds.shape[0]
    reach = 3.0 * (np.prod(upper - lower) / n) ** (1 / 3)             # three mean seed spacings
    while True:
        generators = _with_images(seeds, lower, upper, reach)
        diagram = Voronoi(generators)
        if _inside(diagram, n, lower, upper) or reach > np.max(upper - lower):
            break
        reach *= 2.0
    ridges = np.flatnonzero(diagram.ridge_points.min(axis=1) < n)
    pair = np.sort(diagram.ridge_points[ridges], axis=1)                       # (k, 2): own seed first
    polygons = [diagram.ridge_vertices[r] for r in ridges]
    sizes = np.array([len(p) for p in polygons])
    vertices = np.concatenate(polygons).astype(np.int64)
    used, vertices = np.unique(vertices, return_inverse=True)
    points = diagram.vertices[used]
    tol = 1e-12 * float(np.linalg.norm(upper - lower))
    for bound in (lower, upper):
        near = np.abs(points - bound) <= tol
        points[near] = np.broadcast_to(bound, points.shape)[near]
    normals = generators[pair[:, 1]] - generators[pair[:, 0]]
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    vertices = _counter_clockwise(points, offsets, vertices.reshape(-1), normals)
    # the cells' faces: (own seed, +1) for every ridge and (other seed, -1) where it is a seed
    inner = pair[:, 1] < n
    face = np.concatenate([np.arange(pair.shape[0]), np.flatnonzero(inner)])
    cell = np.concatenate([pair[:, 0], pair[inner, 1]])
    sign = np.concatenate([np.ones(pair.shape[0], np.int64), -np.ones(inner.sum(), np.int64)])
    order = np.lexsort((face, cell))
    cell_offsets = np.concatenate([[0], np.cumsum(np.bincount(cell, minlength=n))]).astype(np.int64)
    mesh = (points, offsets.astype(np.int64), vertices, cell_offsets, face[order], sign[order])
    if min_edge > 0:
        levels = np.einsum("ij,ij->i", normals, 0.5 * (generators[pair[:, 0]] + generators[pair[:, 1]]))
        mesh = collapse_short_edges(*mesh[:3], normals, levels, *mesh[3:], lower, upper, float(min_edge))
    return PolyhedronMesh(*mesh, tags, region_names)
