"""The contact checks that fit a mesh: the 2D :class:`~dolfinx_sfvem.physics.contact.SolidBoundary`
of a polygon mesh or the 3D :class:`~dolfinx_sfvem.physics.solid_surface.SolidSurface` of a
tetrahedral or hexahedral one (docs/contact.md, "Contact checks in 3D").
"""
from __future__ import annotations

import typing

import numpy as np

from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.physics.contact import OVERLAP_TOLERANCE, BoundaryNodes, SolidBoundary


def solid_boundary(mesh: typing.Any, solid_tags: typing.Collection[int],
                   midpoint_keys: typing.Callable[[np.ndarray, np.ndarray], np.ndarray],
                   tolerance: float = OVERLAP_TOLERANCE,
                   face_centre_keys: typing.Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
                   pressure_keys: np.ndarray | None = None) -> BoundaryNodes:
    """The contact geometry of ``mesh``: :class:`SolidBoundary` for a :class:`PolygonMesh`,
    :class:`~dolfinx_sfvem.physics.solid_surface.SolidSurface` for a 3D ``CellMesh`` (the same interface;
    ``face_centre_keys`` only for hexahedra, ``pressure_keys`` only in 3D).

    Raises
    ------
    TypeError
        For a mesh that is neither a :class:`PolygonMesh` nor has points with 3 coordinates.
    """
    if isinstance(mesh, PolygonMesh):
        return SolidBoundary(mesh, solid_tags, midpoint_keys, tolerance)
    if np.shape(mesh.points)[1] != 3:
        raise TypeError(f"contact checks need a PolygonMesh (2D) or a 3D mesh, not a {mesh.cell_type} mesh "
                        f"with {np.shape(mesh.points)[1]} coordinates")
    from dolfinx_sfvem.physics.solid_surface import SolidSurface       # libigl is needed in 3D only
    return SolidSurface(mesh, solid_tags, midpoint_keys, tolerance, face_centre_keys, pressure_keys)
