"""Local refinement of 3D problems: the FEM on tetrahedra (DOLFINx's refinement of marked cells,
the P2 state interpolated from the parent cells), in place and adaptively during a load path;
the refusals for Q2 hexahedra and the 3D SFVEM (docs/guide/refinement.md)."""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.mesh.cell_mesh import CellMesh
from dolfinx_sfvem.mesh.cell_refine import refine_cells

SOLID, MEDIUM = sf.meshes.SOLID, sf.meshes.MEDIUM
MATERIALS = {SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14), MEDIUM: sf.ThirdMedium(mu=5 / 14, gamma=1e-5, alpha_r=1.0)}


def sandwich(cell: str = "tetrahedron", n: int = 2) -> CellMesh:
    """Two solid slabs (z < 0.25, z > 0.75) of the unit cube with third medium between, the bottom
    face named ``"bottom"``."""
    lines = np.linspace(0.0, 1.0, n + 1)
    mesh = sf.meshes.box_grid(lines, lines, np.linspace(0.0, 1.0, 5),
                              lambda x, y, z: np.where((z < 0.25) | (z > 0.75), SOLID, MEDIUM),
                              {"solid": SOLID, "medium": MEDIUM}, cell=cell)
    facets, _, neighbour = mesh.boundary_facets()
    bottom = facets[(neighbour < 0) & np.all(np.isclose(mesh.points[facets][:, :, 2], 0.0), axis=1)]
    return CellMesh(mesh.points, mesh.cells, mesh.tags, cell, mesh.region_names, {"bottom": bottom})


def quadratic(x: np.ndarray) -> np.ndarray:
    """A quadratic displacement (3, n) of the coordinates x (3, n)."""
    return np.array([0.1 * x[0] ** 2 + 0.05 * x[1] * x[2] - 0.02, 0.02 * x[2] ** 2 - 0.03 * x[0] * x[1],
                     0.04 * x[0] * x[2] + 0.01 * x[1] ** 2])


def squeezed(mesh: CellMesh, comm: MPI.Comm = MPI.COMM_WORLD) -> sf.ContactProblem:
    """The sandwich's bottom clamped (by name), its top pushed down by 0.45: the slabs close in on
    each other to a gap of 0.05 across the medium (J = 0.1 there), its stiffening carries the load."""
    problem = sf.ContactProblem(mesh, MATERIALS, method="fem", comm=comm, verbose=False)
    problem.fix("bottom")
    problem.prescribe(lambda x: np.isclose(x[2], 1.0), ux=0.0, uy=0.0, uz=-0.45, name="top")
    return problem


def nodal(problem: sf.ContactProblem) -> np.ndarray:
    """The state (n_local_nodes, 3)."""
    with problem.x.localForm() as xl:
        return xl.array_r.reshape(-1, 3).copy()


def by_coordinates(problem: sf.ContactProblem) -> np.ndarray:
    """The owned nodes' coordinates and displacements (n, 6) of all ranks, sorted by coordinates."""
    n = problem.disc.n_owned_nodes
    rows = np.hstack([problem.disc.x_nodes[:n], nodal(problem)[:n]])
    rows = np.vstack(problem.comm.allgather(rows))
    return rows[np.lexsort(np.round(rows[:, :3], 12).T[::-1])]


def test_a_quadratic_field_is_carried_over_exactly():
    """Two levels of refinement of the cells with x < 0.5: a quadratic displacement, in the P2 space
    of the coarse mesh, is the same P2 field on the refined one (every node, to round-off); the
    regions keep their volumes, the old points their indices."""
    mesh = sandwich()
    problem = sf.ContactProblem(mesh, MATERIALS, method="fem", verbose=False)
    problem.set_displacement(*(lambda x, i=i: quadratic(x)[i] for i in range(3)))
    refinement = problem.refine(lambda x: x[0] < 0.5, levels=2)
    fine = refinement.mesh
    assert problem.mesh is fine and fine.n_cells > 8 * np.count_nonzero(refinement.selected)
    np.testing.assert_array_equal(fine.points[:mesh.n_points], mesh.points)
    np.testing.assert_array_equal(fine.tags, mesh.tags[refinement.parent])
    for tag in (SOLID, MEDIUM):
        assert fine.volumes[fine.tags == tag].sum() == pytest.approx(mesh.volumes[mesh.tags == tag].sum(), rel=1e-13)
    np.testing.assert_allclose(nodal(problem), quadratic(problem.disc.x_nodes.T).T, rtol=0, atol=1e-14)
    assert problem.region_tags().values.size > 0


