"""Plane strain from 3D (issue 29 item 8): the C-box's Q2 grid extruded into a one-element hexahedral
slab with u_z = 0 on both faces reproduces the 2D Q2 solution (reaction per unit depth, displacements)
to 1e-6 relative for every regularization that exists in both dimensions; and the slab on 1 and
2 ranks agrees to 1e-9.

The 3D space restricted to z-independent fields is the 2D Q2 space, the quadrature (3 x 3 x 3
Gauss) integrates z-independent integrands as the 2D 3 x 3 rule does, and the energies reduce to
their plane-strain forms, so the two agree to round-off. Except HuHu-LuLu (Eq. 9, n_dim = 2): its
double stress T_izz = ∂ψ/∂G_izz = -α_r L_i / n_dim does not vanish in plane strain, so the slab's
in-plane displacements bulge in z between its faces (the one-element layer's mid-nodes are free;
u independent of z is not a Dirichlet condition) and the slab is not in plane strain: in the
medium, where the regularization dominates, the displacements differ by 2 % (α_r = 1e-3), the
reaction on the solid by 2.2e-6 relative. For HuHu-LuLu only the reaction is compared (to 1e-5).
"""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.mesh.cell_mesh import CellMesh

SOLID, MEDIUM = sf.meshes.SOLID, sf.meshes.MEDIUM
DEPTH = 0.3
UY = -0.1
#: relative agreement with plane strain (module docstring)
RTOL = {"huhu_lulu": 1e-5}
#: Newton to round-off, so that the comparison sees the discretizations, not the stopping test
TIGHT = {"snes_rtol": 1e-14, "snes_stol": 0.0, "snes_max_it": 30}
REGULARIZATIONS = {"huhu": {"regularization": "huhu"},
                   "exponential_huhu": {"regularization": "huhu", "beta": 5.0},
                   "huhu_lulu": {"regularization": "huhu_lulu", "n_dim": 2},
                   "rotation": {"regularization": "rotation"}}
# tan_rotation (Eq. 16) is left out: its 3D tangent takes gcc many minutes to compile on a shared
# machine (docs/notes/2026-11-26-3d-lagrange-core.md)


def extrude(mesh: sf.PolygonMesh, depth: float) -> CellMesh:
    """One layer of hexahedra of ``depth`` under the quadrilaterals (counter-clockwise) of ``mesh``."""
    quads = mesh.vertices.reshape(-1, 4)
    n = mesh.n_points
    points = np.concatenate([np.c_[mesh.points, np.zeros(n)], np.c_[mesh.points, np.full(n, depth)]])
    bottom = quads[:, [0, 1, 3, 2]]                     # counter-clockwise -> tensor-product order
    return CellMesh(points, np.hstack([bottom, bottom + n]), mesh.tags, "hexahedron")


def materials(name):
    return {SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14),
            MEDIUM: sf.ThirdMedium(mu=5 / 14, gamma=1e-5, alpha_r=1e-3, **REGULARIZATIONS[name])}


def grid():
    return MPI.COMM_WORLD.bcast(sf.meshes.cbox_grid(h_solid=0.1) if MPI.COMM_WORLD.rank == 0 else None, root=0)


def solve_2d(name):
    bench = grid()
    problem = sf.ContactProblem(bench.mesh, materials(name), method="fem", fem_mesh=bench.mesh, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0))
    load = bench.points["load"]
    problem.prescribe(lambda x: np.isclose(x[0], load[0]) & np.isclose(x[1], load[1]), uy=UY, name="load")
    assert problem.solve(steps=2, petsc_options=TIGHT).converged
    return problem


def solve_3d(name, comm=MPI.COMM_WORLD):
    bench = grid()
    problem = sf.ContactProblem(extrude(bench.mesh, DEPTH), materials(name), method="fem", comm=comm, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), components="xy")
    problem.fix(lambda x: np.isclose(x[2], 0.0) | np.isclose(x[2], DEPTH), components="z", name="faces")
    load = bench.points["load"]
    problem.prescribe(lambda x: np.isclose(x[0], load[0]) & np.isclose(x[1], load[1]), uy=UY, name="load")
    assert problem.solve(steps=2, petsc_options=TIGHT).converged
    return problem


def probe_points():
    return np.array([[1.0, 0.5], [1.0, 0.4], [0.55, 0.1], [0.3, 0.25], [1.05, 0.3]])


@pytest.mark.parametrize("name", list(REGULARIZATIONS))
def test_extruded_slab_is_plane_strain(name):
    two, three = solve_2d(name), solve_3d(name)
    R2, R3 = two.reactions()["load"], three.reactions()["load"]
    assert R3[2] == pytest.approx(0.0, abs=1e-10 * abs(R2[1]))
    rtol = RTOL.get(name, 1e-6)
    assert np.asarray(R3[:2]) / DEPTH == pytest.approx(R2, rel=rtol, abs=rtol * abs(R2[1]))
    if name == "huhu_lulu":
        return
    points = probe_points()
    u2 = two.displacement_at(points)
    for z in (0.0, 0.37 * DEPTH, DEPTH):
        u3 = three.displacement_at(np.c_[points, np.full(len(points), z)])
        assert np.abs(u3[:, 2]).max() < 1e-9 * np.abs(u2).max()
        assert u3[:, :2] == pytest.approx(u2, rel=rtol, abs=rtol * np.abs(u2).max())


@pytest.mark.mpi
def test_slab_on_world_and_self():
    world, alone = solve_3d("huhu"), solve_3d("huhu", MPI.COMM_SELF)
    reactions = alone.reactions()
    scale = max(np.abs(reaction).max() for reaction in reactions.values())    # a zero reaction is round-off
    for name, reaction in reactions.items():
        assert np.allclose(world.reactions()[name], reaction, rtol=1e-9, atol=1e-12 * scale)
    points = np.c_[probe_points(), np.full(len(probe_points()), 0.5 * DEPTH)]
    assert np.allclose(world.displacement_at(points), alone.displacement_at(points), rtol=1e-9, atol=1e-13)
