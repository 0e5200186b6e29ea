"""PolyhedronMesh: storage, queries and validation on tiny meshes (exact volumes, hand counts)."""
import numpy as np
import pytest

from dolfinx_sfvem.meshing.hexahedra import box_grid
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh

#: the unit cube's corners (tensor-product order) and its faces, outward
CUBE = np.array([[i, j, k] for k in (0, 1) for j in (0, 1) for i in (0, 1)], dtype=float)
CUBE_FACES = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]


def csr(lists):
    """(offsets, flat values) of a list of lists."""
    return np.concatenate([[0], np.cumsum([len(a) for a in lists])]), np.concatenate(lists)


def cubes(shifts, flip=None):
    """Unit cubes shifted by ``shifts`` (k, 3), each with its own points and faces (no sharing);
    the faces of cell ``flip`` reversed."""
    points = np.concatenate([CUBE + s for s in shifts])
    faces = [[8 * c + v for v in (f[::-1] if c == flip else f)] for c in range(len(shifts)) for f in CUBE_FACES]
    face_offsets, face_vertices = csr(faces)
    n = 6 * len(shifts)
    return points, face_offsets, face_vertices, np.arange(0, n + 1, 6), np.arange(n), np.ones(n, dtype=int)


def grid(cell, n=(2, 2, 1), lengths=(1.0, 2.0, 1.0)):
    mesh = box_grid(*(np.linspace(0.0, L, k + 1) for L, k in zip(lengths, n)),
                    lambda x, y, z: np.where(x < lengths[0] / 2, 1, 2), {"left": 1}, cell)
    return PolyhedronMesh.from_cell_mesh(mesh)


def assert_closed_outward(points, faces, volume):
    """Sum of the area vectors 0 and (1/3) sum x_f . A_f = volume (divergence theorem), from the
    faces' own vertices (fans from their first vertex)."""
    total, flux = np.zeros(3), 0.0
    for f in faces:
        x = points[f]
        A = 0.5 * np.cross(x[1:-1] - x[0], x[2:] - x[0]).sum(axis=0)
        total += A
        flux += x.mean(axis=0) @ A / 3.0      # any point of a planar face: A is normal to it
    assert np.allclose(total, 0.0, atol=1e-13)
    assert flux == pytest.approx(volume, rel=1e-12)


def test_one_cube_and_its_polyhedron():
    mesh = PolyhedronMesh(*cubes([[0.0, 0.0, 0.0]]))
    assert mesh.volumes == pytest.approx([1.0]) and np.allclose(mesh.centroids, 0.5)
    points, faces = mesh.polyhedron(0)
    assert points.shape == (8, 3) and len(faces) == 6 and all(f.dtype == np.int64 for f in faces)
    assert_closed_outward(points, faces, 1.0)
    assert mesh.boundary_faces().tolist() == list(range(6)) and mesh.edges().shape == (12, 2)


