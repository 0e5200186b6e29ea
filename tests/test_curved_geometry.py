"""Curved (degree-2) geometry: the FEM's second gradient on curved cells against exact Hessians,
a homogeneous stretch exact on them (from a CellMesh and from a DOLFINx mesh), gmsh's second order
read, curved faces' areas and volumes against the exact sphere, the surface the contact checks
sample, the SFVEM's one-line note, curved cells that cannot be used named, and nearly tangled ones
warned of."""
import math

import numpy as np
import pytest
import ufl
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem import _compat
from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization
from dolfinx_sfvem.mesh.cell_mesh import CellMesh, reference_nodes
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh
from dolfinx_sfvem.meshing.hexahedra import box_grid
from dolfinx_sfvem.meshing.second_order import second_order
from dolfinx_sfvem.physics.solid_surface import SolidSurface

K, MU, STRETCH = 5 / 3, 5 / 14, 0.1
A, B = 1.0, 2.0


def warp(lengths):
    """A smooth map of the box [0, lengths] onto itself that moves its inside (zero on the faces):
    the cells' inner edges curve."""
    lengths = np.asarray(lengths, dtype=float)

    def place(x: np.ndarray) -> np.ndarray:
        bump = np.prod(np.sin(np.pi * x / lengths), axis=1)
        return x + 0.15 * bump[:, None] * np.array([1.0, -0.5, 0.7]) * lengths.min()
    return place


def curved_box(n: int, cell: str, lengths=(1.0, 1.0, 1.0)) -> CellMesh:
    """The box [0, lengths] in n cells per unit length, degree-2 geometry warped inside."""
    lines = [np.linspace(0.0, length, max(1, round(n * length)) + 1) for length in lengths]
    straight = box_grid(*lines, lambda x, y, z: np.ones_like(x), {"solid": 1}, cell)
    return second_order(straight, warp(lengths))


def edge_node_offsets(mesh: CellMesh) -> np.ndarray:
    """Distance of every edge node from its edge's chord midpoint (how curved the cells are)."""
    edges = mesh.edges()
    return np.linalg.norm(mesh.edge_midpoints(edges[:, 0], edges[:, 1]) - mesh.points[edges].mean(axis=1), axis=1)


def half_GG_energy(mesh: CellMesh, field) -> float:
    """½ ∫ G:G of the P2/Q2 interpolant of ``field`` on ``mesh`` (the FEM's energy form)."""
    energy = sf.UserEnergy(lambda F, G: ufl.inner(G, G) / 2, name="half_GG")
    disc = LagrangeDiscretization.from_cell_mesh(mesh, {1: energy}, MPI.COMM_WORLD, verbose=False,
                                                 quadrature_degree=6)
    u, b = disc.create_vector(), disc.create_vector()
    with u.localForm() as ul:
        ul.array[:] = field(disc.x_nodes).ravel()
    value = disc.residual(u, b).energy
    u.destroy()
    b.destroy()
    return value


@pytest.mark.parametrize("cell", ["tetrahedron", "hexahedron"])
def test_second_gradient_on_curved_cells(cell):
    """The coordinate field x is in the isoparametric space of curved cells and has no second
    gradient (zero to round-off only with the inverse Jacobian's derivative, which UFL takes);
    u = (x², y z, x y / 2), whose G:G is 6.5 everywhere, is interpolated, and ½ ∫ G:G over the unit
    cube converges to 3.25 (at order 2 in h)."""
    meshes = [curved_box(n, cell) for n in (2, 4)]
    for mesh in meshes:
        assert mesh.geometry_degree == 2 and edge_node_offsets(mesh).max() > 0.01
        assert mesh.volumes.sum() == pytest.approx(1.0, rel=1e-12)
        assert abs(half_GG_energy(mesh, lambda x: x @ np.arange(1.0, 10.0).reshape(3, 3))) < 1e-20
    errors = [abs(half_GG_energy(mesh, lambda x: np.c_[x[:, 0] ** 2, x[:, 1] * x[:, 2], 0.5 * x[:, 0] * x[:, 1]])
                  - 3.25) for mesh in meshes]
    assert errors[1] < errors[0] / 3.5 and errors[1] < 0.25


def bar_problem(mesh, method="fem") -> sf.ContactProblem:
    problem = sf.ContactProblem(mesh, {1: sf.Hyperelastic(K=K, mu=MU)}, method=method, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), components="x", name="x0")
    problem.fix(lambda x: np.isclose(x[1], 0.0), components="y", name="y0")
    problem.fix(lambda x: np.isclose(x[2], 0.0), components="z", name="z0")
    problem.prescribe(lambda x: np.isclose(x[0], 2.0), ux=2.0 * STRETCH, name="pull")
    return problem


