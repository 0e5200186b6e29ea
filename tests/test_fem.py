"""P2 FEM reference (dolfinx_sfvem.discretizations.fem): consistency, protocol, convergence (docs/method.md §7).

- The tangent is the derivative of the residual and the residual the derivative of the
  reported energy (central differences), for the solid and every regularization of
  Table 1 with and without the exp(-βJ) scaling, on a two-region mesh.
- Identity rows for constrained unknowns, columns kept (discretization.Constraints).
- Through ContactProblem(method="fem"): a homogeneous uniaxial-stress deformation is
  reproduced exactly and the reaction equals the exact traction resultant P(F)·N·H.
- Manufactured small-strain solution: L2 error ~ h^3, H1 error ~ h^2, for P2 and Q2.
- Q2 on a given quadrilateral mesh (``fem_mesh``): node keys, and the checks of bad meshes.
- Known limitation (expected failure): on the C-box the P2 medium folds around the beam tips,
  solid vertices end inside medium triangles; the SFVEM and Q2 on the C-box grid pass the same
  check.
"""
import json
import pathlib

import numpy as np
import pytest
import scipy.optimize
from matplotlib.path import Path
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx_sfvem as sf
from dolfinx_sfvem.physics.energy import REGULARIZATIONS
from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization
from dolfinx_sfvem.discretizations.compiled_energy import compile_kernels, evaluate
from dolfinx_sfvem.discretizations.node_keys import sfvem_unknowns
from dolfinx_sfvem.mesh.remesh import p2_unknowns, triangulate

STEP = 1e-6
RTOL = 1e-6


def two_regions() -> sf.PolygonMesh:
    """[0, 2] x [0, 1]: region 1 left, region 2 right, 2 x 2 quads each."""
    return sf.meshes.glue(sf.meshes.quad_rectangle(1.0, 1.0, 2, 2, tag=1),
                          sf.meshes.quad_rectangle(1.0, 1.0, 2, 2, origin=(1.0, 0.0), tag=2))


def residual_at(disc, x, d, eps):
    """(b(x + eps d), energy) with ghosts of the shifted state updated."""
    y = x.copy()
    y.axpy(eps, d)
    y.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    b = disc.create_vector()
    info = disc.residual(y, b)
    assert info.min_J > 0
    return b, info.energy


def cells_of(kind: str) -> dict:
    """from_polygon_mesh options of two_regions(): P2 on a triangulation, or Q2 on its own quads."""
    return {"fem_h": 0.35} if kind == "triangles" else {"fem_mesh": two_regions()}


@pytest.mark.mpi
@pytest.mark.parametrize("regularization, beta, jump_penalty, cells",
                         [(r, b, None, "triangles") for r in sorted(REGULARIZATIONS) for b in (None, 5.0)]
                         + [("rotation", None, 40.0, "triangles"), ("huhu_lulu", 5.0, 40.0, "triangles"),
                            ("rotation", None, None, "quads"), ("huhu_lulu", 5.0, None, "quads"),
                            ("rotation", None, 40.0, "quads")])
def test_tangent_and_residual_match_finite_differences(regularization, beta, jump_penalty, cells,
                                                       two_region_materials, state_of, direction_of):
    disc = LagrangeDiscretization.from_polygon_mesh(two_regions(), two_region_materials(regularization, beta),
                                              jump_penalty=jump_penalty, verbose=False, **cells_of(cells))
    x, d = state_of(disc), direction_of(disc)
    b, _ = residual_at(disc, x, d, 0.0)
    A = disc.create_matrix()
    disc.jacobian(x, A)
    Ad = disc.create_vector()
    A.mult(d, Ad)

    (b_plus, e_plus), (b_minus, e_minus) = residual_at(disc, x, d, STEP), residual_at(disc, x, d, -STEP)
    fd = b_plus.copy()
    fd.axpy(-1.0, b_minus)
    fd.scale(1 / (2 * STEP))
    error = Ad.copy()
    error.axpy(-1.0, fd)
    assert error.norm() <= RTOL * fd.norm(), (error.norm(), fd.norm())

    # the residual is the gradient of the reported (globally summed) energy
    assert np.isclose(b.dot(d), (e_plus - e_minus) / (2 * STEP), rtol=RTOL, atol=0.0)


