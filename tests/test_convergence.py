"""Convergence of the order-2 SFVEM on a manufactured smooth solution (docs/method.md §7).

Small-strain plane elasticity, written as a user UFL energy ψ = μ ε:ε + λ/2 (tr ε)² with
ε = sym(F − I), on the unit square with u = 0 on the boundary and the body force
f = −div σ(u) of the exact solution

    u_1 = u_2 = a sin(πx) sin(πy),   a = 0.01 (small strain: J stays near 1).

The errors ‖u − Π^∇_2 u_h‖_L2 and ‖∇u − Π⁰_l∇u_h‖_L2 must fall like h³ and h² on
sequences of Voronoi-like polygon meshes and of quad meshes with hanging nodes. The problem is
conftest.py's ``manufactured`` (test_fem solves it with P2 and Q2).
"""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf


def solve_errors(mesh: sf.PolygonMesh, manufactured, comm=MPI.COMM_WORLD) -> tuple[float, float, float]:
    """(h, L2 error, H1 error) of the SFVEM solution of the manufactured problem on ``mesh``."""
    tag = int(mesh.tags[0])
    problem = sf.ContactProblem(mesh, {tag: manufactured.energy()}, comm=comm, verbose=False)
    problem.fix(manufactured.on_boundary)
    problem.body_force(manufactured.body_force)
    result = problem.solve(steps=1)
    assert result.converged
    h = np.sqrt(1.0 / mesh.n_polygons)
    return (h, *problem.disc.error_norms(problem.x, manufactured.u_exact, manufactured.grad_exact))


@pytest.mark.parametrize("family", ["voronoi", "hanging"])
def test_manufactured_solution_rates(family, manufactured):
    if family == "voronoi":
        meshes = [sf.meshes.polygon_rectangle(1.0, 1.0, h) for h in (0.2, 0.1, 0.05)]
    else:
        meshes = [sf.meshes.quads_with_hanging_nodes(1.0, 1.0, n) for n in (4, 8, 16)]
        assert all(m.hanging_nodes.size > 0 for m in meshes)
    results = [solve_errors(m, manufactured) for m in meshes]
    rate_L2, rate_H1 = manufactured.rates(results)
    assert rate_H1 >= 1.8, (rate_H1, results)
    assert rate_L2 >= 2.7, (rate_L2, results)
    # the errors are small relative to the solution too (‖u‖_L2 = a/2, |u|_H1 = a π/√2)
    a = manufactured.AMPLITUDE
    assert results[-1][1] < 1e-3 * a and results[-1][2] < 1e-2 * a


def test_linear_solution_reproduced_exactly(manufactured):
    """A linear displacement with no body force is reproduced to round-off (patch test of the assembled problem)."""
    mesh = sf.meshes.polygon_rectangle(1.0, 1.0, 0.25)
    tag = int(mesh.tags[0])
    problem = sf.ContactProblem(mesh, {tag: manufactured.energy()}, verbose=False)
    A = np.array([[0.01, -0.02], [0.03, 0.015]])
    problem.prescribe(manufactured.on_boundary, ux=lambda x: A[0] @ x, uy=lambda x: A[1] @ x, name="linear")
    assert problem.solve(steps=1).converged
    e0, e1 = problem.disc.error_norms(problem.x, lambda x: A @ x, lambda x: np.repeat(A[:, :, None], x.shape[1], 2))
    assert e0 < 1e-12 and e1 < 1e-12


@pytest.mark.mpi
def test_same_solution_on_one_and_all_ranks(manufactured):
    """The small-strain solve on all ranks equals the one on a single rank (relative 1e-10)."""
    mesh = sf.meshes.polygon_rectangle(1.0, 1.0, 0.1) if MPI.COMM_WORLD.rank == 0 else None
    mesh = MPI.COMM_WORLD.bcast(mesh, root=0)
    displacements = []
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        problem = sf.ContactProblem(mesh, {int(mesh.tags[0]): manufactured.energy()}, comm=comm, verbose=False)
        problem.fix(manufactured.on_boundary)
        problem.body_force(manufactured.body_force)
        assert problem.solve(steps=1).converged
        displacements.append(problem.point_displacements())
    if MPI.COMM_WORLD.rank == 0:
        u_all, u_one = displacements
        assert np.max(np.abs(u_all - u_one)) <= 1e-10 * np.max(np.abs(u_one))
