"""3D meshes (dolfinx_sfvem.meshes: extrude, cbox3d, hertz3d, thick_sphere, pneunet3d): cell volumes
computed here (all positive, region volumes exact or to the meshing tolerance of curved surfaces),
conformity (every facet in at most two cells, the boundary's area that of the outer surface), the
named points and surfaces selecting the right nodes, and the same mesh on every rank."""
from __future__ import annotations

import hashlib
import math

import numpy as np
import pytest
from mpi4py import MPI                  # before dolfinx: loads the MPI library of the 0.11 wheel

import dolfinx
import dolfinx.io
import ufl

from dolfinx_sfvem import _compat, meshes
from dolfinx_sfvem.meshes import MEDIUM, SOLID

#: the tetrahedra of a hexahedron in tensor-product order (any split gives its volume)
_HEX_TETS = [[0, 1, 3, 7], [0, 1, 5, 7], [0, 4, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 6, 7]]
_TET_FACES = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]
_HEX_FACES = [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]]


def signed_volumes(points, tets):
    p = points[tets]
    return np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6


def cell_volumes(mesh):
    """Volumes of the cells; hexahedra checked to be parallelepipeds with a positive Jacobian."""
    if mesh.cell_type == "tetrahedron":
        return signed_volumes(mesh.points, mesh.cells)
    p = mesh.points[mesh.cells]
    assert np.abs(p[:, 0] + p[:, 3] - p[:, 1] - p[:, 2]).max() < 1e-12     # faces are parallelograms
    assert np.abs(p[:, 0] + p[:, 7] - p[:, 3] - p[:, 4]).max() < 1e-12     # parallelepiped
    jacobian = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 4] - p[:, 0])
    parts = sum(np.abs(signed_volumes(mesh.points, mesh.cells[:, t])) for t in _HEX_TETS)
    assert np.allclose(parts, jacobian, rtol=1e-12)
    return jacobian


def region_volumes(mesh):
    volumes = cell_volumes(mesh)
    assert volumes.min() > 0, "a cell with non-positive volume"
    return {int(t): float(volumes[mesh.tags == t].sum()) for t in np.unique(mesh.tags)}


def boundary_faces(mesh):
    """Faces (f, 3|4) in exactly one cell; asserts no face is in more than two (conforming)."""
    local = _TET_FACES if mesh.cell_type == "tetrahedron" else _HEX_FACES
    faces = mesh.cells[:, local].reshape(-1, len(local[0]))
    _, first, counts = np.unique(np.sort(faces, axis=1), axis=0, return_index=True, return_counts=True)
    assert counts.max() <= 2
    return faces[first[counts == 1]]


def face_areas(points, faces):
    p = points[faces]
    if faces.shape[1] == 3:
        return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    return np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 3] - p[:, 0]), axis=1)   # parallelograms


# --------------------------------------------------------------------------- extrude
def test_extrude_of_a_quad_grid_has_the_expected_counts_volume_and_tags():
    mesh2d = meshes.cbox_grid(h_solid=0.1)
    n_quads, n_points = mesh2d.mesh.n_polygons, mesh2d.mesh.n_points
    mesh = meshes.extrude(mesh2d.mesh, depth=0.25, layers=3)
    assert mesh.cell_type == "hexahedron" and mesh.cells.shape == (3 * n_quads, 8)
    assert mesh.points.shape == (4 * n_points, 3)
    assert sum(region_volumes(mesh).values()) == pytest.approx(mesh2d.mesh.areas.sum() * 0.25, rel=1e-13)
    assert np.array_equal(mesh.tags, np.tile(mesh2d.mesh.tags, 3))
    assert mesh.region_names == {"solid": SOLID, "medium": MEDIUM}
    for tag in (SOLID, MEDIUM):
        area = mesh2d.mesh.areas[mesh2d.mesh.tags == tag].sum()
        assert region_volumes(mesh)[tag] == pytest.approx(0.25 * area, rel=1e-13)
    assert np.array_equal(mesh.points[n_points:2 * n_points, :2], mesh2d.mesh.points)   # point p + n * level
    assert np.allclose(mesh.points[n_points:2 * n_points, 2], 0.25 / 3)
    outer = 2 * mesh2d.mesh.areas.sum() + 0.25 * 2 * (1.1 + 0.5)
    assert face_areas(mesh.points, boundary_faces(mesh)).sum() == pytest.approx(outer, rel=1e-12)