@pytest.mark.mpi
def test_constrained_rows_and_columns_are_identity(two_region_materials, state_of, direction_of):
    disc = LagrangeDiscretization.from_polygon_mesh(two_regions(), two_region_materials(),
                                              fem_h=0.35, verbose=False)
    x, d = state_of(disc), direction_of(disc)
    constrained = np.zeros(disc.n_local_dofs, dtype=bool)
    constrained[disc.locate_dofs(lambda X: np.isclose(X[0], 0.0) | np.isclose(X[1], 1.0), component=1)] = True
    A, A_c = disc.create_matrix(), disc.create_matrix()
    disc.jacobian(x, A)
    disc.set_constraints(np.flatnonzero(constrained))
    disc.jacobian(x, A_c)
    n = disc.n_owned_dofs
    c = constrained[:n]
    d_f = d.copy()
    d_f.array[c] = 0.0
    y, y_c = disc.create_vector(), disc.create_vector()
    A.mult(d_f, y)
    A_c.mult(d, y_c)
    assert MPI.COMM_WORLD.allreduce(int(c.sum()), op=MPI.SUM) > 0
    assert np.allclose(y_c.array[c], d.array[c], rtol=0, atol=1e-14)
    assert np.allclose(y_c.array[~c], y.array[~c], rtol=1e-13, atol=1e-13 * np.abs(y.array).max())


def energy_of(disc, values, nodal_field) -> float:
    x = nodal_field(disc, values)
    return disc.residual(x, disc.create_vector()).energy


@pytest.mark.mpi
def test_jump_penalty_acts_only_on_kinks_of_the_gradient(two_region_materials, nodal_field):
    """The interior-penalty terms vanish for a field with continuous ∇u (a quadratic, which P2
    holds exactly) and add energy for one that kinks across the medium's interior facets."""
    materials = two_region_materials()
    plain, penalised = (LagrangeDiscretization.from_polygon_mesh(two_regions(), materials, fem_h=0.35,
                                                           jump_penalty=eta, verbose=False) for eta in (None, 40.0))
    assert plain.describe()["jump_penalty"] is None and penalised.describe()["jump_penalty"] == 40.0

    def quadratic(X, key):
        return 0.05 * np.stack([X[:, 0] ** 2 - X[:, 1], X[:, 0] * X[:, 1]], axis=1)

    def kink(X, key):                       # the medium sheared more above y = 0.5 than below
        return 0.05 * np.stack([np.abs(X[:, 1] - 0.5), 0.0 * X[:, 1]], axis=1)

    e_plain, e_penalised = energy_of(plain, quadratic, nodal_field), energy_of(penalised, quadratic, nodal_field)
    assert np.isclose(e_penalised, e_plain, rtol=1e-12, atol=0.0)
    # the kink lies along facets only if the triangulation has them at y = 0.5; either way ∇u jumps
    assert energy_of(penalised, kink, nodal_field) > energy_of(plain, kink, nodal_field) * (1 + 1e-3)


def test_jump_penalty_in_3d_acts_only_on_kinks_of_the_gradient(tiny3d):
    """As in 2D, on P2 tetrahedra of a 2 x 1 x 1 medium box (the same form serves Q2 hexahedra;
    their facet forms compile for minutes): no energy for a quadratic field, energy for one whose
    gradient jumps across the interior faces at x = 1/2."""
    points, cells = tiny3d.hex_grid((2, 1, 1), (1.0, 0.5, 0.5))
    cells = cells[:, tiny3d.kuhn_tets()].reshape(-1, 4)
    mesh = sf.CellMesh(points, cells, np.ones(len(cells)), "tetrahedron")
    medium = {1: sf.ThirdMedium(mu=0.5, K=1.0, gamma=1.0, alpha_r=0.3, regularization="huhu")}
    plain, penalised = (LagrangeDiscretization.from_cell_mesh(mesh, medium, jump_penalty=eta, verbose=False)
                        for eta in (None, 40.0))

    def energy(disc, u):
        x = disc.create_vector()
        with x.localForm() as xl:
            xl.array[:] = u(disc.x_nodes).ravel()
        return disc.residual(x, disc.create_vector()).energy

    def quadratic(X):
        return 0.05 * np.stack([X[:, 0] ** 2 - X[:, 1], X[:, 0] * X[:, 2], X[:, 1] * X[:, 2]], axis=1)

    def kink(X):
        return 0.05 * np.stack([0 * X[:, 0], np.abs(X[:, 0] - 0.5), 0 * X[:, 0]], axis=1)

    assert np.isclose(energy(penalised, quadratic), energy(plain, quadratic), rtol=1e-12, atol=0.0)
    assert energy(penalised, kink) > energy(plain, kink) * (1 + 1e-3)


