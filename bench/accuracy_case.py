"""One run of the equal-accuracy benchmark (started by ``accuracy.py``, one fresh process each).

Usage::

    python3 bench/accuracy_case.py --record FILE --example KEY [--refine REGION:LEVELS ...] -- [demo options]

e.g. ``... --example cbox --refine solids:1 contact:2 -- --method vem --h 0.05 --uy -0.5 --out DIR``.
Runs the example's demo (``demos/<demo>.py``, its ``main``: defaults, outputs and all) with its
``build`` wrapped so that the regions named by ``--refine`` (``accuracy_plan.EXAMPLES``) are
split before the load path, one level at a time. Times, wall and CPU: ``setup`` (the demo's
``build``: mesh, discretization, and the refinement), ``solve`` (``ContactProblem.solve``: the
load path with its outputs). Writes FILE (rank 0) with those, the exit code and what the run
gave (from its summary.json): full load or not, unknowns, Newton iterations (failed attempts
included), final force and gap, the peak memory and the load average before and after.
"""
import time

_START = time.perf_counter()

import argparse  # noqa: E402
import importlib  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import pathlib  # noqa: E402
import sys  # noqa: E402
import typing  # noqa: E402

_BENCH = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(_BENCH), str(_BENCH.parent / "demos"), str(_BENCH.parent)]

from mpi4py import MPI  # noqa: E402

import dolfinx_sfvem as sf  # noqa: E402
from dolfinx_sfvem.output.run_summary import RunSummary, read_summary  # noqa: E402

import _common as common  # noqa: E402
import instrument  # noqa: E402
from accuracy_plan import EXAMPLES, Example  # noqa: E402


def refinement(text: str) -> tuple[str, int]:
    """``REGION:LEVELS`` -> (region, levels)."""
    region, _, levels = text.partition(":")
    if not levels.isdigit() or int(levels) < 1:
        raise argparse.ArgumentTypeError(f"expected REGION:LEVELS with LEVELS >= 1, got {text!r}")
    return region, int(levels)


def refined_build(example: Example, build: typing.Callable, refine: typing.Sequence[tuple[str, int]]) -> typing.Callable:
    """The demo's ``build`` followed by the local refinement ``refine`` (recorded in the parameters)."""
    def wrapped(args: argparse.Namespace):
        problem, observers = build(args)
        for region, levels in refine:
            where = example.regions[region]
            for _ in range(levels):
                problem.refine(where.marker, tags=list(where.tags))
        problem.parameters["local_refinement"] = [[r, k] for r, k in refine]
        return problem, observers
    return wrapped


def outcome(example: Example, summary: RunSummary | None) -> dict:
    """What the run gave: full load, load reached, unknowns, Newton iterations, final force and gap."""
    last = summary.final_step if summary else None
    if last is None:
        return {"converged": False, "load": 0.0, "message": summary.message if summary else "no summary.json",
                "unknowns": summary.dofs if summary else 0, "newton_iterations": summary.newton_iterations if summary else 0,
                "force": None, "gap": None, "summary_wall_s": summary.wall_time_s if summary else None}
    gap = last.extra.get(example.gap) if example.gap else (last.gap or {}).get("value")
    return {"converged": summary.converged, "load": summary.load_reached, "message": summary.message,
            "unknowns": last.dofs or summary.dofs, "newton_iterations": summary.newton_iterations,
            "steps": len(summary.converged_steps), "attempts": len(summary.steps), "force": last.force(example.force),
            "gap": gap, "summary_wall_s": summary.wall_time_s,
            "polygons": summary.discretization.get("polygons"), "cells": summary.discretization.get("cells")}


def main(argv: typing.Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--record", type=pathlib.Path, required=True, help="where rank 0 writes the record (JSON)")
    p.add_argument("--example", choices=tuple(EXAMPLES), required=True)
    p.add_argument("--refine", type=refinement, nargs="*", default=[], metavar="REGION:LEVELS")
    p.add_argument("demo_argv", nargs=argparse.REMAINDER, help="-- and the demo's options")
    args = p.parse_args(argv)
    example, demo_argv = EXAMPLES[args.example], args.demo_argv[1:] if args.demo_argv[:1] == ["--"] else args.demo_argv
    unknown = [r for r, _ in args.refine if r not in example.regions]
    if unknown:
        p.error(f"--refine: no region {', '.join(unknown)} in {args.example} (regions: {', '.join(example.regions)})")
    demo = importlib.import_module(example.demo)
    load_before = list(os.getloadavg())
    demo.build = refined_build(example, demo.build, args.refine)
    with instrument.StageTimer() as timer:
        timer.patch(demo, "build", "setup")
        timer.patch(sf.ContactProblem, "solve", "solve")
        code = common.exit_code(demo.main, demo_argv)
    comm = MPI.COMM_WORLD
    stages = instrument.stages_over_ranks(timer.times, comm)
    out = common.parse_args(demo.make_parser(), demo_argv).out
    if comm.rank == 0:
        record = {"example": args.example, "argv": demo_argv, "refine": [[r, k] for r, k in args.refine],
                  "exit_code": code, "ranks": comm.size,
                  "setup": stages.get("setup", {"wall": 0.0, "cpu": 0.0}),
                  "solve": stages.get("solve", {"wall": 0.0, "cpu": 0.0}),
                  "in_process_wall_s": time.perf_counter() - _START, "peak_rss_mb": instrument.peak_rss_mb(),
                  "load_average": {"before": load_before, "after": list(os.getloadavg())},
                  **outcome(example, read_summary(out))}
        args.record.parent.mkdir(parents=True, exist_ok=True)
        args.record.write_text(json.dumps(record, indent=1, default=float) + "\n")
    return code


if __name__ == "__main__":
    sys.exit(main())