def test_extrude_refuses_other_polygons_hanging_nodes_and_non_convex_quadrilaterals():
    with pytest.raises(ValueError, match="hanging node|vertices"):
        meshes.extrude(meshes.quads_with_hanging_nodes(1.0, 1.0, 4), 1.0, 1)
    with pytest.raises(ValueError, match="vertices"):
        meshes.extrude(meshes.polygon_rectangle(1.0, 1.0, 0.3), 1.0, 1)
    trapezoid = meshes.glue(([(0, 0), (2, 0), (1.5, 1), (0.5, 1)], [[0, 1, 2, 3]], [SOLID]))
    assert meshes.extrude(trapezoid, 1.0, 2).volumes == pytest.approx([0.75, 0.75], rel=1e-14)   # non-affine
    dart = meshes.glue(([(0, 0), (2, 0), (0.5, 0.5), (0, 2)], [[0, 1, 2, 3]], [SOLID]))
    with pytest.raises(ValueError, match="polygon 0 is not strictly convex"):
        meshes.extrude(dart, 1.0, 1)
    with pytest.raises(ValueError, match="layers"):
        meshes.extrude(meshes.quad_rectangle(1.0, 1.0, 2, 2), 1.0, 0)


# --------------------------------------------------------------------------- from gmsh
def _two_boxes(path, hexahedra: bool):
    """Write two unit boxes side by side (physical groups "left" 7 and "right" 8) to ``path`` as
    second-order tetrahedra, or as hexahedra (transfinite, recombined)."""
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        left, right = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1), gmsh.model.occ.addBox(1, 0, 0, 1, 1, 1)
        gmsh.model.occ.fragment([(3, left)], [(3, right)])
        gmsh.model.occ.synchronize()
        for name, tag, volume in (("left", 7, left), ("right", 8, right)):
            gmsh.model.setPhysicalName(3, gmsh.model.addPhysicalGroup(3, [volume], tag), name)
        if hexahedra:
            for dim in (1, 2, 3):
                for _, entity in gmsh.model.getEntities(dim):
                    {1: lambda e: gmsh.model.mesh.setTransfiniteCurve(e, 3),
                     2: gmsh.model.mesh.setTransfiniteSurface, 3: gmsh.model.mesh.setTransfiniteVolume}[dim](entity)
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
        else:
            gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
        gmsh.model.mesh.generate(3)
        if not hexahedra:
            gmsh.model.mesh.setOrder(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


@pytest.mark.parametrize("hexahedra", [False, True])
def test_from_gmsh_3d_reads_the_volume_cells_of_the_physical_groups(tmp_path, hexahedra):
    _two_boxes(tmp_path / "boxes.msh", hexahedra)
    mesh = meshes.from_gmsh_3d(tmp_path / "boxes.msh")
    assert mesh.cell_type == ("hexahedron" if hexahedra else "tetrahedron")
    assert mesh.region_names == {"left": 7, "right": 8}
    assert region_volumes(mesh) == pytest.approx({7: 1.0, 8: 1.0}, rel=1e-12)   # positive cells, parallelepipeds
    if hexahedra:
        assert len(mesh.cells) == 2 * 2 ** 3 and len(mesh.points) == 5 * 3 * 3
    assert face_areas(mesh.points, boundary_faces(mesh)).sum() == pytest.approx(10.0, rel=1e-12)
    renamed = meshes.from_gmsh_3d(tmp_path / "boxes.msh", {"right": SOLID})
    assert renamed.region_names == {"right": SOLID} and np.all(renamed.tags == SOLID)
    with pytest.raises(ValueError, match="middle"):
        meshes.from_gmsh_3d(tmp_path / "boxes.msh", {"middle": 3})


# --------------------------------------------------------------------------- C-box
@pytest.mark.parametrize("cell", ["hexahedron", "tetrahedron"])
def test_cbox3d_regions_conformity_and_markers(cell):
    bench = meshes.cbox3d(n=(20, 2, 7), cell=cell)
    mesh = bench.mesh
    assert mesh.cell_type == cell and len(mesh.cells) == 20 * 2 * 7 * (1 if cell == "hexahedron" else 6)
    volumes = region_volumes(mesh)
    medium = 1.9 * 0.5 * 0.7
    assert volumes == pytest.approx({SOLID: 2 * 0.7 * 0.7 - medium, MEDIUM: medium}, rel=1e-12)
    assert face_areas(mesh.points, boundary_faces(mesh)).sum() == pytest.approx(2 * (2 * 0.7 * 2 + 0.7 * 0.7),
                                                                               rel=1e-12)
    clamp = bench.vertices_on("clamp")
    assert len(clamp) == 3 * 8 and np.all(mesh.points[clamp, 0] == 0.0)
    assert np.array_equal(mesh.points[bench.vertex("load")], [2.0, 0.0, 0.7])
    nodes = bench.nodes_on("clamp")
    # Q2 and P2: (2 ny + 1)(2 nz + 1) nodes on x = 0; tetrahedra also the centroids of the 2 triangles per
    # grid face (the SFVEM's face-mean nodes), which are no P2 nodes
    assert len(nodes) == 5 * 15 + (0 if cell == "hexahedron" else 2 * 2 * 7)
    assert np.all(nodes[:, 0] == 0.0)
    marker = bench.marker("clamp")
    assert marker(nodes.T).all()
    assert not marker(np.array([[0.05, 0.0, 0.0], [0.0, 0.0, 0.05 / 2]]).T).any()   # off the face; off the grid


def test_cbox3d_with_h_is_dolfinys_grid_and_refuses_grids_off_the_walls():
    mesh = meshes.cbox3d(h=0.05).mesh
    assert len(mesh.cells) == 40 * 14 * 14 and len(mesh.points) == 41 * 15 * 15
    assert np.allclose(mesh.points, meshes.cbox3d().mesh.points, rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="grid line"):
        meshes.cbox3d(n=(8, 2, 4))
    with pytest.raises(ValueError, match="not both"):
        meshes.cbox3d(n=(20, 2, 7), h=0.1)


def test_cbox3d_tip_refinement_halves_the_cells_under_the_corner_only():
    """k = 2: the grid intervals in x >= 1.6 and y <= 0.35 halved (4 + 2 more grid planes on
    (20, 4, 7)), the regions' volumes unchanged, the cells elsewhere as before."""
    coarse, fine = meshes.cbox3d(n=(20, 4, 7)).mesh, meshes.cbox3d(n=(20, 4, 7), tip_refinement=2).mesh
    assert len(fine.cells) == 24 * 6 * 7
    assert region_volumes(fine) == pytest.approx(region_volumes(coarse), rel=1e-12)
    xs, ys = np.unique(fine.points[:, 0]), np.unique(fine.points[:, 1])
    assert np.allclose(np.diff(xs), np.where(xs[:-1] >= 1.6 - 1e-12, 0.05, 0.1))
    assert np.allclose(np.diff(ys), np.where(ys[:-1] < 0.35 - 1e-12, 0.0875, 0.175))
    with pytest.raises(ValueError, match="tip_refinement"):
        meshes.cbox3d(n=(20, 4, 7), tip_refinement=0)


# --------------------------------------------------------------------------- Hertz
def test_hertz3d_regions_markers_and_size_field():
    bench = meshes.hertz3d(h_contact=0.2, h_far=0.5)
    mesh = bench.mesh
    assert mesh.cell_type == "tetrahedron"
    volumes = region_volumes(mesh)
    quarter_hemisphere = math.pi / 6
    assert volumes[SOLID] == pytest.approx(4.0, rel=1e-12)                        # flat faces: exact
    assert volumes[meshes.SPHERE] == pytest.approx(quarter_hemisphere, rel=0.05)  # chords inside the sphere
    assert volumes[MEDIUM] + volumes[meshes.SPHERE] == pytest.approx(4 * 1.1, rel=1e-12)
    x = mesh.points
    top = bench.vertices_on("sphere_top")
    assert np.allclose(x[top, 2], 2.1) and np.all(np.hypot(x[top, 0], x[top, 1]) <= 1 + 1e-9)
    sphere_cells = mesh.cells[mesh.tags == meshes.SPHERE]
    on_top = np.unique(sphere_cells[np.isclose(x[sphere_cells, 2], 2.1).all(axis=1)])
    assert set(on_top) <= set(top) and set(top) <= set(np.unique(sphere_cells))
    on_sphere = bench.vertices_on("sphere")
    assert np.allclose(np.linalg.norm(x[on_sphere] - [0, 0, 2.1], axis=1), 1.0, atol=1e-9)
    assert bench.vertex("sphere_tip") in on_sphere
    assert np.all(x[bench.vertices_on("symmetry_x"), 0] == 0.0) and np.all(x[bench.vertices_on("bottom"), 2] == 0)
    # finer near the contact: the edges there are shorter than far away
    edges = mesh.cells[:, [0, 1]]
    length = np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1)
    near = np.linalg.norm(x[edges[:, 0]] - [0, 0, 1.05], axis=1) < 0.5
    assert length[near].mean() < 0.6 * length[~near].mean()


