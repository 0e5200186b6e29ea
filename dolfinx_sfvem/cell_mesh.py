"""PLACEHOLDER written on branch h-meshes ONLY so that the 3D mesh generators and their tests run
before `core`'s CellMesh lands. The lead merges core's real ``dolfinx_sfvem/cell_mesh.py`` in its
place (keep core's version on conflict; this file has no other user than the generators' thin
constructor call ``CellMesh(points, cells, tags, cell_type, region_names)``).
"""
from __future__ import annotations

import numpy as np

_TDIM = {"triangle": 2, "quadrilateral": 2, "tetrahedron": 3, "hexahedron": 3}


class CellMesh:
    """Placeholder: stores the arrays of the contract in /work/wt/3D-INTERFACES.md, no validation."""

    def __init__(self, points, cells, tags, cell_type, region_names=None):
        self.points = np.ascontiguousarray(points, dtype=np.float64)
        self.cells = np.ascontiguousarray(cells, dtype=np.int64)
        self.tags = np.ascontiguousarray(tags, dtype=np.int64)
        self.cell_type = cell_type
        self.region_names = dict(region_names or {})
        self.gdim, self.tdim = self.points.shape[1], _TDIM[cell_type]
