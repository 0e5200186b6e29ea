"""One benchmark process: one geometry, one method, one or more mesh sizes (run by ``run.py``).

Usage::

    python3 bench/case.py --geometry cbox --method vem --h 0.1 0.07 --json out.json [--startup-only]
    mpirun -n 2 python3 bench/case.py ... --no-load-path

For every size, in this process and in this order:

1. setup, split into stages by wrapping the functions that do them (mesh generation,
   DOLFINx mesh, function space, SFVEM projections and choice of l, quadrature, FFCx
   kernel or form compilation, gmsh remeshing for the FEM, matrix pattern);
2. the first residual and the first tangent at the deformed state of
   :func:`problems.set_deformed_state` (they include numba compilation or cache loading);
3. (not with ``--startup-only``) residual and tangent again, repeatedly: the smallest
   wall and CPU time; then a few more calls timed piece by piece on every rank;
4. (not with ``--startup-only`` or ``--no-load-path``) the load path of the geometry from
   the undeformed state, its time split into assembly (the discretization's residual and
   jacobian, wrapped), linear solve (PETSc events KSPSetUp + PCSetUp + KSPSolve: MUMPS
   LU factorization and solve) and the rest;
5. (not with ``--startup-only``) the repeated timing of step 3 once more, after the load
   path: the minima over both passes are kept, so a transient slowdown of the shared
   machine during one pass does not count;
6. the peak resident set size of the process so far.

Times of collective work are the largest over the ranks. Rank 0 writes the JSON.
"""
import time

_START = {"wall": time.perf_counter(), "cpu": time.process_time()}

import argparse  # noqa: E402
import json  # noqa: E402
import pathlib  # noqa: E402
import sys  # noqa: E402
import typing  # noqa: E402

_BENCH = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(_BENCH), str(_BENCH.parent)]     # bench modules; the package from this checkout

import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402

import dolfinx  # noqa: E402
import dolfinx.fem  # noqa: E402
import dolfinx.fem.petsc  # noqa: E402
import dolfinx_sfvem as sf  # noqa: E402
import dolfinx_sfvem._compat  # noqa: E402
import dolfinx_sfvem.discretizations.fem  # noqa: E402
import dolfinx_sfvem.discretizations.space  # noqa: E402
import dolfinx_sfvem.discretizations.vem  # noqa: E402

import instrument  # noqa: E402
import problems  # noqa: E402
from geometries import GEOMETRIES  # noqa: E402

_IMPORTS = instrument.since(_START)

#: PETSc events of the linear solve inside SNES; measured disjoint in PETSc 3.18 (the LU
#: factorization, PCSetUp, is logged neither inside KSPSetUp nor inside KSPSolve)
LINEAR_SOLVE_EVENTS = ("KSPSetUp", "PCSetUp", "KSPSolve")
#: reported for information: the numeric LU factorization (inside PCSetUp), the line
#: search (its residuals included) and SNES in total
INFO_EVENTS = ("MatLUFactorNum", "SNESLineSearch", "SNESSolve")


def patch_setup_stages(timer: instrument.StageTimer, method: str) -> None:
    """Wrap the functions that do the set-up stages of ``method``."""
    timer.patch(dolfinx_sfvem._compat, "vector_function_space", "function_space")
    if method == "vem":
        timer.patch(sf.PolygonMesh, "to_dolfinx", "dolfinx_mesh")
        timer.patch(dolfinx_sfvem.discretizations.space, "build_projections", "projections")
        timer.patch(dolfinx_sfvem.discretizations.space, "compressed_polygon_quadrature", "quadrature")
        timer.patch(dolfinx_sfvem.discretizations.vem, "compile_kernels", "kernels")
        timer.patch(dolfinx_sfvem.discretizations.vem, "basis_derivative_tables", "basis_tables")
    else:
        timer.patch(dolfinx_sfvem.discretizations.fem, "matched_triangulation", "remesh")
        timer.patch(dolfinx_sfvem._compat, "create_mesh_partitioned", "dolfinx_mesh")
        timer.patch(dolfinx_sfvem.discretizations.fem.LagrangeDiscretization, "_build_forms", "forms")


def build_problem(geometry: str, h: float, method: str, comm: MPI.Comm,
                  timer: instrument.StageTimer) -> sf.ContactProblem:
    """Mesh, discretization and boundary conditions, timed as stages ``mesh`` and ``discretization``."""
    with timer.stage("mesh"):
        bench = problems.mesh(geometry, h)
    with timer.stage("discretization"):
        problem = sf.ContactProblem(bench.mesh, problems.materials(geometry), method=method, comm=comm,
                                    verbose=False)
    problems.add_boundary_conditions(problem, geometry, bench)
    return problem


