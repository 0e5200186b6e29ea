"""Polygon sets: polygons not yet validated as a mesh, their CSR (offsets, flat indices) form, and
gluing of sets with coincident points merged."""
from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.csgraph
import scipy.spatial

from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh


#: relative tolerance (times the bounding-box size) of all geometric comparisons here
REL_TOL = 1e-9


class PolygonSet(NamedTuple):
    """Polygons not yet validated as a mesh.

    Attributes
    ----------
    points : (n, 2) float64
        Vertex coordinates.
    polygons : list of (N_i,) int64
        Vertex indices of each polygon (counter-clockwise when made here; PolygonMesh
        reorients clockwise ones).
    tags : (m,) int32
        Region tag of each polygon.
    """

    points: np.ndarray
    polygons: list[np.ndarray]
    tags: np.ndarray

    def to_mesh(self) -> PolygonMesh:
        """Validate into a :class:`PolygonMesh` (T-junctions repaired)."""
        return PolygonMesh(self.points, self.polygons, self.tags, insert_hanging_nodes=True)


def csr(polygons: Sequence[npt.ArrayLike]) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (m+1,) and flat vertex indices of a list of polygons."""
    sizes = np.fromiter((len(p) for p in polygons), dtype=np.int64, count=len(polygons))
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    flat = (np.concatenate([np.asarray(p, dtype=np.int64) for p in polygons]) if polygons
            else np.empty(0, dtype=np.int64))
    return offsets, flat


def split_csr(offsets: np.ndarray, flat: np.ndarray) -> list[np.ndarray]:
    """Inverse of :func:`csr`."""
    return np.split(flat, offsets[1:-1])


def compact_points(points: np.ndarray, flat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop points no polygon uses; returns the used points and the renumbered indices."""
    used, renumbered = np.unique(flat, return_inverse=True)
    return points[used], renumbered.astype(np.int64)


def length_tolerance(points: np.ndarray) -> float:
    """Absolute length tolerance: :data:`REL_TOL` times the bounding-box size."""
    extent = float(np.ptp(points, axis=0).max()) if points.size else 0.0
    return REL_TOL * (extent if extent > 0 else 1.0)


def as_polygon_set(part: PolygonSet | PolygonMesh | tuple) -> PolygonSet:
    """A PolygonSet from a PolygonMesh or a ``(points, polygons, tags)`` triple."""
    if isinstance(part, PolygonMesh):
        return PolygonSet(part.points, split_csr(part.offsets, part.vertices), part.tags)
    points, polygons, tags = part
    return PolygonSet(np.asarray(points, dtype=np.float64), list(polygons), np.asarray(tags))


def _merge_points(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge points closer than :func:`length_tolerance`; returns merged points and old -> new."""
    pairs = scipy.spatial.cKDTree(points).query_pairs(length_tolerance(points), output_type="ndarray")
    graph = scipy.sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                                    shape=(len(points), len(points)))
    _, label = scipy.sparse.csgraph.connected_components(graph, directed=False)
    _, first, new_index = np.unique(label, return_index=True, return_inverse=True)
    return points[first], new_index


def _concatenate(parts: Sequence[PolygonSet]) -> PolygonSet:
    """One PolygonSet of all parts, coincident points merged (first occurrence kept)."""
    shifts = np.cumsum([0] + [len(p.points) for p in parts])
    offsets, flat = csr([poly + shift for p, shift in zip(parts, shifts) for poly in p.polygons])
    points, new_index = _merge_points(np.concatenate([p.points for p in parts]))
    tags = np.concatenate([np.asarray(p.tags, dtype=np.int32) for p in parts])
    return PolygonSet(points, split_csr(offsets, new_index[flat]), tags)


def glue(*parts: PolygonSet | PolygonMesh | tuple) -> PolygonMesh:
    """Concatenate meshes, merging coincident points, into one PolygonMesh.

    Points of different parts closer than :data:`REL_TOL` times the overall bounding-box
    size are merged (the first part's coordinates are kept). Where the parts' densities
    differ along a shared straight boundary, ``PolygonMesh`` inserts each vertex lying
    strictly inside a neighbour's edge into that neighbour (hanging nodes).

    Parameters
    ----------
    *parts : PolygonSet, PolygonMesh or (points (n,2), polygons, tags (m,)) triples
    """
    return _concatenate([as_polygon_set(p) for p in parts]).to_mesh()
