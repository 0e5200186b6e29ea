"""One size of the 3D C-box table: the first load step(s) of ``demos/cbox3d.py``, timed per Newton
iteration (run by ``cbox3d_sizes.py``, one process per case, so that its peak memory is its own).

Usage::

    python3 bench/cbox3d_sizes_case.py --json OUT.json --grid NXxNYxNZ --solver direct|iterative
                                       [--until 0.05] [-- more cbox3d options]

The demo's problem (point contact, Q2 hexahedra, rotation regularization, alpha_r = 10, its
adaptive load stepping with the first increment 1/20) at ``--gamma 1e-6`` on ``NX x NY x NZ``
cells, solved from the reference state to the load factor ``--until`` (default 0.05: the first
load step of the path) with ``--linear-solver SOLVER``, writing nothing. Before it, one residual
and one tangent of the same problem on the 20 x 1 x 7 grid (JIT form loading, numba), so that
those are not in the first iteration's time.

Measured (times of collective work: the largest over the ranks):

- ``newton_iterations`` (failed attempts included) and, per Newton solve, the Krylov iterations
  (``SNESGetLinearSolveIterations``; 1 per Newton iteration for the direct solver);
- ``assembly_s``: the tangent assemblies and every residual (those SNES asks for, Newton and line
  search, and the step's diagnostics), by wrapping them (``loadpath_case.patch_load_path``);
- ``path_s``: the whole load path (``path_cpu_s``: its CPU time, the largest over the ranks:
  what the wall time would be on cores the run has to itself); ``linear_s``: what of it is not
  assembly, contact check (``gap``) or reactions: the linear solves and SNES's own vector work
  (PETSc's events of the linear solve nest with the multigrid: its smoothers' and coarse level's
  KSPSolve and PCSetUp count again inside the outer ones, so their sum is no time);
- ``events_s``: PETSc's events KSPSetUp, PCSetUp, KSPSolve (summed over nested calls; with the
  direct solver they are disjoint and PCSetUp is the MUMPS factorization);
- ``peak_rss_mb``: each rank's peak resident set size (``getrusage``), after the build
  (``built_rss_mb``) and at the end.

Nothing is asserted.
"""
import time

_START = time.perf_counter()

import argparse  # noqa: E402
import functools  # noqa: E402
import json  # noqa: E402
import pathlib  # noqa: E402
import sys  # noqa: E402
import typing  # noqa: E402

_BENCH = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(_BENCH), str(_BENCH.parent / "demos"), str(_BENCH.parent)]

from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402

import dolfinx_sfvem.path_following.snes  # noqa: E402

import cbox3d  # noqa: E402
import instrument  # noqa: E402
from cbox3d_sizes import assembly_s, linear_s  # noqa: E402
from loadpath_case import LINEAR_SOLVE_EVENTS, patch_load_path  # noqa: E402

#: the grid of the warm-up: the coarsest with grid lines on the C's walls
WARM_UP_GRID = ("20", "1", "7")


def demo_args(grid: typing.Sequence[str], solver: str, extra: typing.Sequence[str]) -> argparse.Namespace:
    """The demo's options for ``grid`` (three cell counts) and ``solver``, gamma 1e-6, quiet."""
    return cbox3d.common.parse_args(cbox3d.make_parser(), ["--n", *grid, "--gamma", "1e-6", "--linear-solver",
                                                           solver, "--quiet", *extra])


def warm_up(solver: str, extra: typing.Sequence[str], comm: MPI.Comm) -> None:
    """One residual and one tangent on the warm-up grid (module docstring)."""
    problem, _ = cbox3d.build(demo_args(WARM_UP_GRID, solver, extra), comm)
    disc = problem.disc
    disc.residual(problem.x, disc.create_vector())
    disc.assemble_tangent(problem.x, disc.create_matrix())