def setup(geometry: str, h: float, method: str, comm: MPI.Comm
          ) -> tuple[sf.ContactProblem, PETSc.Mat, dict[str, instrument.Times]]:
    """The problem and its tangent matrix, with the wall/CPU time of every set-up stage."""
    with instrument.StageTimer() as timer:
        patch_setup_stages(timer, method)
        problem = build_problem(geometry, h, method, comm, timer)
        with timer.stage("matrix"):
            A = problem.disc.create_matrix()
    return problem, A, instrument.stages_over_ranks(timer.times, comm)


def assembly_calls(problem: sf.ContactProblem, A: PETSc.Mat
                   ) -> tuple[typing.Callable[[], object], typing.Callable[[], None]]:
    """Residual and tangent at the deformed state, as argument-free calls (no constrained rows)."""
    disc = problem.disc
    problems.set_deformed_state(problem)
    b = disc.create_vector()
    return (lambda: disc.residual(problem.x, b)), (lambda: disc.jacobian(problem.x, A))


def time_assembly(residual: typing.Callable, jacobian: typing.Callable, comm: MPI.Comm, min_total: float) -> dict:
    """Smallest wall/CPU time of repeated residual and tangent assemblies."""
    return {"residual": instrument.best_of(residual, comm, min_total=min_total),
            "jacobian": instrument.best_of(jacobian, comm, min_total=min_total)}


def assembly_parts(method: str) -> tuple[tuple[object, str, str], ...]:
    """(owner, function, part) of the pieces of one residual and one tangent assembly."""
    if method == "vem":
        return ((dolfinx_sfvem.discretizations.vem, "residual_loop", "residual_loop"),
                (dolfinx_sfvem.discretizations.vem, "folded_elements", "injectivity_guard"),
                (dolfinx_sfvem.discretizations.vem, "tangent_loop", "tangent_loop"),
                (dolfinx_sfvem._compat, "mat_set_values_coo", "matrix_insert"))
    return ((dolfinx.fem.petsc, "assemble_vector", "residual_form"),
            (dolfinx.fem, "assemble_scalar", "energy_form"),
            (dolfinx_sfvem._compat.CompiledExpression, "__call__", "det_F"),
            (dolfinx_sfvem.discretizations.fem, "folded_elements", "injectivity_guard"),
            (dolfinx.fem.petsc, "assemble_matrix", "tangent_form"))


def assembly_breakdown(method: str, residual: typing.Callable, jacobian: typing.Callable, comm: MPI.Comm,
                       calls: int = 3) -> dict[str, list[float]]:
    """Wall time per call (ms) of the residual, the tangent and their pieces, on every rank.

    Pieces: SFVEM compiled polygon loops (force vector, energy and J in one pass) and the
    COO insertion into the PETSc matrix (the rest of the tangent is mostly ``MatAssembly``);
    FEM residual, energy and tangent forms and det F at the quadrature points and nodes;
    both: the injectivity guard of the residual. Separate from the repeated timing (the
    wrappers cost a few µs per call).
    """
    with instrument.StageTimer() as timer:
        for owner, name, part in assembly_parts(method):
            timer.patch(owner, name, part)
        for _ in range(calls):
            with timer.stage("residual"):
                residual()
            with timer.stage("jacobian"):
                jacobian()
    return {part: comm.allgather(1e3 * t["wall"] / calls) for part, t in timer.times.items()}


def run_load_path(problem: sf.ContactProblem, geometry: str, comm: MPI.Comm) -> dict:
    """The geometry's load path from the undeformed state, its time split by kind of work."""
    spec = GEOMETRIES[geometry]
    problem.set_displacement(0.0, 0.0)
    events = LINEAR_SOLVE_EVENTS + INFO_EVENTS
    before = instrument.petsc_event_times(events)
    with instrument.StageTimer() as timer:
        timer.patch(problem.disc, "residual", "residual")
        timer.patch(problem.disc, "jacobian", "jacobian")
        result = problem.solve(spec.steps)
    after = instrument.petsc_event_times(events)
    event = {name: comm.allreduce(after[name] - before[name], op=MPI.MAX) for name in events}
    wall = {stage: comm.allreduce(t["wall"], op=MPI.MAX) for stage, t in timer.times.items()}
    assembly = wall.get("residual", 0.0) + wall.get("jacobian", 0.0)
    linear = sum(event[name] for name in LINEAR_SOLVE_EVENTS)
    return {"uy": spec.uy, "steps": spec.steps, "converged": bool(result.converged), "load": float(result.load),
            "attempts": len(result.attempts),
            "newton_iterations": int(sum(s["newton_iterations"] for s in result.attempts)),
            "residual_calls": timer.calls.get("residual", 0), "jacobian_calls": timer.calls.get("jacobian", 0),
            "wall": float(result.wall_time_s), "assembly_wall": assembly,
            "residual_wall": wall.get("residual", 0.0), "jacobian_wall": wall.get("jacobian", 0.0),
            "linear_solve_wall": linear, "lu_factorization_wall": event["MatLUFactorNum"],
            "line_search_wall": event["SNESLineSearch"], "snes_wall": event["SNESSolve"],
            "other_wall": float(result.wall_time_s) - assembly - linear}


