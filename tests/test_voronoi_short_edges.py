"""voronoi_box's collapse of short edges (dolfinx_sfvem/meshing/short_edges.py): random seeds whose
Voronoi cells have edges of 2e-4 - 2e-3 of their diameter (on two cells of one set the element's
rank test fails) give valid meshes of the box with no edge shorter than min_edge of its cell's
diameter, cells close to the Voronoi cells, and an element with exactly the 6 rigid motions as zero
modes on every cell."""
import numpy as np
import pytest
from scipy.spatial import cKDTree

from dolfinx_sfvem.discretizations.elasticity import linear_elastic_stiffness_3d
from dolfinx_sfvem.meshes import voronoi_box
from dolfinx_sfvem.meshing.voronoi import MIN_EDGE
from dolfinx_sfvem.mesh.polyhedron import polyhedron_edges
from dolfinx_sfvem.discretizations.projection3d import build_projections_3d


def shortest_edges(mesh):
    """Shortest edge over diameter (largest vertex distance) of every cell, (n_cells,)."""
    out = np.empty(mesh.n_cells)
    for c in range(mesh.n_cells):
        points, faces = mesh.polyhedron(c)
        edges = polyhedron_edges(faces)
        diameter = np.linalg.norm(points[:, None] - points[None], axis=2).max()
        out[c] = np.linalg.norm(points[edges[:, 0]] - points[edges[:, 1]], axis=1).min() / diameter
    return out


def assert_well_shaped_voronoi_partition(seeds, lower, upper):
    """The mesh of the seeds, with and without the collapse: the raw one has an edge below MIN_EDGE
    (the case is exercised); the collapsed one (validated by its constructor: closed cells, planar
    faces, matched faces, positive volumes) fills the box, has no edge below MIN_EDGE of its cell,
    its vertices are within 4 MIN_EDGE diameters of being Voronoi vertices (a merge moves a vertex
    by a short edge's length, a chain of short edges by more; 2.1 MIN_EDGE measured), every cell
    builds its projections and its linear-elastic stiffness has exactly 6 zero eigenvalues."""
    raw = voronoi_box(seeds, lower, upper, min_edge=0.0)
    assert shortest_edges(raw).min() < MIN_EDGE
    mesh = voronoi_box(seeds, lower, upper)
    assert mesh.n_cells == seeds.shape[0]
    assert mesh.volumes.sum() == pytest.approx(np.prod(upper - lower), rel=1e-13)
    assert np.all(shortest_edges(mesh) >= MIN_EDGE)
    tree = cKDTree(seeds)
    for c in range(mesh.n_cells):
        points, faces = mesh.polyhedron(c)
        diameter = np.linalg.norm(points[:, None] - points[None], axis=2).max()
        excess = np.linalg.norm(points - seeds[c], axis=1) - tree.query(points)[0]
        assert np.all(excess <= 4 * MIN_EDGE * diameter)
        K, _ = linear_elastic_stiffness_3d(points, faces, 1.0, 0.3)
        eigenvalues = np.linalg.eigvalsh(K)      # rigid motions at round-off (1e-16 of the largest), the
        # others above the rank test's floor (singular values of the strain >= 3e-6, squared: 1e-11)
        assert np.sum(np.abs(eigenvalues) < 1e-13 * eigenvalues.max()) == 6, c
    build_projections_3d(mesh.points, mesh.face_offsets, mesh.face_vertices, mesh.cell_offsets, mesh.cell_faces,
                         mesh.cell_face_signs)
    return raw, mesh


@pytest.mark.parametrize("rng_seed, n", [(4, 60), (1, 20)])
def test_random_seeds_give_well_shaped_cells(rng_seed, n):
    seeds = np.random.default_rng(rng_seed).random((n, 3))
    raw, _ = assert_well_shaped_voronoi_partition(seeds, np.zeros(3), np.ones(3))
    if rng_seed == 4:                # without the collapse the element fails on two cells
        with pytest.raises(ValueError, match="no l <= l_max=10 is sufficient"):
            build_projections_3d(raw.points, raw.face_offsets, raw.face_vertices, raw.cell_offsets, raw.cell_faces,
                                 raw.cell_face_signs)


def test_short_edges_at_the_box_faces_are_collapsed_onto_them():
    """A body-centred lattice of 2 x 2 x 2 + 1 seeds in a 2 x 1 x 1 box, moved by up to 1e-3 of its
    spacing: the lattice's Voronoi vertices lie on the box's planes, so its clipped cells have edges
    of about 1e-3 spacing ending on them; collapsed, the boundary faces still tile the box's faces."""
    lower, upper = np.zeros(3), np.array([2.0, 1.0, 1.0])
    corner = np.stack(np.meshgrid(*[np.arange(2)] * 3, indexing="ij"), axis=-1).reshape(-1, 3) + 0.5
    seeds = np.vstack([corner, [[1.0, 1.0, 1.0]]]) * upper / 2
    seeds += np.random.default_rng(3).uniform(-1e-3, 1e-3, seeds.shape) * upper / 2
    raw, mesh = assert_well_shaped_voronoi_partition(seeds, lower, upper)
    edges = raw.edges()
    short = np.linalg.norm(raw.points[edges[:, 0]] - raw.points[edges[:, 1]], axis=1) < 1e-2
    on_box = np.any((raw.points == lower) | (raw.points == upper), axis=1)
    assert np.any(short & on_box[edges].any(axis=1))
    boundary = mesh.boundary_faces()
    centroids = mesh.face_centroids[boundary]
    assert np.all(np.isclose(centroids, lower, rtol=0, atol=1e-14).any(axis=1)
                  | np.isclose(centroids, upper, rtol=0, atol=1e-14).any(axis=1))
    assert np.linalg.norm(mesh.face_area_vectors[boundary], axis=1).sum() == pytest.approx(10.0, rel=1e-13)


def test_min_edge_must_not_be_negative():
    with pytest.raises(ValueError, match="min_edge must be a number >= 0"):
        voronoi_box([[0.5, 0.5, 0.5]], [0, 0, 0], [1, 1, 1], min_edge=-1e-3)
