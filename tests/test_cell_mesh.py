"""CellMesh: validation, facets and their orientation on tiny meshes (exact answers)."""
import numpy as np
import pytest

from dolfinx_sfvem.mesh.cell_mesh import CellMesh, facet_normals

def divergence_checks(mesh, facets, volume):
    """Σ N dA = 0 and ⅓ Σ x·N dA = volume on a closed surface of outward normals."""
    N = facet_normals(mesh.points, facets)
    centre = mesh.points[facets].mean(axis=1)
    assert np.allclose(N.sum(axis=0), 0.0, atol=1e-13)
    assert np.einsum("ij,ij->", centre, N) / mesh.gdim == pytest.approx(volume, rel=1e-13)


def test_six_tetrahedra_fill_the_cube_with_outward_facets(tiny3d):
    mesh = CellMesh(tiny3d.CUBE, tiny3d.kuhn_tets(), np.ones(6), "tetrahedron")
    assert mesh.volumes == pytest.approx(np.full(6, 1 / 6), rel=1e-14)     # left-handed ones reordered
    facets, cell, neighbour = mesh.boundary_facets()
    assert facets.shape == (12, 3) and np.all(neighbour == -1)            # two triangles per face
    divergence_checks(mesh, facets, 1.0)
    assert mesh.edges().shape[0] == 19                                    # 12 + 6 face diagonals + 1


def test_one_hexahedron(tiny3d):
    mesh = CellMesh(tiny3d.CUBE * [2.0, 1.0, 0.5], [np.arange(8)], [7], "hexahedron")
    facets, cell, neighbour = mesh.boundary_facets()
    assert facets.shape == (6, 4)
    divergence_checks(mesh, facets, 1.0)
    # cyclic order: (a, c) is a diagonal, so a and c differ in two coordinates
    x = mesh.points[facets]
    assert np.all((np.abs(x[:, 0] - x[:, 2]) > 0).sum(axis=1) == 2)


def test_hexahedra_with_two_regions_interface_and_surfaces(tiny3d):
    points, cells = tiny3d.hex_grid(2)
    tags = np.where(points[cells].mean(axis=1)[:, 0] < 0.5, 1, 2)
    mesh = CellMesh(points, cells, tags, "hexahedron", {"solid": 1, "medium": 2})
    facets, cell, neighbour = mesh.boundary_facets()
    assert facets.shape[0] == 6 * 4 + 4 and (neighbour >= 0).sum() == 4     # 24 outer, 4 on x = 0.5
    interface = neighbour >= 0
    assert np.all(mesh.tags[cell[interface]] == 1) and np.all(mesh.tags[neighbour[interface]] == 2)
    assert np.allclose(facet_normals(mesh.points, facets[interface]), [0.25, 0.0, 0.0])   # out of the solid
    for tag in (1, 2):
        surface, inside, _ = mesh.region_surface([tag])
        assert surface.shape[0] == 4 * 4 and np.all(mesh.tags[inside] == tag)
        divergence_checks(mesh, surface, 0.5)
    divergence_checks(mesh, facets[~interface], 1.0)


def test_triangles_and_quadrilaterals():
    square = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    tri = CellMesh(square, [[0, 1, 3], [0, 3, 2]], [1, 1], "triangle")      # the second one clockwise
    assert tri.volumes == pytest.approx([0.5, 0.5])
    divergence_checks(tri, tri.boundary_facets()[0], 1.0)
    quad = CellMesh(np.c_[square, np.zeros(4)], [[0, 1, 2, 3]], [1], "quadrilateral")
    assert quad.gdim == 2 and quad.boundary_facets()[0].shape == (4, 2)


def test_invalid_cells_are_named(tiny3d):
    CUBE = tiny3d.CUBE
    with pytest.raises(ValueError, match="tetrahedron 1 .* zero volume"):
        flat = np.vstack([CUBE, [[0.5, 0.5, 0.0]]])
        CellMesh(flat, [[0, 1, 2, 4], [0, 1, 3, 8]], [1, 1], "tetrahedron")     # 0, 1, 3, 8 all on z = 0
    tangled = CUBE.copy()
    tangled[7] = [0.2, 0.2, 0.2]                     # past the centre: the determinant turns at vertex 7
    with pytest.raises(ValueError, match="hexahedron 0 .* inverted or degenerate: .* at its vertex 7"):
        CellMesh(tangled, [np.arange(8)], [1], "hexahedron")
    with pytest.raises(ValueError, match="not conforming"):
        CellMesh(CUBE, [[0, 1, 2, 4], [0, 2, 1, 7], [0, 1, 2, 6]], [1, 1, 1], "tetrahedron")
    with pytest.raises(ValueError, match="outside"):
        CellMesh(CUBE, [[0, 1, 2, 9]], [1], "tetrahedron")
    with pytest.raises(ValueError, match="cell type"):
        CellMesh(CUBE, [[0, 1, 2, 3]], [1], "prism")


def test_hexahedron_that_is_not_a_parallelepiped_is_taken(tiny3d):
    skew = tiny3d.CUBE.copy()
    skew[7] += [0.0, 0.0, 0.2]                       # top face z = 1 + 0.2 x y: non-planar
    mesh = CellMesh(skew, [np.arange(8)], [1], "hexahedron")
    assert mesh.volumes == pytest.approx([1.05], rel=1e-14)
    divergence_checks(mesh, mesh.boundary_facets()[0], 1.05)


def test_mirrored_hexahedron_is_reordered(tiny3d):
    mesh = CellMesh(tiny3d.CUBE, [[0, 2, 1, 3, 4, 6, 5, 7]], [1], "hexahedron")     # x and y swapped: left-handed
    assert mesh.volumes == pytest.approx([1.0])
    divergence_checks(mesh, mesh.boundary_facets()[0], 1.0)


def test_from_dolfinx_box():
    import dolfinx.mesh
    from mpi4py import MPI
    from dolfinx_sfvem import _compat
    box = dolfinx.mesh.create_box(MPI.COMM_WORLD, [[0.0, 0.0, 0.0], [2.0, 1.0, 1.0]], [2, 1, 1],
                                  dolfinx.mesh.CellType.tetrahedron)
    n = _compat.num_owned_cells(box) + box.topology.index_map(3).num_ghosts
    midpoint = _compat.cell_geometry_nodes(box)
    tags = np.where(box.geometry.x[midpoint].mean(axis=1)[:, 0] < 1.0, 1, 2).astype(np.int32)
    mesh = CellMesh.from_dolfinx(box, _compat.create_cell_tags(box, tags[:n]), {"left": 1})
    assert mesh.n_cells == 12 and mesh.n_points == 12 and mesh.gdim == 3
    assert mesh.volumes.sum() == pytest.approx(2.0) and np.all(mesh.volumes > 0)
    assert np.bincount(mesh.tags)[1:].tolist() == [6, 6]
    facets, _, neighbour = mesh.boundary_facets()
    divergence_checks(mesh, facets[neighbour < 0], 2.0)