def count_krylov(solves: list[tuple[int, int]]) -> typing.Callable[[], None]:
    """Wrap ``SNESNewton._solve_once`` so that each Newton solve appends (Newton iterations, Krylov
    iterations) to ``solves``; returns the function that restores it."""
    original = dolfinx_sfvem.path_following.snes.SNESNewton._solve_once

    @functools.wraps(original)
    def counted(self, *args, **kwargs):
        try:
            return original(self, *args, **kwargs)
        finally:
            solves.append((int(self.snes.getIterationNumber()), int(self.snes.getLinearSolveIterations())))

    dolfinx_sfvem.path_following.snes.SNESNewton._solve_once = counted
    return lambda: setattr(dolfinx_sfvem.path_following.snes.SNESNewton, "_solve_once", original)


def run(grid: typing.Sequence[str], solver: str, until: float, extra: typing.Sequence[str], comm: MPI.Comm) -> dict:
    """Build, warm up, solve to ``until`` and return the measurements (module docstring)."""
    warm_up(solver, extra, comm)
    args = demo_args(grid, solver, extra)
    t0 = time.perf_counter()
    problem, _ = cbox3d.build(args, comm)
    build_s = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    built_rss = comm.allgather(instrument.peak_rss_mb())
    PETSc.Log.begin()
    before = instrument.petsc_event_times(LINEAR_SOLVE_EVENTS)
    solves: list[tuple[int, int]] = []
    restore = count_krylov(solves)
    try:
        with instrument.StageTimer() as timer:
            patch_load_path(timer, problem.disc)
            comm.barrier()
            t0, c0 = time.perf_counter(), time.process_time()
            result = problem.solve(control=cbox3d.common.load_stepping(args), until=until)
            path_s = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
            path_cpu_s = comm.allreduce(time.process_time() - c0, op=MPI.MAX)
    finally:
        restore()
    after = instrument.petsc_event_times(LINEAR_SOLVE_EVENTS)
    events = {k: comm.allreduce(after[k] - before[k], op=MPI.MAX) for k in after}
    wall = {k: v["wall"] for k, v in instrument.stages_over_ranks(timer.times, comm).items()}
    last = result.steps[-1] if result.steps else {}
    return {"grid": "x".join(grid), "solver": solver, "ranks": comm.size, "gamma": args.gamma, "until": until,
            "extra": list(extra), "unknowns": int(problem.disc.num_dofs_global),
            "converged": bool(result.converged), "load": float(result.load), "steps": len(result.steps),
            "attempts": len(result.attempts),
            "newton_iterations": int(sum(a["newton_iterations"] for a in result.attempts)),
            "solves": solves, "build_s": build_s, "path_s": path_s, "path_cpu_s": path_cpu_s,
            "assembly_s": assembly_s(wall), "stages_s": wall, "linear_s": linear_s(path_s, wall),
            "events_s": events,
            "reaction": last.get("reaction", {}).get("load"), "gap": (last.get("gap") or {}).get("value"),
            "negative_pivots": last.get("negative_pivots"),
            "built_rss_mb": built_rss, "peak_rss_mb": comm.allgather(instrument.peak_rss_mb()),
            "process_s": comm.allreduce(time.perf_counter() - _START, op=MPI.MAX)}


def main(argv: typing.Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    split = argv.index("--") if "--" in argv else len(argv)
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--json", type=pathlib.Path, required=True, help="where rank 0 writes the measurements")
    p.add_argument("--grid", required=True, help="cells NXxNYxNZ (nx a multiple of 20, nz of 7)")
    p.add_argument("--solver", choices=("direct", "iterative"), required=True)
    p.add_argument("--until", type=float, default=0.05, help="load factor to reach (default %(default)s)")
    args = p.parse_args(argv[:split])
    comm = MPI.COMM_WORLD
    record = run(args.grid.split("x"), args.solver, args.until, argv[split + 1:], comm)
    if comm.rank == 0:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(record, indent=1, default=float))
        print(json.dumps({k: v for k, v in record.items() if k != "stages_s"}, default=float), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
