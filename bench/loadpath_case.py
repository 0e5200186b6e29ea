"""One load-path measurement: one demo, one method, one line search (run by ``loadpath.py``).

Usage::

    python3 bench/loadpath_case.py --json out.json -- DEMO [demo options and PETSc options]

e.g. ``... -- multi_object --method vem --h 0.04 --steps 30 -tmc_snes_linesearch_type bt``.
The demo's own ``build`` makes the problem (``demos/<DEMO>.py``); the load path is solved
with ``problem.solve`` writing its usual outputs, while the functions doing each part of a
Newton iteration are wrapped and timed (``instrument.StageTimer``, inclusive times):

- ``residual``: every residual assembly of the discretization (injectivity guard inside),
  ``residual_snes``: the ones SNES asks for (Newton + line search), the rest are the
  final-state diagnostics, the reactions and the initial check;
- ``injectivity``: the folded-element guard (inside ``residual``);
- ``tangent``: the tangent assembly;
- ``gap``: the contact check of every converged trial state (gap and pressure);
- ``reactions``, ``output`` (XDMF, checkpoint, summary, CSV per step), ``output_final``
  (pictures at the end);
- ``solve_s``: the whole ``problem.solve`` (the time to full load a user waits for, after
  set-up and a first residual and tangent on a coarser mesh that hold numba's compilation or
  cache loading);
- linear solve from PETSc's events: factorization (PCSetUp) + solve (KSPSolve, KSPSetUp).

Also recorded: set-up time (mesh + discretization), unknowns, Newton iterations (failed
attempts included), load reached, the last reaction of each condition, the peak resident
set size. Nothing is asserted here.
"""
import time

_START = time.perf_counter()

import argparse  # noqa: E402
import importlib  # noqa: E402
import json  # noqa: E402
import pathlib  # noqa: E402
import sys  # noqa: E402
import types  # noqa: E402
import typing  # noqa: E402

_BENCH = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(_BENCH), str(_BENCH.parent / "demos"), str(_BENCH.parent)]

from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402

import dolfinx_sfvem as sf  # noqa: E402
import dolfinx_sfvem.discretizations.fem  # noqa: E402
import dolfinx_sfvem.problem  # noqa: E402
import dolfinx_sfvem.output.run_output  # noqa: E402
import dolfinx_sfvem.path_following.snes  # noqa: E402
import dolfinx_sfvem.discretizations.vem  # noqa: E402

import _common as common  # noqa: E402
import instrument  # noqa: E402

#: PETSc events of the linear solve (disjoint in PETSc 3.18: the factorization is PCSetUp)
LINEAR_SOLVE_EVENTS = ("KSPSetUp", "PCSetUp", "KSPSolve")


def patch_load_path(timer: instrument.StageTimer, disc: object) -> None:
    """Wrap the functions doing the parts of a load step (module docstring)."""
    timer.patch(type(disc), "residual", "residual")
    timer.patch(type(disc), "assemble_tangent", "tangent")
    timer.patch(dolfinx_sfvem.path_following.snes.SNESNewton, "_residual", "residual_snes")
    timer.patch(dolfinx_sfvem.discretizations.vem, "folded_elements", "injectivity")
    timer.patch(dolfinx_sfvem.discretizations.fem, "folded_elements", "injectivity")
    timer.patch(sf.ContactProblem, "contact_state", "gap")
    timer.patch(sf.ContactProblem, "reactions", "reactions")
    timer.patch(dolfinx_sfvem.output.run_output.RunWriter, "step", "output")
    timer.patch(dolfinx_sfvem.output.run_output.RunWriter, "finish", "output_final")


def warm_up(demo: types.ModuleType, args: argparse.Namespace) -> None:
    """One residual and one tangent of the same demo on a 4 times coarser mesh, so that numba's
    compilation (or cache loading) and the JIT-compiled energy are not in the load path's
    times (timed separately as ``first_assembly_s``), and the peak memory is the load path's:
    a warm-up on the measured mesh itself would allocate a second tangent (+68 MB on the
    multi-object SFVEM's peak)."""
    problem, _ = demo.build(argparse.Namespace(**{**vars(args), "h": 4 * args.h, "quiet": True}))
    disc = problem.disc
    disc.residual(problem.x, disc.create_vector())
    disc.assemble_tangent(problem.x, disc.create_matrix())


def run(demo_argv: typing.Sequence[str], comm: MPI.Comm) -> dict:
    """Build the demo's problem, solve its load path, and return the measurements."""
    name, argv = demo_argv[0], list(demo_argv[1:])
    demo = importlib.import_module(name)
    args = common.parse_args(demo.make_parser(), argv)
    t0 = time.perf_counter()
    problem, observers = demo.build(args)
    setup = time.perf_counter() - t0
    t0 = time.perf_counter()
    warm_up(demo, args)
    first = time.perf_counter() - t0
    PETSc.Log.begin()
    before = instrument.petsc_event_times(LINEAR_SOLVE_EVENTS)
    with instrument.StageTimer() as timer:
        patch_load_path(timer, problem.disc)
        t0 = time.perf_counter()
        result = problem.solve(args.steps, out=args.out, observers=observers)
        solve = time.perf_counter() - t0
    after = instrument.petsc_event_times(LINEAR_SOLVE_EVENTS)
    linear = {k: comm.allreduce(after[k] - before[k], op=MPI.MAX) for k in after}
    stages = instrument.stages_over_ranks(timer.times, comm)
    last = result.steps[-1] if result.steps else {}
    return {"demo": name, "argv": argv, "quadrature_points": int(comm.allreduce(
                problem.disc.space.x_q.shape[0], op=MPI.SUM)) if args.method == "vem" else None, "method": args.method, "ranks": comm.size,
            "unknowns": int(problem.disc.num_dofs_global), "setup_s": comm.allreduce(setup, op=MPI.MAX),
            "first_assembly_s": comm.allreduce(first, op=MPI.MAX), "solve_s": comm.allreduce(solve, op=MPI.MAX),
            "converged": bool(result.converged), "load": float(result.load), "message": result.message,
            "load_path_s": float(result.wall_time_s),
            "steps": len(result.steps), "attempts": len(result.attempts),
            "newton_iterations": int(sum(a["newton_iterations"] for a in result.attempts)),
            "calls": {k: comm.allreduce(v, op=MPI.MAX) for k, v in sorted(timer.calls.items())},
            "wall_s": {k: v["wall"] for k, v in stages.items()},
            "linear_solve_s": sum(linear.values()), "factorization_s": linear["PCSetUp"],
            "reaction": last.get("reaction", {}), "gap": (last.get("gap") or {}).get("value"),
            "peak_rss_mb": comm.allreduce(instrument.peak_rss_mb(), op=MPI.MAX),
            "process_s": time.perf_counter() - _START}


def main(argv: typing.Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if "--" not in argv:
        raise SystemExit("usage: loadpath_case.py --json FILE -- DEMO [demo options]")
    split = argv.index("--")
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--json", type=pathlib.Path, required=True, help="where rank 0 writes the measurements")
    args = p.parse_args(argv[:split])
    comm = MPI.COMM_WORLD
    record = run(argv[split + 1:], comm)
    if comm.rank == 0:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(record, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
