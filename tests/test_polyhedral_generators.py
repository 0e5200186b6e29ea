"""Prisms over polygon meshes and clipped Voronoi polyhedra: volumes, matched faces, convexity and
the Voronoi property, against the 2D areas and the box."""
import numpy as np
import pytest
from scipy.spatial import cKDTree

import dolfinx_sfvem as sf
from dolfinx_sfvem.meshes import extrude_polygons, voronoi_box


def assert_faces_matched(mesh, boundary):
    """Faces with ``boundary`` (n_faces,) True are in one cell, the others in two with opposite signs."""
    count = np.bincount(mesh.cell_faces, minlength=mesh.n_faces)
    assert np.all(count == np.where(boundary, 1, 2))
    signs = np.bincount(mesh.cell_faces, weights=mesh.cell_face_signs, minlength=mesh.n_faces)
    assert np.all(signs[~boundary] == 0)


def test_prisms_over_polygons_with_hanging_nodes_keep_the_volumes():
    mesh2d = sf.meshes.quads_with_hanging_nodes(2.0, 1.0, 4, refine=(0.5, 1.5, 0.25, 0.75))
    mesh2d.region_names = {"all": 0}
    assert mesh2d.hanging_nodes.size == 8
    depth, layers = 0.3, 2
    mesh = extrude_polygons(mesh2d, depth, layers)
    assert mesh.n_cells == layers * mesh2d.n_polygons
    assert mesh.volumes == pytest.approx(np.tile(mesh2d.areas, layers) * depth / layers, rel=1e-13)
    assert np.all(np.diff(mesh.cell_offsets) == np.tile(np.diff(mesh2d.offsets) + 2, layers))
    z, x, y = mesh.face_centroids[:, 2], mesh.face_centroids[:, 0], mesh.face_centroids[:, 1]
    outer = (np.isclose(z, 0) | np.isclose(z, depth) | np.isclose(x, 0) | np.isclose(x, 2) | np.isclose(y, 0)
             | np.isclose(y, 1))
    assert_faces_matched(mesh, outer)
    area = np.linalg.norm(mesh.face_area_vectors[mesh.boundary_faces()], axis=1).sum()
    assert area == pytest.approx(2 * 2.0 + 2 * (2.0 + 1.0) * depth)
    assert mesh.region_names == {"all": 0} and mesh.n_points == 3 * mesh2d.n_points
    # a coarse pentagon's prism: bottom, top and 5 sides, one side on each half of the split edge
    pentagon = int(np.flatnonzero(np.diff(mesh2d.offsets) == 5)[0])
    points, faces = mesh.polyhedron(pentagon)
    assert points.shape == (10, 3) and sorted(len(f) for f in faces) == [4] * 5 + [5] * 2


def test_a_non_convex_prism():
    """An L-shaped hexagon and the square that completes it to [0, 2]^2."""
    points = [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2], [2, 2]]
    mesh2d = sf.PolygonMesh(points, [[0, 1, 2, 3, 4, 5], [3, 2, 6, 4]], [1, 2])
    mesh = extrude_polygons(mesh2d, 1.0, 1)
    assert mesh.volumes == pytest.approx([3.0, 1.0]) and mesh.tags.tolist() == [1, 2]
    assert np.allclose(mesh.centroids[0], [5 / 6, 5 / 6, 0.5])      # the L's centroid by its two rectangles


def test_extrude_polygons_errors():
    mesh2d = sf.meshes.quad_rectangle(1.0, 1.0, 1, 1)
    with pytest.raises(ValueError, match="extrude_polygons: depth must be a number > 0"):
        extrude_polygons(mesh2d, 0.0, 1)
    with pytest.raises(ValueError, match="extrude_polygons: layers must be an integer >= 1"):
        extrude_polygons(mesh2d, 1.0, 0)


@pytest.mark.parametrize("clustered", [False, True])
def test_voronoi_cells_are_convex_fill_the_box_and_are_voronoi(clustered):
    """40 uniform seeds in a 2 x 1 x 1 box, or 300 seeds in a corner of a 4 x 2 x 2 box and 2 far from
    its faces (their cells reach the faces from farther than three mean spacings: voronoi_box must
    mirror more seeds than at first); no collapse of short edges (min_edge=0: the exact cells)."""
    rng = np.random.default_rng(7)
    if clustered:
        lower, upper = np.array([0.0, 0.0, 0.0]), np.array([4.0, 2.0, 2.0])
        seeds = np.vstack([rng.random((300, 3)) * 0.5, [[2.0, 1.0, 1.0], [3.0, 1.1, 0.9]]])
    else:
        lower, upper = np.array([0.0, 0.0, 0.0]), np.array([2.0, 1.0, 1.0])
        seeds = rng.random((40, 3)) * upper
    mesh = voronoi_box(seeds, lower, upper, min_edge=0.0)
    size = upper - lower
    assert mesh.n_cells == seeds.shape[0] and mesh.volumes.sum() == pytest.approx(np.prod(size), rel=1e-12)
    on_box = np.isclose(mesh.face_centroids, lower).any(axis=1) | np.isclose(mesh.face_centroids, upper).any(axis=1)
    assert_faces_matched(mesh, on_box)
    assert np.linalg.norm(mesh.face_area_vectors[on_box], axis=1).sum() == pytest.approx(
        2 * (size[0] * size[1] + size[1] * size[2] + size[0] * size[2]))
    tree = cKDTree(seeds)
    for c in range(mesh.n_cells):
        points, faces = mesh.polyhedron(c)
        # convex: every vertex on the inner side of every face's plane
        for f in faces:
            normal = np.cross(points[f[1]] - points[f[0]], points[f[2]] - points[f[0]])
            assert np.all((points - points[f[0]]) @ normal <= 1e-12)
        # Voronoi: seed c is a nearest seed of each of its vertices
        nearest = tree.query(points)[0]
        assert np.allclose(np.linalg.norm(points - seeds[c], axis=1), nearest, atol=1e-12)
        assert np.all(points >= lower - 1e-15) and np.all(points <= upper + 1e-15)


def test_voronoi_of_a_lattice_is_a_grid_of_cubes():
    centres = (np.stack(np.meshgrid(*[np.arange(3) + 0.5] * 3, indexing="ij"), axis=-1).reshape(-1, 3)) / 3
    mesh = voronoi_box(centres, [0, 0, 0], [1, 1, 1], tags=np.arange(27) % 2, region_names={"odd": 1})
    assert mesh.volumes == pytest.approx(np.full(27, 1 / 27), rel=1e-12)
    assert mesh.n_faces == 108 and mesh.n_points == 64 and np.all(np.diff(mesh.face_offsets) == 4)
    assert np.allclose(mesh.centroids, centres) and mesh.region_names == {"odd": 1}


def test_voronoi_box_errors():
    with pytest.raises(ValueError, match=r"seed 1 .* is not strictly inside the box"):
        voronoi_box([[0.5, 0.5, 0.5], [1.0, 0.5, 0.5]], [0, 0, 0], [1, 1, 1])
    with pytest.raises(ValueError, match="seed 0 is repeated"):
        voronoi_box([[0.5, 0.5, 0.5], [0.2, 0.5, 0.5], [0.5, 0.5, 0.5]], [0, 0, 0], [1, 1, 1])
    with pytest.raises(ValueError, match="upper > lower"):
        voronoi_box([[0.5, 0.5, 0.5]], [0, 0, 0], [1, 1, 0])
