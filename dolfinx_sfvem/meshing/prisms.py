"""Prisms: any polygon mesh swept along z into a mesh of polyhedra."""
from __future__ import annotations

import numpy as np

from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh
from dolfinx_sfvem.meshing.hexahedra import extruded_points


def extrude_polygons(mesh2d: PolygonMesh, depth: float, layers: int) -> PolyhedronMesh:
    """Prisms over the polygons of ``mesh2d``, swept from z = 0 to z = ``depth`` in ``layers`` equal
    layers.

    Any polygon extrudes (convex or not, with hanging nodes: a hanging node's vertical line splits
    the side faces of its polygon as the finer neighbours' sides are split, so the mesh stays
    conforming). Cell ``c + n_polygons * layer`` comes from polygon ``c``; its faces are the
    bottom (the polygon reversed, normal -z), the top (normal +z) and one quadrilateral per side of
    the polygon, in the polygon's vertex order. Point ``p + n_points * level`` is point ``p`` at
    z = level * depth / layers (points no polygon uses are dropped, the others keep their order).
    Tags and ``region_names`` are kept.

    Parameters
    ----------
    mesh2d : PolygonMesh
    depth : float > 0
    layers : int >= 1

    Raises
    ------
    ValueError
        For a depth that is not a number > 0 or a layer count that is not an integer >= 1.
    """
    points = extruded_points(mesh2d, depth, layers, "extrude_polygons")
    n, n_poly = mesh2d.n_points, mesh2d.n_polygons
    N = np.diff(mesh2d.offsets)
    owner = np.repeat(np.arange(n_poly), N)
    position = np.arange(mesh2d.vertices.size) - mesh2d.offsets[owner]
    reverse = mesh2d.vertices[mesh2d.offsets[owner + 1] - 1 - position]
    start, end = mesh2d.vertices, mesh2d.vertices[mesh2d.next_entry]
    # one layer's local faces as entries (cell, slot, position, point): bottom slot 0, top 1, sides 2 + j
    side_cell = np.repeat(owner, 4)
    side_slot = 2 + np.repeat(position, 4)
    side_position = np.tile(np.arange(4), owner.size)
    cell = np.concatenate([owner, owner, side_cell])
    slot = np.concatenate([np.zeros_like(owner), np.ones_like(owner), side_slot])
    order = np.lexsort((np.concatenate([position, position, side_position]), slot, cell))
    level = np.concatenate([np.zeros_like(owner), np.ones_like(owner), np.tile([0, 0, 1, 1], owner.size)])[order]
    point = np.concatenate([reverse, start, np.column_stack([start, end, end, start]).ravel()])[order]
    sizes = np.concatenate([N, N, np.full(owner.size, 4)])
    face_cell = np.concatenate([np.arange(n_poly), np.arange(n_poly), owner])
    sizes = sizes[np.lexsort((np.concatenate([np.zeros(n_poly), np.ones(n_poly), 2 + position]), face_cell))]
    vertices = np.concatenate([point + (k + level) * n for k in range(layers)])
    used, vertices = np.unique(vertices, return_inverse=True)
    face_offsets = np.concatenate([[0], np.cumsum(np.tile(sizes, layers))])
    cell_offsets = np.concatenate([[0], np.cumsum(np.tile(N + 2, layers))])
    return PolyhedronMesh.from_cell_faces(points[used], cell_offsets, face_offsets, vertices.reshape(-1),
                                          np.tile(mesh2d.tags, layers), mesh2d.region_names)

