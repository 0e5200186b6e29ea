"""The Hertz model with an octree block (benchmarks3d.hertz3d_octree, meshing.octree_tetrahedra): the
mesh's volumes, its conformity on the block's top, the octree's sizes, and a first SFVEM step."""
from __future__ import annotations

import math

import numpy as np
import pytest

import dolfinx_sfvem as sf
from dolfinx_sfvem.meshing.benchmarks3d import HERTZ3D_R, SPHERE, hertz3d_octree
from dolfinx_sfvem.meshing.octree_tetrahedra import _square_of_triangles, top_squares
from dolfinx_sfvem.mesh.csr import concatenated_ranges, segment_owner

#: coarse: cubes of 0.25 near the contact, 0.5 far away
H_CONTACT, H_FAR, GAP = 0.25, 0.5, 0.1


@pytest.fixture(scope="module")
def bench():
    return hertz3d_octree(H_CONTACT, H_FAR, GAP, fine_radius=0.4)


def cell_boxes(mesh: sf.meshes.PolyhedronMesh) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners (n_cells, 3) of the cells' bounding boxes."""
    entries = np.repeat(np.arange(mesh.n_cells), np.diff(mesh.cell_offsets))
    face_sizes = np.diff(mesh.face_offsets)[mesh.cell_faces]
    owner = np.repeat(entries, face_sizes)
    vertices = mesh.face_vertices[concatenated_ranges(mesh.face_offsets[mesh.cell_faces], face_sizes)]
    lower = np.full((mesh.n_cells, 3), np.inf)
    upper = np.full((mesh.n_cells, 3), -np.inf)
    np.minimum.at(lower, owner, mesh.points[vertices])
    np.maximum.at(upper, owner, mesh.points[vertices])
    return lower, upper


def test_volumes_and_regions(bench):
    """The block is exactly the 2 x 2 x 1 box, the three regions fill the box 2 x 2 x (1 + gap + R),
    the sphere is the flat-faced quarter hemisphere inside the exact one."""
    mesh = bench.mesh
    volume = {name: mesh.volumes[mesh.tags == tag].sum() for name, tag in bench.regions.items()}
    assert volume["block"] == pytest.approx(4.0, rel=1e-12)
    assert sum(volume.values()) == pytest.approx(4.0 * (1.0 + GAP + HERTZ3D_R), rel=1e-12)
    exact_sphere = 2.0 / 3.0 * math.pi * HERTZ3D_R ** 3 / 4.0
    assert 0.9 * exact_sphere < volume["sphere"] < exact_sphere
    assert mesh.region_names == {"block": sf.meshes.SOLID, "medium": sf.meshes.MEDIUM, "sphere": SPHERE}
    tets = mesh.tags != sf.meshes.SOLID
    assert np.all(np.diff(mesh.cell_offsets)[tets] == 4)


def test_top_squares_are_not_crossed(bench):
    """Every face on the block's top z = 1 is a triangle inside the top square of its block cube
    (the cube's bounding box), and the triangles of a cube cover its square."""
    mesh = bench.mesh
    lower, upper = cell_boxes(mesh)
    cell = segment_owner(mesh.cell_offsets)
    top = np.logical_and.reduceat(np.isclose(mesh.points[mesh.face_vertices, 2], 1.0), mesh.face_offsets[:-1])
    on_top = top[mesh.cell_faces] & (mesh.tags[cell] == sf.meshes.SOLID)
    faces, owner = mesh.cell_faces[on_top], cell[on_top]
    assert np.all(np.diff(mesh.face_offsets)[faces] == 3)
    corners = mesh.points[np.stack([mesh.face(f) for f in faces])][..., :2]                    # (k, 3, 2)
    assert np.all(corners >= lower[owner, None, :2] - 1e-12) and np.all(corners <= upper[owner, None, :2] + 1e-12)
    area = np.bincount(owner, weights=np.linalg.norm(mesh.face_area_vectors[faces], axis=1), minlength=mesh.n_cells)
    top_cubes = np.unique(owner)
    assert area[top_cubes] == pytest.approx(np.prod(upper[top_cubes, :2] - lower[top_cubes, :2], axis=1), rel=1e-12)
    assert area.sum() == pytest.approx(4.0, rel=1e-12)                     # the whole top is covered