def test_regions_and_boundary_conditions_are_kept():
    """The medium alone is selected by ``tags``; the named bottom face passes to the refined
    facets (same area), and the condition fixed on it by name holds every new node there."""
    mesh = sandwich()
    problem = squeezed(mesh)
    refinement = problem.refine(tags=["medium"])
    assert np.all(mesh.tags[np.flatnonzero(refinement.selected)] == MEDIUM)
    fine = problem.refine(lambda x: x[2] < 0.25).mesh

    def area(m: CellMesh) -> float:
        x = m.points[m.boundary_names["bottom"]]
        return 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1).sum()

    assert fine.boundary_names["bottom"].shape[0] > mesh.boundary_names["bottom"].shape[0]
    assert area(fine) == pytest.approx(1.0, rel=1e-13) and area(mesh) == pytest.approx(1.0, rel=1e-13)
    constrained = problem.constraints().dofs
    on_bottom = np.flatnonzero(np.isclose(problem.disc.x_nodes[:, 2], 0.0))
    assert np.all(np.isin(3 * on_bottom[:, None] + np.arange(3), constrained))


def test_refinement_input_is_checked():
    hexahedra = sandwich("hexahedron")
    solid = CellMesh(hexahedra.points, hexahedra.cells, np.full(hexahedra.n_cells, SOLID), "hexahedron")
    problem = sf.ContactProblem(solid, {SOLID: MATERIALS[SOLID]}, method="fem", verbose=False)
    with pytest.raises(ValueError, match="hexahedrons \\(Q2\\) cannot be refined locally"):
        problem.refine(lambda x: x[0] < 0.5)
    with pytest.raises(ValueError, match="the selection is empty \\(no cell chosen\\)"):
        refine_cells(sandwich(), lambda x: x[0] > 2.0)
    with pytest.raises(ValueError, match="no cell has region tag 7"):
        refine_cells(sandwich(), tags=[7])


@pytest.mark.parametrize("mesh", [sf.meshes.octree_box([0, 0, 0], [1, 1, 1], 2).polyhedra(
    lambda x: np.full(x.shape[1], SOLID)), "hexahedra"], ids=["octree", "hexahedra-as-polyhedra"])
def test_the_3d_sfvem_is_not_refined_in_place(mesh):
    if mesh == "hexahedra":
        hexahedra = sandwich("hexahedron")
        mesh = CellMesh(hexahedra.points, hexahedra.cells, np.full(hexahedra.n_cells, SOLID), "hexahedron")
    problem = sf.ContactProblem(mesh, {SOLID: MATERIALS[SOLID]}, verbose=False)
    with pytest.raises(ValueError, match="3D SFVEM is not refined in place"):
        problem.refine(lambda x: x[0] < 0.5)
    with pytest.raises(ValueError, match="adapt: adaptive refinement needs"):
        problem.solve(steps=1, adapt=sf.Adaptivity())


def test_a_squeezed_medium_refined_mid_path_goes_on():
    """Half the push on the coarse mesh, the medium refined, then the rest from the carried state:
    the re-balancing step converges at once (the carried state is nearly in balance), the path
    reaches the full load, and the reaction is close to that of the coarse mesh."""
    coarse = squeezed(sandwich())
    assert coarse.solve(steps=2).converged
    problem = squeezed(sandwich())
    half = problem.solve(steps=2, until=0.5)
    assert half.converged and problem.load == pytest.approx(0.5)
    problem.refine(tags=["medium"])
    after = problem.solve(steps=2, from_current_state=True)
    assert after.converged and [s["load"] for s in after.steps] == pytest.approx([0.5, 1.0])
    assert after.steps[0]["newton_iterations"] <= 4 and after.steps[0]["dofs"] > half.steps[0]["dofs"]
    force, force_coarse = (p.reactions()["top"][2] for p in (problem, coarse))
    assert force < 0 and force == pytest.approx(force_coarse, rel=0.1)
    assert problem.contact_gap().value == pytest.approx(0.05, rel=0.01)


def test_adaptive_refinement_of_tetrahedra():
    """``adapt=`` on tetrahedra: the compressed medium is split after a converged step, the path
    re-balances and goes on to the full load on more unknowns."""
    problem = squeezed(sandwich())
    result = problem.solve(steps=2, adapt=sf.Adaptivity(sf.Compression(J_below=0.9), max_levels=1))
    assert result.converged and problem.load == pytest.approx(1.0)
    dofs = [s["dofs"] for s in result.steps if s["converged"]]
    assert dofs[-1] > dofs[0]
    assert sum(s.get("refined_polygons", 0) for s in result.steps) > 0


@pytest.mark.mpi
def test_refined_results_agree_with_one_rank():
    """Refined mid-path on all ranks and on each rank alone (``MPI.COMM_SELF``): the same mesh and
    the same state, node by node."""
    states = []
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        problem = squeezed(sandwich(), comm)
        assert problem.solve(steps=2, until=0.5).converged
        problem.refine(lambda x: (x[0] < 0.5) & (x[2] > 0.25) & (x[2] < 0.75))
        assert problem.solve(steps=2, from_current_state=True).converged
        states.append(by_coordinates(problem))
    world, alone = states
    np.testing.assert_allclose(world[:, :3], alone[:, :3], rtol=0, atol=1e-14)
    np.testing.assert_allclose(world[:, 3:], alone[:, 3:], rtol=0, atol=1e-9 * np.abs(alone[:, 3:]).max())