def test_jump_penalty_must_be_positive(two_region_materials):
    with pytest.raises(ValueError, match="jump_penalty"):
        LagrangeDiscretization.from_polygon_mesh(two_regions(), two_region_materials(), fem_h=0.35,
                                           jump_penalty=-1.0, verbose=False)


def uniaxial_stretch(energy, stretch):
    """F = diag(stretch, lambda_2) with P_22 = 0 (top/bottom traction free), and P (2, 2)."""
    kernels = compile_kernels(energy)

    def P(l2):
        return evaluate(kernels, np.diag([stretch, l2]), None, energy.params)["P"]

    l2 = scipy.optimize.brentq(lambda l2: P(l2)[1, 1], 0.5, 1.5, xtol=1e-15)
    return np.diag([stretch, l2]), P(l2)


@pytest.mark.mpi
def test_contact_problem_with_fem_reproduces_homogeneous_deformation(tmp_path):
    """Same ContactProblem code path as the SFVEM: BCs with function values, Newton, reactions, output."""
    comm = MPI.COMM_WORLD
    energy = sf.Hyperelastic(K=5 / 3, mu=5 / 14)
    F, P = uniaxial_stretch(energy, 1.2)
    H = 1.0
    mesh = sf.meshes.polygon_rectangle(2.0, H, 0.5, tag=3)
    problem = sf.ContactProblem(mesh, {3: energy}, method="fem", fem_h=0.3, verbose=False)
    assert problem.disc.method == "fem"
    right = lambda x: np.isclose(x[0], 2.0)                                                   # noqa: E731
    rest = lambda x: (np.isclose(x[0], 0.0) | np.isclose(x[1], 0.0) | np.isclose(x[1], H)) & ~right(x)  # noqa: E731
    G = F - np.eye(2)
    problem.prescribe(right, ux=lambda x: G[0] @ x, uy=lambda x: G[1] @ x, name="right")
    problem.prescribe(rest, ux=lambda x: G[0] @ x, uy=lambda x: G[1] @ x, name="rest")
    out = pathlib.Path(comm.bcast(str(tmp_path), root=0))
    result = problem.solve(steps=2, out=out)

    assert result.converged
    assert all(s["newton_iterations"] <= 6 for s in result.steps)
    e0, e1 = problem.disc.error_norms(problem.x, lambda x: G @ x, lambda x: np.repeat(G[:, :, None], x.shape[1], 2))
    assert e0 < 1e-12 and e1 < 1e-12
    # Σ of the nodal reactions on the right side = ∫_right P N ds = P[:, 0] H exactly (P N = 0 on top/bottom)
    assert np.allclose(result.steps[-1]["reaction"]["right"], P[:, 0] * H, rtol=1e-9, atol=1e-12)
    if comm.rank == 0:
        summary = json.loads((out / "summary.json").read_text())
        assert summary["method"] == "fem" and summary["cells"] == problem.disc.output_mesh.n_polygons
        assert summary["cell_type"] == "triangle"
        assert summary["dofs"] == p2_unknowns(problem.disc.output_mesh.vertices.reshape(-1, 3))
        assert (out / "deformed.png").is_file()
    u = problem.point_displacements()
    if comm.rank == 0:
        points = problem.disc.output_mesh.points
        assert np.allclose(u, points @ G.T, atol=1e-12)


def test_named_points_stay_vertices():
    box = sf.meshes.cbox(h_solid=0.1)
    tri = triangulate(box.mesh, 0.2)
    for name, xy in box.points.items():
        assert np.min(np.linalg.norm(tri.points - np.asarray(xy), axis=1)) == 0.0, name
    areas = {tag: sum(box.mesh.areas[box.mesh.tags == tag]) for tag in (1, 2)}
    a, b, c = (tri.points[tri.triangles[:, k]] for k in range(3))
    tri_area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    for tag, area in areas.items():
        assert np.isclose(tri_area[tri.tags == tag].sum(), area, rtol=1e-12)


