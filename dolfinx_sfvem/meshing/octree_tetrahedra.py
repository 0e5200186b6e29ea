"""Polyhedra: an octree block under gmsh tetrahedra, conforming on the block's top plane.

The block is an :class:`~dolfinx_sfvem.meshing.octree.OctreeMesh` (its cubes read as polyhedra,
hanging vertices and all); the bodies above it are a gmsh geometry whose bottom lies on the
block's top plane z = z_top and covers it. Before gmsh meshes that geometry, every square of the
octree's top (the top face of a leaf in the top layer) is fragmented into it (OpenCASCADE), so
that the plane z = z_top is meshed square by square: every gmsh triangle there lies inside one
octree square, and the squares' corners, the hanging ones included, are gmsh nodes. Then

- each top-layer cube's top face is replaced by the gmsh triangles inside its square (the cube
  becomes a polyhedron with more faces, all planar);
- every gmsh node on a square's side (gmsh splits a side longer than its mesh size) is inserted
  into the loops of the octree faces that have that side as an edge, so the cubes stay closed
  and every face matches the face across;
- the tetrahedra become polyhedra of four triangles; points are merged by coordinates.

The result is validated by :class:`~dolfinx_sfvem.mesh.polyhedron_mesh.PolyhedronMesh` (closed,
oriented, matching faces).
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from dolfinx_sfvem.mesh.polygon import RTOL
from dolfinx_sfvem.mesh.csr import concatenated_ranges, next_entries, segment_owner
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh
from dolfinx_sfvem.meshing.gmsh3d import VolumeBuilder, gmsh_tetrahedra
from dolfinx_sfvem.meshing.octree import OctreeMesh

#: outward faces of a positively oriented tetrahedron (local vertex triples)
_TETRAHEDRON_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


def top_squares(octree: OctreeMesh) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The leaves of the top layer (k,) and the lower and upper (x, y) corners (k, 2) of their top
    squares."""
    leaves = np.flatnonzero(octree.ijk[:, 2] == (octree.n[2] << octree.level) - 1)
    lower = octree.centres[leaves, :2] - 0.5 * octree.sizes[leaves, :2]
    return leaves, lower, lower + octree.sizes[leaves, :2]