def edge_lengths_about(mesh, centre, radius):
    """Lengths of the cells' first edges whose first vertex lies within / beyond ``radius`` of ``centre``."""
    x = mesh.points
    edges = mesh.cells[:, [0, 1]]
    length = np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1)
    near = np.linalg.norm(x[edges[:, 0]] - centre, axis=1) < radius
    return length[near], length[~near]


def test_hertz3d_core_refines_only_about_the_contact_point():
    """h_core: edges within core_radius of the contact point about h_core long (tetrahedra of a
    size field have edges about its size), the mesh beyond the growth shell as without it."""
    plain = meshes.hertz3d(h_contact=0.2, h_far=0.5, fine_radius=0.4).mesh
    cored = meshes.hertz3d(h_contact=0.2, h_far=0.5, fine_radius=0.4, h_core=0.05, core_radius=0.2).mesh
    centre = [0.0, 0.0, 1.05]
    near_plain, _ = edge_lengths_about(plain, centre, 0.15)
    near_cored, _ = edge_lengths_about(cored, centre, 0.15)
    assert 0.6 * 0.05 < np.median(near_cored) < 1.5 * 0.05 < 0.5 * np.median(near_plain)
    _, far_plain = edge_lengths_about(plain, centre, 1.2)
    _, far_cored = edge_lengths_about(cored, centre, 1.2)
    assert np.median(far_cored) == pytest.approx(np.median(far_plain), rel=0.15)
    assert region_volumes(cored)[SOLID] == pytest.approx(4.0, rel=1e-12)
    with pytest.raises(ValueError, match="h_core"):
        meshes.hertz3d(h_contact=0.2, h_core=0.2)