@pytest.mark.parametrize("given", ["cell mesh", "dolfinx mesh"])
def test_uniaxial_stretch_is_exact_on_curved_tetrahedra(given, by_hand):
    """A linear field is in the isoparametric P2 space: the homogeneous stretch of a bar of curved
    tetrahedra is exact (reaction, displacements inside cells), given as a CellMesh or as a DOLFINx
    mesh of degree-2 geometry with its cell tags."""
    mesh = curved_box(2, "tetrahedron", (2.0, 1.0, 1.0))
    if given == "dolfinx mesh":
        dmesh = _compat.create_mesh_partitioned(MPI.COMM_WORLD, mesh.nodes if MPI.COMM_WORLD.rank == 0 else
                                                np.empty((0, 10), np.int64), mesh.node_points, cell="tetrahedron")
        tags = _compat.create_cell_tags(dmesh, np.ones(dmesh.topology.index_map(3).size_local
                                                       + dmesh.topology.index_map(3).num_ghosts, dtype=np.int32))
        mesh = (dmesh, tags)
    problem = bar_problem(mesh)
    assert problem.mesh.geometry_degree == 2 and problem.mesh.n_cells == 96
    assert problem.solve(steps=2).converged
    s, P11 = by_hand.uniaxial(K, MU, STRETCH)
    assert problem.reactions()["pull"] == pytest.approx([P11 * 1.0, 0.0, 0.0], abs=1e-10)
    X = np.array([[2.0, 1.0, 1.0], [1.1, 0.45, 0.3], [0.3, 0.8, 0.6]])
    assert problem.displacement_at(X) == pytest.approx(X * [STRETCH, s - 1, s - 1], abs=1e-10)


def test_sfvem_on_curved_cells_keeps_the_vertices_and_says_faces_are_flat(capsys, caplog):
    mesh = curved_box(2, "tetrahedron", (2.0, 1.0, 1.0))
    polyhedra = PolyhedronMesh.from_cell_mesh(mesh)
    assert np.array_equal(polyhedra.points, mesh.points) and polyhedra.n_cells == mesh.n_cells
    # the package's console handler prints it once set up (by an earlier problem), else it propagates
    said = capsys.readouterr().out + "".join(record.getMessage() for record in caplog.records)
    assert "curved (degree-2) tetrahedra; their vertices are kept and their faces taken flat" in said
    problem = bar_problem(mesh, method="vem")                # it runs: on the flat faces' polyhedra
    assert problem.solve(steps=1).converged


def test_curved_cells_that_cannot_be_used_are_named():
    nodes = reference_nodes("tetrahedron", 2)
    bent = nodes.copy()
    bent[9] = [0.5, 0.9, 0.9]                       # edge (0, 1)'s node pulled through the cell
    with pytest.raises(ValueError, match=r"tetrahedron 0 \(nodes .*\) is inverted or degenerate: .* at its "):
        CellMesh(bent, [np.arange(10)], [1], "tetrahedron")
    with pytest.raises(ValueError, match="cells must have 8 or 27 nodes each"):
        CellMesh(np.zeros((20, 3)), [np.arange(20)], [1], "hexahedron")
    mirrored = CellMesh(nodes, [[0, 2, 1, 3, 5, 4, 6, 7, 9, 8]], [1], "tetrahedron")
    assert np.array_equal(mirrored.nodes[0], np.arange(10)) and mirrored.volumes[0] == pytest.approx(1 / 6)


def test_nearly_tangled_curved_cells_are_named_in_a_warning(capsys, caplog):
    """Edge (0, 1)'s node moved by t (0, 1, 1): the determinant is 1 - 8 t at the node's worst
    point, zero at t = 1/8; at t = 0.12 the cell is valid with a ratio of 0.04 (warned), at 0.1
    0.2 (not)."""
    nodes = reference_nodes("tetrahedron", 2)
    for t, warned in ((0.12, True), (0.1, False)):
        bent = nodes.copy()
        bent[9] += t * np.array([0.0, 1.0, 1.0])
        caplog.clear()
        capsys.readouterr()
        with caplog.at_level("WARNING", logger="dolfinx_sfvem.mesh.cell_mesh"):
            CellMesh(bent, [np.arange(10)], [1], "tetrahedron")
        # the package's console handler prints it once set up (by an earlier problem), else it propagates
        printed = capsys.readouterr()
        said = printed.out + printed.err + "".join(record.getMessage() for record in caplog.records)
        assert ("nearly tangled" in said) == warned, said
        if warned:
            assert "1 curved tetrahedron(s) nearly tangled" in said
            assert "tetrahedron 0 varies by a factor 25" in said


