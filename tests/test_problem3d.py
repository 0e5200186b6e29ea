"""ContactProblem on a 3D mesh (Q2 hexahedra, P2 tetrahedra): boundary conditions, solve,
reactions, output and resume against the exact homogeneous uniaxial stretch."""
import json

import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.mesh.cell_mesh import CellMesh

K, MU, STRETCH = 5 / 3, 5 / 14, 0.1
LENGTHS = np.array([2.0, 1.0, 1.0])




def meshes(tiny3d):
    points, cells = tiny3d.hex_grid(2, LENGTHS)
    octree = sf.meshes.octree_box([0.0, 0.0, 0.0], LENGTHS, [2, 1, 1]).refine(lambda c: c[0] < 1.0).polyhedra()
    return {"hexahedron": CellMesh(points, cells, np.ones(len(cells)), "hexahedron"),
            "tetrahedron": CellMesh(tiny3d.CUBE * LENGTHS, tiny3d.kuhn_tets(), np.ones(6), "tetrahedron"),
            "octree": octree}


def bar(tiny3d, cell, comm=MPI.COMM_WORLD, method="fem"):
    mesh = meshes(tiny3d)[cell]
    problem = sf.ContactProblem(mesh, {int(mesh.tags[0]): sf.Hyperelastic(K=K, mu=MU)}, method=method, comm=comm,
                                verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), components="x", name="x0")
    problem.fix(lambda x: np.isclose(x[1], 0.0), components="y", name="y0")
    problem.fix(lambda x: np.isclose(x[2], 0.0), components=["z"], name="z0")
    problem.prescribe(lambda x: np.isclose(x[0], 2.0), ux=2.0 * STRETCH, name="pull")
    return problem


@pytest.mark.parametrize("cell, method", [("hexahedron", "fem"), ("tetrahedron", "fem"), ("hexahedron", "vem"),
                                          ("octree", "vem")])
def test_uniaxial_stretch_is_exact(cell, method, tmp_path, tiny3d, by_hand):
    """Q2, P2 and the SFVEM (hexahedra read as polyhedra; an octree with hanging vertices) are
    exact for the homogeneous stretch."""
    problem = bar(tiny3d, cell, method=method)
    result = problem.solve(steps=2, out=tmp_path)
    assert result.converged
    s, P11 = by_hand.uniaxial(K, MU, STRETCH)
    assert problem.reactions()["pull"] == pytest.approx([P11 * 1.0, 0.0, 0.0], abs=1e-10)
    u = problem.displacement_at([[2.0, 1.0, 1.0], [1.0, 0.5, 0.25]])
    assert u == pytest.approx(np.array([[0.2, s - 1, s - 1], [0.1, 0.5 * (s - 1), 0.25 * (s - 1)]]), abs=1e-10)
    assert problem.displacement().function_space.dofmap.index_map_bs == 3
    sigma = problem.stress("piola").x.array.reshape(-1, 3, 3)
    assert np.allclose(sigma, np.diag([P11, 0.0, 0.0]), atol=1e-10)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["converged"] and summary["steps"][-1]["reaction"]["pull"][0] == pytest.approx(P11, rel=1e-9)
    assert (tmp_path / "displacement.xdmf").exists()
    assert np.load(tmp_path / "checkpoint.npz")["values"].shape[1] == 3


def test_resume_continues_the_same_path(tmp_path, tiny3d, by_hand):
    first = bar(tiny3d, "hexahedron")
    first.solve(steps=4, out=tmp_path, until=0.5)
    resumed = bar(tiny3d, "hexahedron")
    result = resumed.solve(steps=4, out=tmp_path, resume=True)
    assert result.converged and len(result.steps) == 4
    assert resumed.reactions()["pull"][0] == pytest.approx(by_hand.uniaxial(K, MU, STRETCH)[1], rel=1e-10)