# --------------------------------------------------------------------------- thick sphere
@pytest.mark.parametrize("filled", [False, True])
def test_thick_sphere_volumes_surfaces_and_boundary(filled):
    a, b = 1.0, 2.0
    bench = meshes.thick_sphere(a, b, h=0.5, filled=filled)
    mesh = bench.mesh
    volumes = region_volumes(mesh)
    assert volumes[SOLID] == pytest.approx(math.pi / 6 * (b ** 3 - a ** 3), rel=0.05)
    if filled:
        assert volumes[MEDIUM] == pytest.approx(math.pi / 6 * a ** 3, rel=0.08)
        assert bench.regions == {"solid": SOLID, "cavity": MEDIUM}
    inner = bench.vertices_on("inner")
    assert np.allclose(np.linalg.norm(mesh.points[inner], axis=1), a, atol=1e-9) and len(inner) > 10
    # every vertex of the outer boundary lies on one of the named surfaces (the vertices on the spheres)
    boundary = np.unique(boundary_faces(mesh))
    named = np.unique(np.concatenate([bench.vertices_on(name) for name in bench.surfaces]))
    assert set(boundary) <= set(named)
    # the inner surface's nodes: its vertices, the midpoints of the edges between them (inside by the sagitta)
    # and the centroids of the faces between them (the SFVEM's face means: deeper inside, on the flat faces)
    nodes = bench.nodes_on("inner")
    radius = np.linalg.norm(nodes, axis=1)
    assert np.all(radius <= a + 1e-9) and np.all(radius > a - 0.5 ** 2 / (6 * a) - 1e-9)
    faces = np.unique(np.sort(mesh.cells[:, _TET_FACES].reshape(-1, 3), axis=1), axis=0)   # boundary or interface
    inner_faces = faces[np.isin(faces, inner).all(axis=1)]
    assert len(nodes) == len(inner) + len(inner_faces) + len(np.unique(np.sort(
        inner_faces[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1), axis=0))
    for name in bench.points:
        bench.vertex(name)


def test_thick_sphere_is_deterministic():
    first, second = meshes.thick_sphere(h=0.6).mesh, meshes.thick_sphere(h=0.6).mesh
    assert np.array_equal(first.points, second.points) and np.array_equal(first.cells, second.cells)


# --------------------------------------------------------------------------- PneuNet
@pytest.mark.parametrize("half", [True, False])
def test_pneunet3d_region_volumes_and_markers(half):
    g = meshes.PneuNet3D()
    n = 3
    bench = meshes.pneunet3d(h=2.0, n_chambers=n, half=half)
    mesh = bench.mesh
    volumes = region_volumes(mesh)
    width = g.width / 2 if half else g.width
    L = n * (g.length + g.spacing) - g.spacing
    cavity = (g.length - 2 * g.sidewall) * (g.height - 2 * g.wall) * (width - (1 if half else 2) * g.side)
    gaps = (n - 1) * g.spacing * (g.height - g.wall) * width
    base = L * width * g.base
    expected = {meshes.BASE_LAYER: base, MEDIUM: gaps,
                **{meshes.FIRST_CHAMBER + i: cavity for i in range(n)},
                SOLID: L * width * (g.base + g.height) - base - gaps - n * cavity}
    assert volumes == pytest.approx(expected, rel=1e-12)
    assert set(bench.regions.values()) == set(expected)
    assert ("symmetry" in bench.surfaces) == half
    assert np.all(mesh.points[bench.vertices_on("clamp"), 0] == 0.0)
    for name in bench.points:
        bench.vertex(name)


# --------------------------------------------------------------------------- into DOLFINx
#: DOLFINx's (tensor-product) vertex order -> VTK's, which XDMF files use
_VTK_ORDER = {"hexahedron": [0, 1, 3, 2, 4, 5, 7, 6], "tetrahedron": [0, 1, 2, 3]}


def read_by_dolfinx(mesh, path):
    """The mesh written as an XDMF file with inline (XML) data, cells in VTK's vertex order, and read
    by DOLFINx's XDMF reader, which puts them back into its own order."""
    with dolfinx.io.XDMFFile(MPI.COMM_WORLD, str(path), "w") as file:   # the HDF5 file the reader opens
        file.write_mesh(dolfinx.mesh.create_unit_cube(MPI.COMM_WORLD, 1, 1, 1))
    cells = mesh.cells[:, _VTK_ORDER[mesh.cell_type]]
    n, k = cells.shape
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(
            f'<?xml version="1.0"?><Xdmf Version="3.0"><Domain><Grid Name="mesh" GridType="Uniform">'
            f'<Topology TopologyType="{mesh.cell_type.capitalize()}" NumberOfElements="{n}" NodesPerElement="{k}">'
            f'<DataItem Dimensions="{n} {k}" NumberType="Int" Format="XML">{" ".join(map(str, cells.ravel()))}'
            f'</DataItem></Topology><Geometry GeometryType="XYZ"><DataItem Dimensions="{len(mesh.points)} 3" '
            f'Format="XML">{" ".join(format(v, ".17g") for v in mesh.points.ravel())}</DataItem></Geometry>'
            f'</Grid></Domain></Xdmf>')
    MPI.COMM_WORLD.barrier()
    with dolfinx.io.XDMFFile(MPI.COMM_WORLD, str(path), "r") as file:
        return file.read_mesh(name="mesh")


def degree2_unknowns(mesh):
    """3 x (vertices + edges, + faces + cells for hexahedra) of a conforming mesh."""
    local = {"tetrahedron": [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]],
             "hexahedron": [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6],
                            [3, 7]]}[mesh.cell_type]
    n = len(mesh.points) + len(np.unique(np.sort(mesh.cells[:, local].reshape(-1, 2), axis=1), axis=0))
    if mesh.cell_type == "hexahedron":
        n += len(np.unique(np.sort(mesh.cells[:, _HEX_FACES].reshape(-1, 4), axis=1), axis=0)) + len(mesh.cells)
    return 3 * n