#: how close matched_triangulation gets to the SFVEM unknowns of the C-box at h = 0.1 depends on
#: gmsh: within 0.8 % with gmsh 4.8 (Debian 12), 6.2 % with gmsh 4.15 (PyPI; the sixth and last
#: mesh it tries), so the bound is one both meet
MATCHED_UNKNOWNS_RTOL = 0.07


def test_matched_triangulation_matches_the_sfvem_unknowns(two_region_materials):
    mesh = sf.meshes.cbox(h_solid=0.1).mesh
    target = sf.VEMSpace(mesh, verbose=False).num_dofs_global
    assert sfvem_unknowns(mesh) == target
    materials = two_region_materials()
    disc = LagrangeDiscretization.from_polygon_mesh(mesh, materials, verbose=False)
    assert disc.num_dofs_global == p2_unknowns(disc.output_mesh.vertices.reshape(-1, 3))
    assert abs(disc.num_dofs_global - target) <= MATCHED_UNKNOWNS_RTOL * target
    assert disc.describe()["mesh_size"] > 0


def solid_vertices_inside_medium(problem: sf.ContactProblem) -> int:
    """Number of (vertex, medium cell) pairs with a solid vertex strictly inside the deformed cell
    (straight-sided), on rank 0 (0 elsewhere)."""
    mesh = problem.disc.output_mesh
    u = problem.point_displacements()
    if MPI.COMM_WORLD.rank != 0:
        return 0
    x = mesh.points + u
    cells = [mesh.vertices[mesh.offsets[k]:mesh.offsets[k + 1]] for k in range(mesh.n_polygons)]
    solid = np.unique(np.concatenate([c for c, tag in zip(cells, mesh.tags) if tag == sf.meshes.SOLID]))
    return sum(int(Path(x[c]).contains_points(x[np.setdiff1d(solid, c)], radius=-1e-9).sum())
               for c, tag in zip(cells, mesh.tags) if tag == sf.meshes.MEDIUM)


@pytest.mark.parametrize("method, options", [("vem", {}), ("fem", {}), ("fem", {"jump_penalty": 40.0}),
                                             ("fem", {"fem_mesh": "grid"})])
def test_cbox_medium_keeps_the_beams_apart(method, options):
    """C-box (paper §5.2: rotation, gamma 1e-5, alpha_r 1, medium column 0.1 wide) at u_y = -0.3
    in 15 steps, the P2 FEM on the matched mesh: no solid vertex lies inside a deformed medium
    cell. (With the column one element wide, 0.05, the plain P2 medium folded around the beam
    tips here: docs/contact.md.)"""
    box = sf.meshes.cbox(h_solid=0.05)
    if options.get("fem_mesh") == "grid":
        options = {"fem_mesh": sf.meshes.cbox_grid(h_solid=0.05).mesh}
    problem = sf.ContactProblem(box.mesh, {
        sf.meshes.SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14),
        sf.meshes.MEDIUM: sf.ThirdMedium(mu=5 / 14, gamma=1e-5, alpha_r=1.0, regularization="rotation")},
        method=method, verbose=False, **options)
    problem.fix(lambda x: np.isclose(x[0], 0.0))
    load = np.asarray(box.points["load"])
    problem.prescribe(lambda x: np.hypot(x[0] - load[0], x[1] - load[1]) < 1e-10, uy=-0.3, name="load")
    result = problem.solve(steps=15)
    assert result.converged, result.message
    assert solid_vertices_inside_medium(problem) == 0


def solve_errors_fem(h, manufactured, comm=MPI.COMM_WORLD, quads=False):
    """(h, L2 error, H1 error) of the FEM solution of the manufactured problem (conftest.py): P2 on
    triangles of size h, or Q2 on squares of size h (``quads``)."""
    square = sf.meshes.quad_rectangle(1.0, 1.0, 1, 1)
    cells = {"fem_mesh": sf.meshes.quad_rectangle(1.0, 1.0, round(1 / h), round(1 / h))} if quads else {"fem_h": h}
    problem = sf.ContactProblem(square, {0: manufactured.energy()}, method="fem", comm=comm, verbose=False, **cells)
    problem.fix(manufactured.on_boundary)
    problem.body_force(manufactured.body_force)
    assert problem.solve(steps=1).converged
    return (h, *problem.disc.error_norms(problem.x, manufactured.u_exact, manufactured.grad_exact))


