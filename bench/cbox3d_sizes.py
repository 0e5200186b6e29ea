"""The 3D C-box by size: unknowns, Newton iterations, time per Newton iteration, peak memory, on 1 and
2 ranks, direct (MUMPS LDL^T) and iterative (GMRES + p-multigrid) linear solver, gamma 1e-6.

Usage::

    python3 bench/cbox3d_sizes.py [--cases GRID:RANKS:SOLVER ...] [--until 0.05] [--out DIR] [--results DIR]

Every case is a fresh process of ``cbox3d_sizes_case.py`` (the first load step of
``demos/cbox3d.py``'s point contact, Q2 hexahedra, on ``GRID`` = ``NXxNYxNZ`` cells, 1 or 2 ranks,
``SOLVER`` direct or iterative), so that its peak memory is its own. The default cases double the
unknowns from 9 k to 204 k (dolfiny's 40 x 14 x 14 grid); the direct solver stops at 55 k, where
one factorization takes about a minute (at 103 k it took 7 minutes, bench/solvers3d.md). Ordered so
that an interrupted run has the smaller sizes complete; a rerun skips the cases already in
``DIR/cbox3d_sizes.json`` (appended as each finishes). Writes ``DIR/cbox3d_sizes.md`` (the
table, with the ratios between its rows: time per iteration against the smallest grid of the same
solver and ranks, iterative against direct at the same grid and ranks); ``--results DIR`` copies
both there. Times as measured, never asserted; run it alone on the machine (``make bench`` runs it).
"""
from __future__ import annotations

import argparse
import json
import pathlib
import subprocess
import sys
import typing

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from dolfinx_sfvem import mpi_launcher  # noqa: E402
from case_store import CaseStore, machine  # noqa: E402

#: GRID:RANKS:SOLVER of the default run, by priority: the sizes up to 33 k unknowns with both
#: solvers, dolfiny's grid on 2 ranks, 55 k with both, then the iterative solver's other large cases
DEFAULT_CASES = tuple(f"{grid}:{ranks}:{solver}" for grid in ("20x2x7", "20x4x7", "40x4x7")
                      for ranks in (1, 2) for solver in ("direct", "iterative")) + \
    ("40x14x14:2:iterative",) + tuple(f"40x7x7:{ranks}:{solver}" for ranks in (1, 2) for solver in ("direct", "iterative")) + \
    ("40x7x14:2:iterative", "40x7x14:1:iterative", "40x14x14:1:iterative")


def run_case(out: pathlib.Path, grid: str, ranks: int, solver: str, until: float) -> dict | None:
    """Run one case in its own process; its record, or None if it failed (log in ``out``)."""
    name = f"{grid}_{ranks}_{solver}"
    cmd = [*mpi_launcher.command(ranks if ranks > 1 else None), sys.executable, str(HERE / "cbox3d_sizes_case.py"),
           "--json", str(out / f"{name}.json"), "--grid", grid, "--solver", solver, "--until", str(until)]
    (out / f"{name}.json").unlink(missing_ok=True)
    with open(out / f"{name}.log", "w") as f:
        code = subprocess.call(cmd, stdout=f, stderr=subprocess.STDOUT, env=mpi_launcher.job_environment(OMP_NUM_THREADS="1"))
    if code != 0 or not (out / f"{name}.json").exists():
        return None
    return json.loads((out / f"{name}.json").read_text())


def assembly_s(stages: dict[str, float]) -> float:
    """The tangent assemblies and every residual (s), from the stages' wall times."""
    return stages.get("tangent", 0.0) + stages.get("residual", 0.0)


def linear_s(path_s: float, stages: dict[str, float]) -> float:
    """The load path's time that is not assembly, contact check or reactions (s): the linear solves."""
    return path_s - assembly_s(stages) - stages.get("gap", 0.0) - stages.get("reactions", 0.0)


def factorization_s(r: dict) -> float | None:
    """The direct solver's factorizations (s; PETSc's PCSetUp, disjoint from its KSPSolve there; the
    multigrid's events nest, None)."""
    if r["solver"] != "direct":
        return None
    return r["events_s"]["PCSetUp"] if "events_s" in r else r["setup_s"]


def per_iteration(r: dict) -> float:
    """Wall time of the load path per Newton iteration (s)."""
    return r["path_s"] / max(r["newton_iterations"], 1)