def shell_model(gmsh, h: float, order: int) -> None:
    """The 1/8 shell 1 < R < 2 meshed by gmsh at order ``order``, physical volume "wall", surfaces
    "inner" and "outer"."""
    occ = gmsh.model.occ
    outer, inner = (occ.addSphere(0, 0, 0, r, angle1=0.0, angle2=math.pi / 2, angle3=math.pi / 2) for r in (B, A))
    wall, _ = occ.cut([(3, outer)], [(3, inner)])
    occ.synchronize()
    gmsh.model.setPhysicalName(3, gmsh.model.addPhysicalGroup(3, [v for _, v in wall]), "wall")
    for name, r in (("inner", A), ("outer", B)):
        surfaces = [s for _, s in gmsh.model.getEntities(2)
                    if abs(np.linalg.norm(gmsh.model.occ.getCenterOfMass(2, s)) - r) < 0.5 * r
                    and gmsh.model.getType(2, s) == "Sphere"]
        gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, surfaces), name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.model.mesh.generate(3)
    gmsh.model.mesh.setOrder(order)


def test_read_gmsh_second_order_tetrahedra(tmp_path):
    """gmsh's 10-node tetrahedra are read with their curved geometry: the shell's volume far closer
    to the exact one than the same mesh's straight cells; the named surfaces kept."""
    exact = math.pi / 6 * (B ** 3 - A ** 3)
    errors = {}
    for order in (1, 2):
        with sf.meshes.gmsh_session() as gmsh:
            shell_model(gmsh, 0.5, order)
            gmsh.write(str(tmp_path / f"shell{order}.msh"))
        mesh = sf.meshes.read_gmsh(tmp_path / f"shell{order}.msh")
        assert mesh.geometry_degree == order and mesh.nodes.shape[1] == (4, 10)[order - 1]
        assert sorted(mesh.boundary_names) == ["inner", "outer"] and mesh.region_names == {"wall": 1}
        radius = np.linalg.norm(mesh.points[mesh.boundary_names["outer"]], axis=2)
        assert radius == pytest.approx(B, abs=1e-9)
        errors[order] = abs(mesh.volumes.sum() / exact - 1)
    assert errors[1] > 1e-3 and errors[2] < 2e-5


def test_named_curved_surface_holds_its_curved_edge_nodes():
    """A named surface of a gmsh order-2 model, given by name to fix and pressure, selects every
    node on it (vertices and the curved edge nodes, which lie off the flat faces through the
    vertices) and no other; its faces are those the radius selects."""
    from dolfinx_sfvem.physics.face_loads import loaded_facets
    with sf.meshes.gmsh_session() as gmsh:
        shell_model(gmsh, 0.5, 2)
        mesh = sf.meshes.read_gmsh(None)
    problem = sf.ContactProblem(mesh, {"wall": sf.Hyperelastic(K=K, mu=MU)}, method="fem", verbose=False)
    X = problem.disc.x_nodes
    on_sphere = np.flatnonzero(np.abs(np.linalg.norm(X, axis=1) - A) < 1e-9)
    bc = problem.fix("inner", name="inner")
    assert np.array_equal(problem.disc.locate_nodes(bc.marker), on_sphere)
    assert len(on_sphere) > 2 * len(np.unique(mesh.boundary_names["inner"]))       # edge nodes included
    by_name = loaded_facets(problem.disc, problem._where("inner", "p"), "p")
    by_radius = loaded_facets(problem.disc, lambda x: np.linalg.norm(x, axis=0) <= A + 1e-9, "p")
    assert np.array_equal(np.sort(by_name), np.sort(by_radius)) and len(by_name) > 0


def test_curved_faces_area_and_volume_against_the_sphere():
    """With degree-2 geometry the forms of the face loads integrate over the curved faces: the inner
    sphere's area (∫ ds over the faces a pressure loads) and the wall's volume are within 1e-4 of
    π a² / 2 and π (b³ - a³) / 6 (straight cells: 2 % and 0.5 % short), and closer on a finer mesh."""
    import dolfinx.fem
    from dolfinx_sfvem.physics.face_loads import loaded_facets
    area_error, volume_error = [], []
    for h, order in ((0.5, 1), (0.5, 2), (0.25, 2)):
        bench = sf.meshes.thick_sphere(A, B, h, order=order)
        problem = sf.ContactProblem(bench.mesh, {"solid": sf.Hyperelastic(K=K, mu=MU)}, method="fem", verbose=False)
        mesh = problem.disc.dolfinx_mesh
        facets = loaded_facets(problem.disc, lambda x: np.linalg.norm(x, axis=0) <= A + 1e-9, "p")
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=_compat.create_facet_tags(
            mesh, facets, np.ones(facets.size, dtype=np.int32)))
        area = MPI.COMM_WORLD.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(1.0 * ds(1))), op=MPI.SUM)
        volume = MPI.COMM_WORLD.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(1.0 * ufl.dx(domain=mesh))),
                                          op=MPI.SUM)
        area_error.append(area / (math.pi * A ** 2 / 2) - 1)
        volume_error.append(volume / (math.pi * (B ** 3 - A ** 3) / 6) - 1)
        assert volume == pytest.approx(bench.mesh.volumes.sum(), rel=1e-12)
    assert area_error[0] < -1e-2 and volume_error[0] < -3e-3
    assert abs(area_error[1]) < 1e-4 and abs(volume_error[1]) < 2e-5
    assert abs(area_error[2]) < abs(area_error[1]) and abs(volume_error[2]) < abs(volume_error[1])