def mesh_facts(problem: sf.ContactProblem, comm: MPI.Comm) -> dict:
    """Unknowns, cells, quadrature points of the energy and (SFVEM) the distribution of l."""
    disc = problem.disc
    facts = {"unknowns": int(disc.num_dofs_global)}
    if problem.method == "vem":
        facts["polygons"] = int(disc.space.polygon_mesh.n_polygons)
        facts["l_histogram"] = {str(k): int(v) for k, v in disc.space.l_histogram().items()}
        local_points = disc.space.x_q.shape[0]
    else:
        facts["triangles"] = int(disc.output_mesh.n_polygons)
        facts["fem_h"] = disc.mesh_size
        _, weights = dolfinx_sfvem._compat.reference_quadrature(disc.mesh, disc.quadrature_degree)
        local_points = dolfinx_sfvem._compat.num_owned_cells(disc.mesh) * weights.size
    facts["quadrature_points"] = int(comm.allreduce(local_points, op=MPI.SUM))
    return facts


def run_size(geometry: str, h: float, method: str, comm: MPI.Comm, args: argparse.Namespace) -> dict:
    """Every measurement of one mesh size (module docstring, steps 1-6)."""
    problem, A, stages = setup(geometry, h, method, comm)
    residual, jacobian = assembly_calls(problem, A)
    record = {"geometry": geometry, "method": method, "h": h, "ranks": comm.size, **mesh_facts(problem, comm),
              "setup": stages,
              "first_assembly": {"residual": instrument.time_collective(residual, comm),
                                 "jacobian": instrument.time_collective(jacobian, comm)},
              "min_J": residual().min_J}
    if not args.startup_only:
        passes = [time_assembly(residual, jacobian, comm, args.min_time)]
        record["assembly_breakdown_ms_per_rank"] = assembly_breakdown(method, residual, jacobian, comm)
        if not args.no_load_path:
            record["load_path"] = run_load_path(problem, geometry, comm)
            problems.set_deformed_state(problem)
        passes.append(time_assembly(residual, jacobian, comm, args.min_time))
        record["assembly"] = {part: instrument.best_of_passes([t[part] for t in passes]) for part in passes[0]}
    record["peak_rss_mb"] = comm.allreduce(instrument.peak_rss_mb(), op=MPI.MAX)
    record["peak_rss_mb_ranks"] = comm.allgather(instrument.peak_rss_mb())
    return record


def versions() -> dict:
    """Versions of the libraries whose speed is measured."""
    import ffcx
    import numba
    import petsc4py
    return {"dolfinx": dolfinx.__version__, "petsc": ".".join(map(str, PETSc.Sys.getVersion())),
            "petsc4py": petsc4py.__version__,
            "ffcx": ffcx.__version__, "numba": numba.__version__, "numpy": np.__version__,
            "mpi": MPI.Get_library_version().splitlines()[0].strip().strip("\x00")}


def parse_args(argv: typing.Sequence[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--geometry", choices=sorted(GEOMETRIES), required=True)
    p.add_argument("--method", choices=("vem", "fem"), required=True)
    p.add_argument("--h", type=float, nargs="+", required=True, help="solid mesh sizes, measured in this order")
    p.add_argument("--json", type=pathlib.Path, required=True, help="where rank 0 writes the measurements")
    p.add_argument("--startup-only", action="store_true", help="set-up and first assembly only")
    p.add_argument("--no-load-path", action="store_true", help="skip the load path")
    p.add_argument("--min-time", type=float, default=0.5,
                   help="least total wall time of the repeated assemblies per size (s, default %(default)s)")
    return p.parse_args(argv)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    comm = MPI.COMM_WORLD
    PETSc.Log.begin()
    sizes = [run_size(args.geometry, h, args.method, comm, args) for h in args.h]
    out = {"geometry": args.geometry, "method": args.method, "ranks": comm.size,
           "imports": instrument.max_over_ranks(_IMPORTS, comm),
           "process": instrument.max_over_ranks(instrument.since(_START), comm),
           "versions": versions(), "sizes": sizes}
    if comm.rank == 0:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