def markdown(records: typing.Sequence[dict], machine: str) -> str:
    """The table: one row per case, by size, ranks and solver, with the ratios of the module docstring."""
    def key(r):
        return r["grid"], r["ranks"], r["solver"]
    by_key = {key(r): r for r in records}
    smallest = {}
    for r in sorted(records, key=lambda r: r["unknowns"]):
        smallest.setdefault((r["ranks"], r["solver"]), r)
    lines = ["# The 3D C-box by size (bench/cbox3d_sizes.py)", "",
             "The first load step of `demos/cbox3d.py`'s point contact (load factor 0 to 0.05, the corner moved by "
             "(0, 0.0125, -0.05)), Q2 hexahedra, gamma 1e-6, rotation regularization with alpha_r = 10, from the "
             f"reference state; {machine}. Newton: iterations of the step (failed attempts included); Krylov: "
             "GMRES iterations per Newton iteration (mean, and the largest Newton solve's mean); per it.: the "
             "load path's wall time per Newton iteration (CPU: its CPU time, largest rank: the wall time on cores "
             "the run has to itself), of it assembly (tangent and every residual) and "
             "linear solve (the rest but the contact check and reactions); factor.: of that the MUMPS LDL^T "
             "factorizations of the direct solver; vs smallest: per-iteration time over that of the smallest grid with the same "
             "ranks and solver; it./dir.: iterative over direct at the same grid and ranks; peak MB: the "
             "largest resident set of one rank, and the sum over the ranks. Compare rows of one run.", "",
             "| grid | unknowns | ranks | solver | Newton | Krylov per it. | s per it. | CPU s per it. | assembly s/it. | "
             "linear s/it. | factor. s/it. | vs smallest | it./dir. | peak MB (rank) | peak MB (sum) |",
             "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in sorted(records, key=lambda r: (r["unknowns"], r["ranks"], r["solver"])):
        n = max(r["newton_iterations"], 1)
        krylov = "-"
        if r["solver"] == "iterative":
            means = [k / i for i, k in r["solves"] if i > 0]
            krylov = f"{sum(k for _, k in r['solves']) / n:.0f} ({max(means):.0f})" if means else "-"
        ratio = per_iteration(r) / per_iteration(smallest[(r["ranks"], r["solver"])])
        direct = by_key.get((r["grid"], r["ranks"], "direct"))
        versus = f"{per_iteration(r) / per_iteration(direct):.2f}" if r["solver"] == "iterative" and direct else "-"
        newton = f"{r['newton_iterations']}" + ("" if r["converged"] else " (not converged)")
        factor = "-" if factorization_s(r) is None else f"{factorization_s(r) / n:.1f}"
        cpu = f"{r['path_cpu_s'] / n:.1f}" if "path_cpu_s" in r else "-"
        lines.append(f"| {r['grid']} | {r['unknowns']:,} | {r['ranks']} | {r['solver']} | {newton} | {krylov} | "
                     f"{per_iteration(r):.1f} | {cpu} | {assembly_s(r['stages_s']) / n:.1f} | "
                     f"{linear_s(r['path_s'], r['stages_s']) / n:.1f} | {factor} | {ratio:.1f} | {versus} | "
                     f"{max(r['peak_rss_mb']):.0f} | "
                     f"{sum(r['peak_rss_mb']):.0f} |")
    return "\n".join(lines) + "\n"


def parse_args(argv: typing.Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(DEFAULT_CASES), help="NXxNYxNZ:RANKS:SOLVER")
    parser.add_argument("--until", type=float, default=0.05, help="load factor of each case (default %(default)s)")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/cbox3d_sizes"))
    parser.add_argument("--results", type=pathlib.Path, default=None)
    return parser.parse_args(argv)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    store = CaseStore(args.out, "cbox3d_sizes")
    done = {(r["grid"], r["ranks"], r["solver"]) for r in store.records}
    for case in args.cases:
        grid, ranks, solver = case.split(":")
        if (grid, int(ranks), solver) in done:
            continue
        record = run_case(args.out, grid, int(ranks), solver, args.until)
        print(case, "FAILED (see its log)" if record is None else
              f"{record['unknowns']} unknowns, {record['newton_iterations']} Newton its, {per_iteration(record):.1f} s/it",
              flush=True)
        if record:
            store.add(record)
            store.write(markdown(store.records, machine()))
    store.write(markdown(store.records, machine()), args.results)
    return 0

if __name__ == "__main__":
    sys.exit(main())