def test_contact_surface_samples_the_curved_faces():
    """The contact checks' surface on curved tetrahedra: each face's 4 sub-triangles run through the
    curved edges' nodes (on the sphere), so the sampled surface is closer to the sphere than the flat
    one through the vertices alone."""
    bench = sf.meshes.thick_sphere(A, B, 0.5, order=2)
    straight = CellMesh(bench.mesh.points, bench.mesh.cells, bench.mesh.tags, "tetrahedron")
    gaps = {}
    for name, mesh in (("curved", bench.mesh), ("flat", straight)):
        problem = sf.ContactProblem(mesh, {1: sf.Hyperelastic(K=K, mu=MU)}, method="fem", verbose=False)
        surface = problem.boundary
        assert isinstance(surface, SolidSurface)
        centres = surface.X[surface.triangles].mean(axis=1)
        radius = np.linalg.norm(centres, axis=1)
        on_inner = np.linalg.norm(surface.X[surface.triangles], axis=2).max(axis=1) < A + 1e-6
        gaps[name] = np.abs(radius[on_inner] - A).max()
        on_sphere = np.abs(np.linalg.norm(surface.X, axis=1) - A) < 1e-9
        if name == "curved":
            assert on_sphere.sum() > np.isclose(np.linalg.norm(mesh.points, axis=1), A).sum()  # edge nodes too
    assert gaps["curved"] < gaps["flat"] / 3


def _pressurized_sphere(comm: MPI.Comm) -> tuple[sf.ContactProblem, list[float]]:
    """The 1/8 thick sphere of curved tetrahedra (h = 0.4) under a dead pressure of 1e-6 on R = a,
    solved on ``comm``; with its relative L2 and H1 errors against Lamé and the load's recorded
    work-conjugate displacement."""
    from dolfinx_sfvem import exact
    from dolfinx_sfvem.output.run_summary import RunSummary
    bench = sf.meshes.thick_sphere(A, B, 0.4, order=2)
    problem = sf.ContactProblem(bench.mesh, {"solid": sf.Hyperelastic(K=K, mu=MU)}, comm=comm, method="fem",
                                verbose=False)
    for axis in "xyz":
        problem.fix(bench.marker(f"symmetry_{axis}"), components=axis, name=f"symmetry_{axis}")
    problem.pressure(lambda x: np.linalg.norm(x, axis=0) <= A + 1e-9, 1e-6, follower=False, name="p")
    run = RunSummary.from_dict(problem.solve(steps=1).summary)
    assert run.converged
    u_exact, grad_exact = exact.radial_field(exact.lame_sphere(A, B, K, MU, 1e-6))
    zero = problem.disc.create_vector()
    zero.set(0.0)
    norms = [e / n for e, n in zip(problem.disc.error_norms(problem.x, u_exact, grad_exact),
                                   problem.disc.error_norms(zero, u_exact, grad_exact))]
    zero.destroy()
    return problem, norms + [run.final_step.loads["p"]["displacement"]]


@pytest.mark.mpi
def test_curved_thick_sphere_on_all_ranks_agrees_with_one():
    """The thick sphere of curved tetrahedra distributed over the ranks (2 under mpirun) gives the
    one-rank answer: displacements at points inside curved cells near the inner sphere, the pressure's
    recorded conjugate and the L2 and H1 errors against Lamé (5e-3 and 6e-2)."""
    X = np.array([[1.0, 0.0, 0.0], [0.6, 0.5, 0.62], [0.2, 1.5, 0.9], [1.2, 1.2, 0.3]])
    answers = []
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        problem, numbers = _pressurized_sphere(comm)
        assert problem.mesh.geometry_degree == 2
        answers.append((problem.displacement_at(X), numbers))
    (u_all, norms_all), (u_one, norms_one) = answers
    assert u_all == pytest.approx(u_one, rel=1e-9, abs=1e-18)
    assert norms_all == pytest.approx(norms_one, rel=1e-9)
    assert 3e-3 < norms_all[0] < 7e-3 and norms_all[1] < 8e-2, norms_all
