"""One linear solve of a 3D third-medium tangent, timed: the case that bench/solvers3d.py runs
in its own process per (size, ranks, solver) so that the peak memory is that solver's.

The tangent is assembled here with plain DOLFINx from the package's UFL energies (not through
ContactProblem): Q2 hexahedra on the C-box [0, 2] x [0, 0.7] x [0, 0.7] with ``nx x ny x nz``
cells, medium where x >= 0.1 and 0.1 <= z <= 0.6 (DESIGN §12; E = 5,
nu = 0.3, gamma 1e-6, rotation regularization, alpha_r = 1), face x = 0 clamped, the end face
of the upper arm (x = 2, z >= 0.6) moved by (0, 0, -0.01): the Newton step of a load increment,
lifted as in the package. ``state``: ``reference`` (u = 0) or ``deformed`` (u_z = -0.8 (x/2)^2 times
the height above the lower wall within the medium: the upper arm lowered by 0.4 (x/2)^2, the medium
under it compressed by up to 80 %, J >= 0.2; when the walls are whole cells, else the kink falls
inside solid cells).

Usage::

    python bench/solvers3d_case.py NXxNYxNZ STATE SOLVER OUT.json [--save-solution FILE.npy] [--compare FILE.npy]

SOLVER: a key of :data:`SOLVERS`. The solution is compared (by node position, so across rank
counts) with one saved by an earlier run, e.g. the direct solver's.
"""
from __future__ import annotations

import json
import resource
import sys
import time

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx_sfvem as sf
from dolfinx_sfvem import _compat
from dolfinx_sfvem.path_following.snes import negative_pivots
from dolfinx_sfvem.path_following.linear_solvers import configure_ksp, linear_solver_options, rigid_body_modes

WALL = 0.1
E, NU, GAMMA = 5.0, 0.3, 1e-6
SOLID, MEDIUM = 1, 2


def tangent(grid: tuple[int, int, int], state: str, comm: MPI.Comm = MPI.COMM_WORLD):
    """(A, b, V): the lifted tangent system of the module docstring and its space, on ``grid``
    (cells along x, y, z; the walls are whole cells when 0.1 is a multiple of 2 / nx and 0.7 / nz)."""
    mesh = dolfinx.mesh.create_box(comm, [np.zeros(3), np.array([2.0, 0.7, 0.7])], list(grid),
                                   dolfinx.mesh.CellType.hexahedron)
    tdim = 3
    n_cells = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
    mid = dolfinx.mesh.compute_midpoints(mesh, tdim, np.arange(n_cells, dtype=np.int32))
    medium = (mid[:, 0] >= WALL) & (mid[:, 2] >= WALL) & (mid[:, 2] <= 0.7 - WALL)
    tags = dolfinx.mesh.meshtags(mesh, tdim, np.arange(n_cells, dtype=np.int32),
                                 np.where(medium, MEDIUM, SOLID).astype(np.int32))
    V = _compat.vector_function_space(mesh, 2)
    u, v, du = dolfinx.fem.Function(V), ufl.TestFunction(V), ufl.TrialFunction(V)
    if state == "deformed":
        def lowered(x):
            s = np.clip((x[2] - WALL) / (0.7 - 2 * WALL), 0.0, 1.0) * (0.7 - 2 * WALL)
            return np.vstack([0 * x[0], 0 * x[0], -0.8 * (x[0] / 2) ** 2 * s])
        u.interpolate(lowered)
    K, mu = E / (3 * (1 - 2 * NU)), E / (2 * (1 + NU))
    solid = sf.Hyperelastic(K=K, mu=mu)
    med = sf.ThirdMedium(mu=mu, gamma=GAMMA, alpha_r=1.0, regularization="rotation")
    F = ufl.variable(ufl.Identity(3) + ufl.grad(u))
    G = ufl.grad(ufl.grad(u))
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=tags, metadata={"quadrature_degree": 4})
    Pi = solid.psi(F, G, solid.params) * dx(SOLID) + med.psi(F, G, med.params) * dx(MEDIUM)
    R = ufl.derivative(Pi, u, v)
    a = dolfinx.fem.form(ufl.derivative(R, u, du))
    L = dolfinx.fem.form(-R)
    fdim = tdim - 1
    clamped = dolfinx.mesh.locate_entities_boundary(mesh, fdim, lambda x: np.isclose(x[0], 0.0))
    end = dolfinx.mesh.locate_entities_boundary(mesh, fdim, lambda x: np.isclose(x[0], 2.0) & (x[2] >= 0.7 - WALL - 1e-9))
    zero, step = dolfinx.fem.Function(V), dolfinx.fem.Function(V)
    step.interpolate(lambda x: np.vstack([0 * x[0], 0 * x[0], -0.01 + 0 * x[0]]))
    bcs = [dolfinx.fem.dirichletbc(zero, dolfinx.fem.locate_dofs_topological(V, fdim, clamped)),
           dolfinx.fem.dirichletbc(step, dolfinx.fem.locate_dofs_topological(V, fdim, end))]
    A = dolfinx.fem.petsc.assemble_matrix(a, bcs=bcs)
    A.assemble()
    b = dolfinx.fem.petsc.assemble_vector(L)
    dolfinx.fem.petsc.apply_lifting(b, [a], bcs=[bcs])
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    dolfinx.fem.petsc.set_bc(b, bcs)
    return A, b, V