def test_three_d_errors(tiny3d):
    mesh = meshes(tiny3d)["hexahedron"]
    octree = meshes(tiny3d)["octree"]
    with pytest.raises(ValueError, match="method='fem' needs tetrahedra or hexahedra"):
        sf.ContactProblem(octree, {int(octree.tags[0]): sf.Hyperelastic(K=K, mu=MU)}, method="fem", verbose=False)
    on_polyhedra = sf.ContactProblem(octree, {int(octree.tags[0]): sf.Hyperelastic(K=K, mu=MU)}, verbose=False)
    with pytest.raises(ValueError, match="refine the octree"):
        on_polyhedra.refine(lambda x: x[0] < 1.0)
    with pytest.raises(ValueError, match="on a 2D mesh"):
        on_polyhedra.solve(steps=1, adapt=sf.Adaptivity())
    problem = sf.ContactProblem(mesh, {1: sf.Hyperelastic(K=K, mu=MU)}, method="fem", verbose=False)
    with pytest.raises(ValueError, match="component 'w'"):
        problem.fix(lambda x: x[0] < 0.1, components="w")
    with pytest.raises(ValueError, match="triple"):
        problem.point_force((2.0, 1.0), fx=1.0)
    with pytest.raises(ValueError, match="not a node of the mesh"):
        problem.point_force((1.9, 1.0, 1.0), fx=1.0)


def test_dolfinx_mesh_and_tags_and_point_force():
    """A mesh from dolfinx.mesh.create_box with its cell tags; a point force's work-conjugate
    displacement is the node's displacement along it."""
    import dolfinx.mesh
    from dolfinx_sfvem import _compat
    box = dolfinx.mesh.create_box(MPI.COMM_WORLD, [[0.0, 0.0, 0.0], LENGTHS], [2, 1, 1],
                                  dolfinx.mesh.CellType.hexahedron)
    n = _compat.num_owned_cells(box) + box.topology.index_map(3).num_ghosts
    problem = sf.ContactProblem((box, _compat.create_cell_tags(box, np.ones(n, np.int32))),
                                {1: sf.Hyperelastic(K=K, mu=MU)}, method="fem", verbose=False)
    assert problem.gdim == 3 and problem.disc.num_dofs_global == 3 * 5 * 3 * 3
    problem.fix(lambda x: np.isclose(x[0], 0.0))
    force = problem.point_force((2.0, 1.0, 1.0), fz=-1e-3)
    result = problem.solve(steps=1)
    assert result.converged
    tip = problem.displacement_at([[2.0, 1.0, 1.0]])[0]
    assert tip[2] < 0.0
    assert result.steps[-1]["loads"][force.name]["displacement"] == pytest.approx(-tip[2], rel=1e-10)
    assert problem.reactions()["fixed"] == pytest.approx([0.0, 0.0, 1e-3], abs=1e-12)


def cantilever(tiny3d, comm, method="fem"):
    """Q2 hexahedra, or the SFVEM on an octree refined at the clamp (hanging vertices), bent by
    its end and a follower pressure on its top."""
    if method == "fem":
        points, cells = tiny3d.hex_grid((4, 2, 2), LENGTHS)
        mesh = CellMesh(points, cells, np.ones(len(cells)), "hexahedron")
    else:
        mesh = sf.meshes.octree_box([0.0, 0.0, 0.0], LENGTHS, [4, 2, 2]).refine(lambda c: c[0] < 0.5).polyhedra()
    problem = sf.ContactProblem(mesh, {int(mesh.tags[0]): sf.Hyperelastic(K=K, mu=MU)}, method=method, comm=comm,
                                verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0))
    problem.prescribe(lambda x: np.isclose(x[0], 2.0), uz=-0.3, name="tip")
    problem.pressure(lambda x: np.isclose(x[2], 1.0), 0.01, name="top")
    result = problem.solve(steps=2)
    assert result.converged
    return problem.reactions(), problem.displacement_at([[2.0, 0.5, 0.5], [1.0, 1.0, 0.0], [0.25, 0.0, 1.0]])


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["fem", "vem"])
def test_same_results_on_world_and_self(method, tiny3d):
    """A bent cantilever on all ranks and on one: reactions and displacements to 1e-9."""
    world, u_world = cantilever(tiny3d, MPI.COMM_WORLD, method)
    alone, u_alone = cantilever(tiny3d, MPI.COMM_SELF, method)
    for name in alone:
        assert np.allclose(world[name], alone[name], rtol=1e-9, atol=1e-12 * np.abs(alone[name]).max())
    assert np.allclose(u_world, u_alone, rtol=1e-9, atol=1e-12)
    assert abs(alone["tip"][2]) > 0.0