def test_octree_sizes_and_hanging_vertices(bench):
    """Cubes of h_contact at the contact point, h_far far from it, 2:1 grading in between with cubes
    that carry hanging vertices (more than 8 vertices, not counting those added on the top)."""
    mesh = bench.mesh
    lower, upper = cell_boxes(mesh)
    block = np.flatnonzero(mesh.tags == sf.meshes.SOLID)
    size = (upper - lower)[block, 0]

    def size_at(x):
        inside = np.all((lower[block] <= x) & (upper[block] >= x), axis=1)
        return size[inside]

    assert size_at([0.01, 0.01, 0.99]) == pytest.approx([H_CONTACT])
    assert size_at([1.99, 1.99, 0.01]) == pytest.approx([H_FAR])
    assert set(np.round(size, 12)) == {H_CONTACT, H_FAR}
    below_top = np.array([np.sum(~np.isclose(mesh.polyhedron(c)[0][:, 2], 1.0)) for c in block])
    assert np.sum(below_top > 4 + 4 * (upper[block, 2] < 1.0)) > 0          # cubes with hanging vertices


def test_markers_hold_face_centroids(bench):
    """The symmetry plane's nodes include the SFVEM's face means at the faces' centroids."""
    nodes = bench.nodes_on("symmetry_x")
    mesh = bench.mesh
    on = np.logical_and.reduceat(np.isclose(mesh.points[mesh.face_vertices, 0], 0.0), mesh.face_offsets[:-1])
    assert np.all(np.isclose(nodes[:, 0], 0.0))
    tree_hits = bench.marker("symmetry_x")(mesh.face_centroids[on].T)
    assert tree_hits.all() and on.sum() > 0


def test_geometry_must_cover_the_top():
    """A gmsh geometry over half of the octree's top leaves squares without triangles: refused."""
    octree = sf.meshes.octree_box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 2)

    def half_box(gmsh):
        volume = gmsh.model.occ.addBox(0.0, 0.0, 1.0, 0.5, 1.0, 0.5)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
        return {2: [volume]}

    with pytest.raises(ValueError, match="cover"):
        sf.meshes.octree_under_tetrahedra(octree, half_box, {"block": 1, "top": 2}, 1)


def test_a_triangle_across_two_squares_is_refused():
    """The check behind the conformity: a triangle of the top plane reaching into the next square."""
    octree = sf.meshes.octree_box((0.0, 0.0, 0.0), (2.0, 1.0, 1.0), (2, 1, 1))
    leaves, lower, upper = top_squares(octree)
    points = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0], [2.0, 0.0, 1.0],
                       [2.0, 1.0, 1.0]])
    squares = _square_of_triangles(octree, leaves, points, np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]]),
                                   lower, upper, 1e-12)
    assert leaves[squares].tolist() == [0, 0, 1, 1]
    with pytest.raises(ValueError, match="does not lie inside one octree square"):
        _square_of_triangles(octree, leaves, points, np.array([[0, 4, 5], [0, 5, 3]]), lower, upper, 1e-12)


@pytest.mark.slow
def test_first_sfvem_step(tmp_path):
    """One step of the demo with --block octree --method vem (the sphere moved by a tenth of the
    gap): the medium's force on the block is the load's reaction, the z reactions balance, and the
    gap stays open."""
    import hertz3d

    args = hertz3d.common.parse_args(hertz3d.make_parser(), [
        "--block", "octree", "--method", "vem", "--h", "0.25", "--h-core", "0.125", "--core-radius", "0.15",
        "--h-far", "0.5", "--fine-radius", "0.3", "--regularization", "huhu", "--quiet"])
    problem, _ = hertz3d.build(args)
    result = problem.solve(steps=10, until=0.1, out=tmp_path)
    assert result.converged
    step = result.steps[-1]
    load = step["reaction"]["load"][2]
    block = next(c for c in step["contact"] if c["region"] == sf.meshes.SOLID)
    assert load < 0.0
    assert block["force"][2] == pytest.approx(load, rel=1e-4)
    assert sum(r[2] for r in step["reaction"].values()) == pytest.approx(0.0, abs=1e-6 * abs(load))
    assert 0.0 < block["gap"] < GAP


def test_octree_block_needs_the_sfvem():
    import hertz3d

    args = hertz3d.common.parse_args(hertz3d.make_parser(), ["--block", "octree", "--method", "fem"])
    with pytest.raises(ValueError, match="needs --method vem"):
        hertz3d.build(args)