@pytest.mark.mpi
@pytest.mark.parametrize("quads", [False, True])
def test_manufactured_solution_rates(quads, manufactured):
    results = [solve_errors_fem(h, manufactured, quads=quads) for h in (0.2, 0.1, 0.05)]
    rate_L2, rate_H1 = manufactured.rates(results)
    assert 2.7 <= rate_L2 <= 3.5, (rate_L2, results)
    assert 1.8 <= rate_H1 <= 2.4, (rate_H1, results)
    a = manufactured.AMPLITUDE
    assert results[-1][1] < 1e-3 * a and results[-1][2] < 1e-2 * a


@pytest.mark.mpi
def test_q2_node_keys_are_unique_and_name_their_place(two_region_materials):
    """Q2 on a quadrilateral fem_mesh: one key per node over all ranks; a vertex node keys its
    output point, an edge node the midpoint of its two points, a centre node its cell."""
    disc = LagrangeDiscretization.from_polygon_mesh(two_regions(), two_region_materials(),
                                              fem_mesh=sf.meshes.glue(
                                                  sf.meshes.quad_rectangle(1.0, 1.0, 2, 3, tag=1),
                                                  sf.meshes.quad_rectangle(1.0, 1.0, 2, 3, origin=(1.0, 0.0), tag=2)),
                                              verbose=False)
    assert disc.describe()["cell_type"] == "quadrilateral" and disc.describe()["cells"] == 12
    assert disc.num_dofs_global == 2 * 9 * 7
    keys = np.concatenate(MPI.COMM_WORLD.allgather(disc.node_key[:disc.V.dofmap.index_map.size_local]))
    assert np.unique(keys).size == keys.size == disc.num_dofs_global // 2
    points, n = disc.output_mesh.points, disc.output_mesh.n_points
    vertex, centre = disc.node_key < n, disc.node_key >= n + n * n
    edge = ~vertex & ~centre
    assert np.allclose(disc.x_nodes[vertex], points[disc.node_key[vertex]])
    a, b = np.divmod(disc.node_key[edge] - n, n)
    assert np.allclose(disc.x_nodes[edge], 0.5 * (points[a] + points[b]))
    cell = disc.node_key[centre] - n - n * n
    assert np.allclose(disc.x_nodes[centre], disc.output_mesh.centroids[cell])


def dented_quads() -> sf.PolygonMesh:
    """[0, 2] x [0, 1] in three quadrilaterals, the first with a reflex corner at (0.3, 0.3): no
    bilinear map (the other two, not parallelograms, would do)."""
    return sf.PolygonMesh([(0, 0), (1, 0), (2, 0), (0, 1), (1, 1), (2, 1), (0.3, 0.3)],
                          [[0, 1, 6, 3], [1, 2, 5, 4], [1, 4, 3, 6]], [1, 1, 1])


@pytest.mark.parametrize("mesh, fem_mesh, message", [
    (lambda: sf.meshes.cbox(h_solid=0.1).mesh, lambda: sf.meshes.cbox(h_solid=0.1).mesh,
     "all triangles or all quadrilaterals"),
    (lambda: sf.meshes.cbox(h_solid=0.1).mesh, lambda: sf.meshes.cbox_grid(h_solid=0.05, column=0.05).mesh,
     "region 2 has area"),
    (lambda: sf.meshes.quad_rectangle(2.0, 1.0, 2, 1, tag=1), dented_quads, "quadrilateral 0 is not strictly convex"),
])
def test_fem_mesh_is_checked(mesh, fem_mesh, message, two_region_materials):
    with pytest.raises(ValueError, match=message):
        LagrangeDiscretization.from_polygon_mesh(mesh(), two_region_materials(), fem_mesh=fem_mesh(),
                                           verbose=False)


def test_fem_h_and_fem_mesh_exclude_each_other(two_region_materials):
    with pytest.raises(ValueError, match="not both"):
        LagrangeDiscretization.from_polygon_mesh(two_regions(), two_region_materials(), fem_h=0.35,
                                           fem_mesh=two_regions(), verbose=False)
