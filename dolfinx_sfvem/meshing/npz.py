"""A small ``.npz`` format for polygon meshes (points, CSR polygons, region tags)."""
from __future__ import annotations

import os

import numpy as np

from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.meshing.polygon_sets import PolygonSet, split_csr


#: identifier stored in the ``.npz`` files written by :func:`write_polygons`
NPZ_FORMAT = "dolfinx-sfvem-polygons-1"


def write_polygons(path: str | os.PathLike, mesh: PolygonMesh) -> None:
    """Save a PolygonMesh as ``.npz``.

    Format (all arrays, numpy ``savez_compressed``): ``format`` = :data:`NPZ_FORMAT`;
    ``points`` (n, 2) float64; ``offsets`` (m+1,) int64 and ``vertices`` (offsets[-1],)
    int64, polygon i being ``vertices[offsets[i]:offsets[i+1]]`` counter-clockwise;
    ``tags`` (m,) int32.
    """
    np.savez_compressed(path, format=np.array(NPZ_FORMAT), points=mesh.points.astype(np.float64),
                        offsets=mesh.offsets.astype(np.int64), vertices=mesh.vertices.astype(np.int64),
                        tags=mesh.tags.astype(np.int32))


def read_polygons(path: str | os.PathLike) -> PolygonMesh:
    """Load a PolygonMesh written by :func:`write_polygons`."""
    with np.load(path) as data:
        if "format" not in data or str(data["format"]) != NPZ_FORMAT:
            raise ValueError(f"{os.fspath(path)} is not a {NPZ_FORMAT} file")
        return PolygonSet(data["points"], split_csr(data["offsets"], data["vertices"]), data["tags"]).to_mesh()