@pytest.mark.parametrize("cell, n_faces", [("hexahedron", 6), ("tetrahedron", 4)])
def test_from_cell_mesh_fills_the_box_with_matched_faces(cell, n_faces):
    mesh = grid(cell)
    assert mesh.volumes.sum() == pytest.approx(2.0, rel=1e-14) and np.all(mesh.volumes > 0)
    assert np.all(np.diff(mesh.cell_offsets) == n_faces)
    cells = mesh.face_cells
    interior = (cells >= 0).all(axis=1)
    # every face once: in two cells with opposite signs inside, in one on the boundary
    count = np.bincount(mesh.cell_faces, minlength=mesh.n_faces)
    assert np.all(count == np.where(interior, 2, 1))
    signs = np.bincount(mesh.cell_faces, weights=mesh.cell_face_signs, minlength=mesh.n_faces)
    assert np.all(signs[interior] == 0)
    # boundary: 2 (1*2 + 2*1 + 1*1) = 10 unit squares of the 2 x 2 x 1 grid of (0.5 x 1 x 1) boxes
    boundary_area = np.linalg.norm(mesh.face_area_vectors[mesh.boundary_faces()], axis=1).sum()
    assert boundary_area == pytest.approx(2 * (1 * 2 + 2 * 1 + 1 * 1))
    assert mesh.boundary_faces().size == (16 if cell == "hexahedron" else 32)
    for c in range(mesh.n_cells):
        assert_closed_outward(*mesh.polyhedron(c), mesh.volumes[c])
    assert mesh.region_names == {"left": 1} and np.bincount(mesh.tags).tolist() == [0, mesh.n_cells // 2,
                                                                                    mesh.n_cells // 2]


@pytest.mark.parametrize("cell_type", ["tetrahedron", "hexahedron"])
def test_from_dolfinx_create_box(cell_type):
    import dolfinx.mesh
    from mpi4py import MPI
    from dolfinx_sfvem import _compat
    from dolfinx_sfvem.mesh.cell_mesh import CellMesh
    box = dolfinx.mesh.create_box(MPI.COMM_WORLD, [[0.0, 0.0, 0.0], [2.0, 1.0, 1.0]], [2, 2, 1],
                                  getattr(dolfinx.mesh.CellType, cell_type))
    n = _compat.num_owned_cells(box) + box.topology.index_map(3).num_ghosts
    mesh = PolyhedronMesh.from_cell_mesh(CellMesh.from_dolfinx(box, _compat.create_cell_tags(
        box, np.ones(n, dtype=np.int32))))
    assert mesh.n_cells == (4 if cell_type == "hexahedron" else 24)
    assert mesh.volumes.sum() == pytest.approx(2.0, rel=1e-14)
    assert np.all(np.bincount(mesh.cell_faces) <= 2)


def test_a_flipped_face_is_named():
    points, fo, fv, co, cf, signs = cubes([[0, 0, 0], [3, 0, 0]])
    signs[8] = -1                                                  # face 2 of cell 1
    with pytest.raises(ValueError, match=r"cell 1 is not consistently oriented: its edge .* runs the same way"):
        PolyhedronMesh(points, fo, fv, co, cf, signs)


def test_a_reversed_vertex_order_is_named():
    points, fo, fv, co, cf, signs = cubes([[0, 0, 0], [3, 0, 0]])
    fv[fo[7]:fo[8]] = fv[fo[7]:fo[8]][::-1].copy()                 # face 1 of cell 1 turned round
    with pytest.raises(ValueError, match=r"cell 1 is not consistently oriented"):
        PolyhedronMesh(points, fo, fv, co, cf, signs)


def test_an_open_cell_is_named():
    points, fo, fv, co, cf, signs = cubes([[0, 0, 0], [3, 0, 0]])
    keep = np.arange(12) != 9                                      # cell 1 loses a face
    faces = [fv[fo[f]:fo[f + 1]] for f in range(12) if keep[f]]
    fo, fv = csr(faces)
    with pytest.raises(ValueError, match=r"cell 1 is not closed: its edge \(\d+, \d+\) lies in only one"):
        PolyhedronMesh(points, fo, fv, [0, 6, 11], np.arange(11), np.ones(11, dtype=int))


def test_a_non_planar_face_is_named():
    points, *rest = cubes([[0, 0, 0], [3, 0, 0], [6, 0, 0]])
    points[23] += [0.0, 0.0, 0.01]                                 # corner (1, 1, 1) of cell 2 lifted
    with pytest.raises(ValueError, match=r"cell 2: face 1[3-7] is not planar: its vertex \d+ lies"):
        PolyhedronMesh(points, *rest)
    PolyhedronMesh(points, *rest, planar_rtol=0.01)  # within a looser tolerance


def test_a_negative_volume_is_named():
    with pytest.raises(ValueError, match=r"cell 1 has a negative volume \(-1\): its faces point into it"):
        PolyhedronMesh(*cubes([[0, 0, 0], [3, 0, 0]], flip=1))


def test_faces_shared_wrongly_are_named():
    mesh = grid("hexahedron", n=(2, 1, 1), lengths=(2.0, 1.0, 1.0))
    args = [mesh.points, mesh.face_offsets, mesh.face_vertices, mesh.cell_offsets, mesh.cell_faces,
            mesh.cell_face_signs]
    shared = int(np.flatnonzero((mesh.face_cells >= 0).all(axis=1))[0])
    signs = mesh.cell_face_signs.copy()
    signs[mesh.cell_faces == shared] = 1
    with pytest.raises(ValueError, match=rf"cell 1: its face {shared} points the same way as in cell 0"):
        PolyhedronMesh(*args[:5], signs)
    # the shared face stored twice, once for each cell
    fo, fv = csr([mesh.face(f) for f in range(mesh.n_faces)] + [mesh.face(shared)[::-1]])
    cf = mesh.cell_faces.copy()
    second = np.flatnonzero(cf == shared)[1]
    cf[second], signs = mesh.n_faces, mesh.cell_face_signs.copy()
    signs[second] = 1
    with pytest.raises(ValueError, match=rf"cell 1: its face {mesh.n_faces} has the vertices of face {shared}"):
        PolyhedronMesh(mesh.points, fo, fv, mesh.cell_offsets, cf, signs)
    # a face in three cells: a third cell made of cell 0's faces
    with pytest.raises(ValueError, match=r"cell 2: its face \d+ also belongs to cells \[0, 1\]"):
        PolyhedronMesh(*args[:3], np.r_[mesh.cell_offsets, 18], np.r_[mesh.cell_faces, mesh.cell_faces[:6]],
                       np.r_[mesh.cell_face_signs, mesh.cell_face_signs[:6]])


def test_a_t_junction_is_not_conforming():
    """A unit cube next to two half boxes: the cube's face x = 1 is not split like theirs."""
    half = np.array([[1, 0, 0], [2, 0, 0], [1, 0.5, 0], [2, 0.5, 0], [1, 0, 1], [2, 0, 1], [1, 0.5, 1], [2, 0.5, 1]])
    points, index = np.unique(np.concatenate([CUBE, half, half + [0, 0.5, 0]]), axis=0, return_inverse=True)
    fo, fv = csr([[index[8 * c + v] for v in f] for c in range(3) for f in CUBE_FACES])
    with pytest.raises(ValueError, match=r"cell \d: point \d+ lies on its boundary face \d+ .* not conforming"):
        PolyhedronMesh.from_cell_faces(points, [0, 6, 12, 18], fo, fv)


def test_from_cell_faces_refuses_a_scrambled_shared_face():
    mesh = grid("hexahedron", n=(2, 1, 1), lengths=(2.0, 1.0, 1.0))
    faces = []
    for c in range(2):
        points, local = mesh.polyhedron(c)
        vertices = np.unique(np.concatenate([mesh.face(f) for f in mesh.cell_face_indices(c)]))
        faces += [vertices[f] for f in local]
    shared = next(k for k in range(6, 12) if set(faces[k].tolist()) in [set(f.tolist()) for f in faces[:6]])
    faces[shared] = faces[shared][[0, 2, 1, 3]]
    fo, fv = csr(faces)
    with pytest.raises(ValueError, match=r"cell 1: its face with vertices .* different cyclic order"):
        PolyhedronMesh.from_cell_faces(mesh.points, [0, 6, 12], fo, fv)


def test_bad_arrays_are_named():
    points, fo, fv, co, cf, signs = cubes([[0, 0, 0]])
    with pytest.raises(ValueError, match=r"face 1: point index 99 out of range \[0, 8\)"):
        PolyhedronMesh(points, fo, np.r_[fv[:4], 99, fv[5:]], co, cf, signs)
    with pytest.raises(ValueError, match=r"cell_face_signs must hold \+1 or -1"):
        PolyhedronMesh(points, fo, fv, co, cf, 2 * signs)
    with pytest.raises(ValueError, match=r"cell 0 has 5 faces, at least 4 needed|cell 0 is not closed"):
        PolyhedronMesh(points, fo[:6], fv[:20], [0, 5], np.arange(5), signs[:5])
    with pytest.raises(ValueError, match=r"region names \{'x': 3\} name tags that no cell has"):
        PolyhedronMesh(points, fo, fv, co, cf, signs, [1], {"x": 3})