@pytest.mark.mpi
@pytest.mark.parametrize("make", [lambda: meshes.cbox3d(n=(20, 2, 7)).mesh,
                                  lambda: meshes.cbox3d(n=(20, 2, 7), cell="tetrahedron").mesh,
                                  lambda: meshes.pneunet3d(n_chambers=2).mesh,
                                  lambda: meshes.hertz3d(h_contact=0.25, h_far=0.6).mesh,
                                  lambda: meshes.extrude(meshes.cbox_grid(h_solid=0.1).mesh, 0.1, 2)],
                         ids=["cbox-hex", "cbox-tet", "pneunet", "hertz", "extrude"])
def test_meshes_load_into_dolfinx_with_their_region_volumes_and_degree2_unknowns(make, tmp_path_factory):
    mesh = make()
    path = MPI.COMM_WORLD.bcast(tmp_path_factory.mktemp("xdmf") if MPI.COMM_WORLD.rank == 0 else None)
    domain = read_by_dolfinx(mesh, path / "mesh.xdmf")
    tags = _compat.create_cell_tags(domain, mesh.tags[_compat.original_cell_index(domain)].astype(np.int32))
    dx = ufl.Measure("dx", domain=domain, subdomain_data=tags)
    for tag, volume in region_volumes(mesh).items():
        value = MPI.COMM_WORLD.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(1.0 * dx(tag))), op=MPI.SUM)
        assert value == pytest.approx(volume, rel=1e-12)
    V = _compat.vector_function_space(domain, 2)
    assert V.dofmap.index_map.size_global * V.dofmap.index_map_bs == degree2_unknowns(mesh)


# --------------------------------------------------------------------------- parallel
@pytest.mark.mpi
def test_gmsh_meshes_are_the_same_on_every_rank():
    comm = MPI.COMM_WORLD
    mesh = meshes.hertz3d(h_contact=0.25, h_far=0.6).mesh
    digests = comm.allgather(hashlib.sha256(mesh.points.tobytes() + mesh.cells.tobytes()).hexdigest())
    assert len(set(digests)) == 1