def octree_under_tetrahedra(octree: OctreeMesh, build: VolumeBuilder, names: Mapping[str, int],
                            block_tag: int) -> PolyhedronMesh:
    """The octree's cubes (tag ``block_tag``) and the tetrahedra of the gmsh geometry above them,
    conforming on the octree's top plane (module docstring).

    Parameters
    ----------
    octree
        The block; its top plane is z = ``octree.upper[2]``.
    build
        A :data:`~dolfinx_sfvem.meshing.gmsh3d.VolumeBuilder` making the bodies above the block with
        gmsh's OpenCASCADE kernel (synchronised, mesh size set; ``{tag: volumes}`` returned); their
        part on the plane z = top must be exactly the block's top (no gap, nothing beyond it).
    names
        Region name -> tag of the whole mesh (the block's included).
    block_tag
        Region tag of the octree's cells.

    Returns
    -------
    PolyhedronMesh
        The octree's cells first (cell ``c`` is leaf ``c``), then the tetrahedra.

    Raises
    ------
    ValueError
        If a gmsh triangle on the top plane does not lie inside one octree square, or the
        triangles leave part of a square uncovered (the geometry is not exactly on the block's
        top), and whatever :class:`PolyhedronMesh` refuses.
    """
    leaves, square_lo, square_hi = top_squares(octree)
    z_top = float(octree.upper[2])

    def build_on_squares(gmsh) -> dict[int, list[int]]:
        regions = {tag: list(volumes) for tag, volumes in build(gmsh).items()}
        occ = gmsh.model.occ
        rectangles = [(2, occ.addRectangle(x0, y0, z_top, x1 - x0, y1 - y0))
                      for (x0, y0), (x1, y1) in zip(square_lo.tolist(), square_hi.tolist())]
        volumes = [(3, v) for tag in regions for v in regions[tag]]
        _, children = occ.fragment(volumes, rectangles)
        occ.synchronize()
        pieces = iter(children[:len(volumes)])
        return {tag: [v for _ in regions[tag] for _, v in next(pieces)] for tag in regions}

    tets = gmsh_tetrahedra(build_on_squares, {name: tag for name, tag in names.items() if tag != block_tag})
    blocks = octree.polyhedra(lambda x: np.full(x.shape[1], block_tag), None)
    extent = np.ptp(np.vstack([blocks.points, tets.points]), axis=0)
    tol = RTOL * float(np.linalg.norm(extent))
    points, gmsh_index = _merge_points(blocks.points, tets.points, tol)
    cells = gmsh_index[tets.cells]
    triangles = _top_triangles(points, cells, z_top, tol)
    owner = _square_of_triangles(octree, leaves, points, triangles, square_lo, square_hi, tol)
    on_top = np.abs(points[:, 2] - z_top) <= tol
    face_offsets, face_vertices = _with_top_points(points, blocks.face_offsets, blocks.face_vertices,
                                                   np.flatnonzero(on_top[blocks.n_points:]) + blocks.n_points,
                                                   on_top, tol)
    top_face = np.logical_and.reduceat(on_top[face_vertices], face_offsets[:-1])
    # the octree cells' faces, oriented out of their cells, without their top faces
    cell = segment_owner(blocks.cell_offsets)
    keep = ~top_face[blocks.cell_faces]
    local_offsets, local_vertices = _oriented(face_offsets, face_vertices, blocks.cell_faces[keep],
                                              blocks.cell_face_signs[keep])
    # the top triangles (pointing up, out of the block) and the tetrahedra's faces
    tet_faces = cells[:, _TETRAHEDRON_FACES].reshape(-1, 3)
    face_cell = np.concatenate([cell[keep], leaves[owner], blocks.n_cells + np.repeat(np.arange(tets.n_cells), 4)])
    sizes = np.concatenate([np.diff(local_offsets), np.full(len(triangles) + len(tet_faces), 3)])
    vertices = np.concatenate([local_vertices, triangles.ravel(), tet_faces.ravel()])
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    order = np.argsort(face_cell, kind="stable")
    vertices = vertices[concatenated_ranges(starts[order], sizes[order])]
    cell_offsets = np.concatenate([[0], np.cumsum(np.bincount(face_cell, minlength=blocks.n_cells + tets.n_cells))])
    tags = np.concatenate([np.full(blocks.n_cells, block_tag, dtype=np.int64), tets.tags])
    return PolyhedronMesh.from_cell_faces(points, cell_offsets, np.concatenate([[0], np.cumsum(sizes[order])]),
                                          vertices, tags, names)


def _merge_points(octree_points: npt.NDArray[np.float64], gmsh_points: npt.NDArray[np.float64], tol: float
                  ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """The octree's points, then the gmsh points that are none of them within ``tol``; and the
    index (n_gmsh,) of every gmsh point in that list."""
    distance, nearest = cKDTree(octree_points).query(gmsh_points, distance_upper_bound=tol)
    new = ~np.isfinite(distance)
    index = np.where(new, octree_points.shape[0] + np.cumsum(new) - 1, nearest).astype(np.int64)
    return np.vstack([octree_points, gmsh_points[new]]), index


def _top_triangles(points: npt.NDArray[np.float64], tetrahedra: npt.NDArray[np.int64], z_top: float, tol: float
                   ) -> npt.NDArray[np.int64]:
    """The tetrahedra's faces (k, 3) on the plane z = z_top, oriented upward (out of the block
    below, into the tetrahedra)."""
    faces = tetrahedra[:, _TETRAHEDRON_FACES].reshape(-1, 3)
    on_plane = np.all(np.abs(points[faces, 2] - z_top) <= tol, axis=1)
    return faces[on_plane][:, ::-1]


def _square_of_triangles(octree: OctreeMesh, leaves: npt.NDArray[np.int64], points: npt.NDArray[np.float64],
                         triangles: npt.NDArray[np.int64], lower: npt.NDArray[np.float64],
                         upper: npt.NDArray[np.float64], tol: float) -> npt.NDArray[np.int64]:
    """The top square (index into ``leaves`` (k,) and their squares' corners ``lower``, ``upper``
    (k, 2)) holding each triangle (t,): the top leaf over the finest cell under the triangle's
    centroid. ValueError if a triangle's corners are not all in that square, or the triangles do
    not cover every square."""
    xy = points[triangles, :2]                                          # (t, 3, 2)
    centre = xy.mean(axis=1)
    finest = octree.n << octree.finest
    ij = np.floor((centre - octree.lower[:2]) / (octree.upper - octree.lower)[:2] * finest[:2]).astype(np.int64)
    ijk = np.column_stack([np.clip(ij, 0, finest[:2] - 1), np.full(len(ij), finest[2] - 1)])
    leaf = octree.covering(octree.finest, ijk)
    square = np.searchsorted(leaves, leaf)
    square[(square >= leaves.size) | (leaves[np.minimum(square, leaves.size - 1)] != leaf)] = -1
    bad = np.flatnonzero(square < 0)
    if bad.size == 0:
        corners_in = np.all((xy >= lower[square, None] - tol) & (xy <= upper[square, None] + tol), axis=(1, 2))
        bad = np.flatnonzero(~corners_in)
    if bad.size:
        t = int(bad[0])
        raise ValueError(f"the gmsh triangle {triangles[t].tolist()} on the octree's top (corners "
                         f"{xy[t].tolist()}) does not lie inside one octree square")
    d1, d2 = xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]
    area = np.bincount(square, weights=0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]), minlength=len(lower))
    uncovered = np.flatnonzero(np.abs(area - np.prod(upper - lower, axis=1)) > tol * (upper - lower).max(axis=1))
    if uncovered.size:
        s = int(uncovered[0])
        raise ValueError(f"the gmsh triangles on the octree's top cover {area[s]:.6g} of its square "
                         f"{lower[s].tolist()}-{upper[s].tolist()}, not all of it")
    return square


