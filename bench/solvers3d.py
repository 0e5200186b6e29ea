"""Linear solvers at 3D size: one Newton step of the 3D C-box's third-medium tangent (gamma 1e-6).

Usage::

    python3 bench/solvers3d.py [--cases N:RANKS:SOLVER ...] [--state deformed|reference]
                               [--out DIR] [--results DIR]

Every case is a fresh process of ``solvers3d_case.py`` (``nx x ny x nz`` Q2 hexahedra;
1 or 2 ranks; solver ``direct`` = MUMPS LDL^T, ``iterative`` = the package's preset, ``gamg`` =
the previous preset, GMRES + GAMG, capped at 300 iterations), so that its peak memory is its own.
The first direct solve of a size saves its solution and every later case of that size is compared
with it (relative 2-norm error, by node position, across rank counts). Writes
``DIR/solvers3d.json`` (every case, appended as it finishes: an interrupted run keeps its cases
and a rerun skips them) and ``DIR/solvers3d.md`` (the table); ``--results DIR`` copies both there.
Timings are as measured on the machine's state at the time, never asserted.
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

#: grid:ranks:solver of the default run (grids whose walls are whole cells: nx in 20 k, nz in 7 k):
#: the direct solver up to where it takes minutes
DEFAULT_CASES = ("20x4x7:1:direct", "20x4x7:1:iterative", "20x4x7:1:gamg",
                 "20x7x7:1:direct", "20x7x7:1:iterative", "20x7x7:2:iterative", "20x7x7:1:gamg",
                 "40x7x7:1:direct", "40x7x7:1:iterative", "40x7x7:2:direct", "40x7x7:2:iterative",
                 "20x14x14:1:iterative", "20x14x14:2:iterative", "40x14x14:2:iterative", "20x14x14:2:direct")


def run_case(out: pathlib.Path, grid: str, ranks: int, solver: str, state: str) -> dict | None:
    """Run one case in its own process; its record, or None if it failed (log in ``out``)."""
    reference = out / f"direct_{state}_{grid}.npy"
    name = f"{state}_{grid}_{ranks}_{solver}"
    cmd = [*mpi_launcher.command(ranks if ranks > 1 else None), sys.executable, str(HERE / "solvers3d_case.py"),
           grid, state, solver, str(out / f"{name}.json")]
    if solver == "direct" and not reference.exists():
        cmd += ["--save-solution", str(reference)]
    elif reference.exists():
        cmd += ["--compare", str(reference)]
    with open(out / f"{name}.log", "w") as f:
        code = subprocess.call(cmd, stdout=f, stderr=subprocess.STDOUT, env=mpi_launcher.job_environment(OMP_NUM_THREADS="1"))
    if code != 0 or not (out / f"{name}.json").exists():
        return None
    return json.loads((out / f"{name}.json").read_text())


def markdown(records: typing.Sequence[dict], machine: str) -> str:
    """The table: one row per case, by size, ranks and solver."""
    lines = ["# Linear solvers at 3D size (bench/solvers3d.py)", "",
             f"One Newton step of the 3D C-box tangent (Q2 hexahedra, gamma 1e-6, rotation regularization, "
             f"medium compressed by up to 80 %), {machine}. Setup: factorization (direct) or multigrid setup; "
             "peak MB: the largest resident set of the process(es), summed over ranks (assembly included; "
             "'before' is the peak before the solver was made); error: relative 2-norm distance to the "
             "direct solution of the same size. Timings as measured on a machine that other jobs shared "
             "(compare rows of one run, not runs).", "",
             "| grid | unknowns | ranks | solver | setup s | iterations | s per solve | peak MB | before MB | error | neg. pivots |",
             "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in sorted(records, key=lambda r: (r["unknowns"], r["ranks"], r["solver"])):
        its = r["iterations"] if r["reason"] > 0 else f"{r['iterations']} (not converged)"
        error = f"{r['rel_error']:.1e}" if "rel_error" in r else "-"
        negative = "-" if r.get("negative_pivots") is None else r["negative_pivots"]
        lines.append(f"| {r['grid']} | {r['unknowns']} | {r['ranks']} | {r['solver']} | {r['setup_s']:.1f} | {its} | "
                     f"{r['solve_s']:.1f} | {r['peak_MB']:.0f} | {r['before_solver_MB']:.0f} | {error} | {negative} |")
    return "\n".join(lines) + "\n"


def parse_args(argv: typing.Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(DEFAULT_CASES), help="NXxNYxNZ:RANKS:SOLVER")
    parser.add_argument("--state", default="deformed", choices=("deformed", "reference"))
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/solvers3d"))
    parser.add_argument("--results", type=pathlib.Path, default=None)
    return parser.parse_args(argv)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    store = CaseStore(args.out, "solvers3d")
    done = {(r["grid"], r["ranks"], r["solver"], r["state"]) for r in store.records}
    for case in args.cases:
        grid, ranks, solver = case.split(":")
        if (grid, int(ranks), solver, args.state) in done:
            continue
        record = run_case(args.out, grid, int(ranks), solver, args.state)
        print(case, record if record else "FAILED (see its log)", flush=True)
        if record:
            store.add(record)
    store.write(markdown(store.records, machine()), args.results)
    return 0

if __name__ == "__main__":
    sys.exit(main())