def owned_coordinates(V) -> np.ndarray:
    n = V.dofmap.index_map.size_local
    return V.tabulate_dof_coordinates()[:n]


def gathered_solution(x: PETSc.Vec, V) -> np.ndarray | None:
    """The solution on rank 0 ordered by node coordinates (independent of the partition)."""
    comm = x.getComm().tompi4py()
    X = owned_coordinates(V)
    vals = x.getArray(readonly=True).reshape(-1, 3)
    allX, allv = comm.gather(X, root=0), comm.gather(vals.copy(), root=0)
    if comm.rank != 0:
        return None
    X, vals = np.concatenate(allX), np.concatenate(allv)
    order = np.lexsort(np.round(X, 9).T[::-1])
    return vals[order]


#: solver name -> PETSc options; "iterative" and "direct" are the package's presets (direct: MUMPS
#: LDL^T), "gamg" the previous 'iterative' preset (GMRES + GAMG on the whole tangent), capped at 300
#: iterations here
SOLVERS = {
    "direct": {"ksp_type": "preonly", "pc_type": "cholesky", "pc_factor_mat_solver_type": "mumps"},
    "iterative": linear_solver_options("iterative"),
    "gamg": {"ksp_type": "gmres", "ksp_gmres_restart": "200", "ksp_rtol": "1e-10", "ksp_max_it": "300",
             "pc_type": "gamg", "pc_gamg_threshold": "0.01", "mg_levels_ksp_type": "chebyshev",
             "mg_levels_pc_type": "jacobi", "mg_levels_ksp_max_it": "3"},
}
PREFIX = "s3d_"


def main(argv: list[str]) -> None:
    grid, state, solver, out = argv[0], argv[1], argv[2], argv[3]
    comm = MPI.COMM_WORLD
    t0 = time.perf_counter()
    A, b, V = tangent(tuple(int(k) for k in grid.split("x")), state, comm)
    t_assemble = time.perf_counter() - t0
    n_owned_nodes = V.dofmap.index_map.size_local
    A.setNearNullSpace(rigid_body_modes(V.tabulate_dof_coordinates(), n_owned_nodes, A.createVecRight))
    mem_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    db = PETSc.Options()
    for k, val in SOLVERS[solver].items():
        db[PREFIX + k] = val
    ksp = PETSc.KSP().create(comm)
    ksp.setOptionsPrefix(PREFIX)
    ksp.setOperators(A)
    if SOLVERS[solver].get("pc_type") == "mg":
        configure_ksp(ksp, _compat.interpolation_matrix(_compat.vector_function_space(V.mesh, 1), V))
    ksp.setFromOptions()
    x = A.createVecRight()
    comm.Barrier()
    t0 = time.perf_counter()
    ksp.setUp()
    comm.Barrier()
    t_setup = time.perf_counter() - t0
    pc = ksp.getPC()
    negative = negative_pivots(pc) if solver == "direct" else None
    t0 = time.perf_counter()
    ksp.solve(b, x)
    comm.Barrier()
    t_solve = time.perf_counter() - t0
    r = b.duplicate()
    A.mult(x, r)
    r.aypx(-1.0, b)
    peak = comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, op=MPI.SUM) / 1024
    record = dict(grid=grid, unknowns=A.getSize()[0], ranks=comm.size, state=state, solver=solver,
                  assemble_s=t_assemble, setup_s=t_setup, solve_s=t_solve, iterations=ksp.getIterationNumber(),
                  reason=int(ksp.getConvergedReason()), rel_residual=r.norm() / b.norm(),
                  negative_pivots=negative, peak_MB=peak, before_solver_MB=comm.allreduce(mem_before, op=MPI.SUM) / 1024)
    sol = gathered_solution(x, V)
    if comm.rank == 0:
        if "--save-solution" in argv:
            np.save(argv[argv.index("--save-solution") + 1], sol)
        if "--compare" in argv:
            ref = np.load(argv[argv.index("--compare") + 1])
            record["rel_error"] = float(np.linalg.norm(sol - ref) / np.linalg.norm(ref))
        with open(out, "w") as f:
            json.dump(record, f)
        print(json.dumps(record), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