def _with_top_points(points: npt.NDArray[np.float64], offsets: npt.NDArray[np.int64],
                     vertices: npt.NDArray[np.int64], extra: npt.NDArray[np.int64], on_top: npt.NDArray[np.bool_],
                     tol: float) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """The face loops (CSR) with the points ``extra`` inserted, in order, into every side whose
    two ends are on the top plane (``on_top``) and on which they lie."""
    nxt = vertices[next_entries(offsets)]
    side = np.flatnonzero(on_top[vertices] & on_top[nxt])
    a, b = points[vertices[side]], points[nxt[side]]
    length = np.linalg.norm(b - a, axis=1)
    near = cKDTree(points[extra]).query_ball_point(0.5 * (a + b), 0.5 * length + tol) if extra.size else \
        [[] for _ in side]
    count = np.array([len(n) for n in near], dtype=np.int64)
    hit_side = np.repeat(np.arange(side.size), count)
    hit = extra[np.concatenate([np.asarray(n, dtype=np.int64) for n in near])] if count.sum() else \
        np.zeros(0, np.int64)
    d = points[hit] - a[hit_side]
    t = np.einsum("ij,ij->i", d, b[hit_side] - a[hit_side]) / length[hit_side] ** 2
    off = np.linalg.norm(d - t[:, None] * (b[hit_side] - a[hit_side]), axis=1)
    inside = (off <= tol) & (t * length[hit_side] > tol) & ((1.0 - t) * length[hit_side] > tol)
    hit_side, hit, t = hit_side[inside], hit[inside], t[inside]
    # entries: every old vertex at (its position, 0), every inserted point after its side's start
    position = np.concatenate([np.arange(vertices.size), side[hit_side]])
    along = np.concatenate([np.zeros(vertices.size), t])
    order = np.lexsort((along, position))
    new_vertices = np.concatenate([vertices, hit])[order]
    grown = np.bincount(segment_owner(offsets)[side[hit_side]], minlength=offsets.size - 1)
    return np.concatenate([[0], np.cumsum(np.diff(offsets) + grown)]), new_vertices


def _oriented(offsets: npt.NDArray[np.int64], vertices: npt.NDArray[np.int64], faces: npt.NDArray[np.int64],
              signs: npt.NDArray[np.int64]) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """CSR of the loops of ``faces`` (k,), reversed where ``signs`` is negative."""
    sizes = np.diff(offsets)[faces]
    new_offsets = np.concatenate([[0], np.cumsum(sizes)])
    local = np.arange(new_offsets[-1]) - np.repeat(new_offsets[:-1], sizes)
    position = np.where(np.repeat(signs, sizes) > 0, local, np.repeat(sizes, sizes) - 1 - local)
    return new_offsets, vertices[np.repeat(offsets[faces], sizes) + position]
