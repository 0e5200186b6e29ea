"""What a polygon mesh is made of: T-junctions and a one-paragraph summary."""
from __future__ import annotations


import numpy as np

from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh


def t_junctions(mesh: PolygonMesh) -> np.ndarray:
    """Hanging nodes in the T-junction sense: vertices (k,) at which one polygon has a
    straight angle and another polygon a proper corner.

    These are where meshes of different densities meet. Unlike ``mesh.hanging_nodes``
    (every vertex collinear with its neighbours in some polygon), a collinear vertex that
    no polygon has as a corner is not counted: on a straight outer boundary, or straight
    on both sides of an interface (as the dual of a triangle mesh leaves them).
    """
    points, flat, nxt, prv = mesh.points, mesh.vertices, mesh.next_entry, mesh.previous_entry
    d_in, d_out = points[flat] - points[flat[prv]], points[flat[nxt]] - points[flat]
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    length_in, length_out = np.linalg.norm(d_in, axis=1), np.linalg.norm(d_out, axis=1)
    straight = (np.abs(cross) <= mesh.tol * np.maximum(length_in, length_out)) \
        & (np.einsum("ij,ij->i", d_in, d_out) > 0)
    has_straight = np.bincount(flat[straight], minlength=len(points)) > 0
    has_corner = np.bincount(flat[~straight], minlength=len(points)) > 0
    return np.flatnonzero(has_straight & has_corner)


def describe(mesh: PolygonMesh) -> str:
    """Summary: polygons by vertex count, hanging nodes, per-region counts and areas, area range.

    Hanging nodes are counted three ways: T-junctions (:func:`t_junctions`), vertices
    inserted by T-junction repair, and all collinear polygon vertices
    (``mesh.hanging_nodes``, which also holds straight-boundary vertices of dual meshes).
    """
    n_vertices, counts = np.unique(np.diff(mesh.offsets), return_counts=True)
    lines = [f"{mesh.n_polygons} polygons, {mesh.n_points} points",
             "polygons by vertex count: " + ", ".join(f"{k}: {c}" for k, c in zip(n_vertices, counts)),
             f"hanging nodes: {t_junctions(mesh).size} T-junctions ({mesh.n_inserted_hanging_nodes} vertex "
             f"insertions), {mesh.hanging_nodes.size} collinear vertices"]
    for tag in np.unique(mesh.tags):
        chosen = mesh.tags == tag
        lines.append(f"region {tag}: {chosen.sum()} polygons, area {mesh.areas[chosen].sum():.6g}")
    lines.append(f"polygon area: min {mesh.areas.min():.3g}, max {mesh.areas.max():.3g}")
    return "\n".join(lines)
