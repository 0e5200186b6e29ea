"""Run a demo with SFVEM and with FEM and compare the two runs (docs/method.md §7 cross-check).

Usage::

    python3 demos/compare.py cbox [--np N] [--out DIR] [demo options ...]

runs ``demos/<demo>.py --method vem --out DIR/vem ...`` and ``... --method fem --out
DIR/fem ...`` one after the other (each on N MPI ranks with ``--np N``, see
:mod:`dolfinx_sfvem.mpi_launcher`), passing
every other option (the demo's own and PETSc's) through unchanged, the FEM's own options
(``--fem-NAME VALUE``, e.g. ``--fem-cells triangles``) to the FEM run only, reads the two
``summary.json`` files and prints a table: unknowns, load factor reached, the reaction of
the ``load`` condition and every recorded observer (``extra``, e.g. ``gap``, ``tip_uy``)
at the largest load factor both runs reached, Newton iterations, wall times, and the
relative differences (FEM − SFVEM) / |SFVEM|. The table is written to
``DIR/comparison.json`` and ``DIR/comparison.md``; each run's output goes to
``DIR/<method>.log``.

Exit code: 0 if both runs reached the full load, 1 if not, 2 if a run wrote no summary.
"""
from __future__ import annotations

import argparse
import math
import pathlib
import subprocess
import sys
import time
import typing

from dolfinx_sfvem.output import markdown, post
from dolfinx_sfvem import mpi_launcher
from dolfinx_sfvem.output.run_summary import RunSummary, Step, read_summary

METHODS = ("vem", "fem")
DEMOS = pathlib.Path(__file__).resolve().parent

#: one row of the table: quantity, SFVEM value, FEM value, relative difference (or None)
Row = tuple[str, typing.Any, typing.Any, typing.Optional[float]]


def split_fem_options(options: typing.Sequence[str]) -> tuple[list[str], list[str]]:
    """(options for both runs, options for the FEM run only): ``--fem-NAME VALUE`` and
    ``--fem-NAME=VALUE`` go to the FEM run, everything else to both."""
    common, fem_only = [], []
    tokens = iter(options)
    for token in tokens:
        if token.startswith("--fem-"):
            fem_only += [token] if "=" in token else [token, next(tokens, "")]
        else:
            common.append(token)
    return common, [t for t in fem_only if t]


def run_demo(script: pathlib.Path, method: str, out: pathlib.Path, options: typing.Sequence[str],
             prefix: typing.Sequence[str] = ()) -> tuple[int, float]:
    """Run one demo with ``--method method --out out``; its output goes to ``out.parent/<method>.log``.
    A ``summary.json`` left in ``out`` by an earlier run is removed first.

    Returns
    -------
    (exit code, wall time in s of the whole process: start-up, meshing, JIT and solve)
    """
    cmd = [*prefix, sys.executable, str(script), "--method", method, "--out", str(out), *options]
    out.parent.mkdir(parents=True, exist_ok=True)
    (out / "summary.json").unlink(missing_ok=True)
    print(f"[{method}] {' '.join(cmd)}", flush=True)
    t0 = time.perf_counter()
    with open(out.parent / f"{method}.log", "w") as log:
        code = subprocess.call(cmd, stdout=log, stderr=subprocess.STDOUT, env=mpi_launcher.job_environment())
    wall = time.perf_counter() - t0
    print(f"[{method}] exit code {code}, {wall:.1f} s (log: {out.parent / f'{method}.log'})", flush=True)
    return code, wall


def _relative(a, b) -> float | None:
    """(b - a) / |a| for finite numbers; None for anything else and for a = 0 != b."""
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in (a, b)):
        return None
    if a == 0:
        return 0.0 if b == 0 else None
    return (b - a) / abs(a)


def common_load(vem: RunSummary, fem: RunSummary, tol: float = 1e-9) -> float | None:
    """The largest load factor at which both runs have a converged step."""
    loads = [s.load for s in fem.converged_steps]
    shared = [s.load for s in vem.converged_steps if any(abs(s.load - f) <= tol for f in loads)]
    return max(shared, default=None)


def step_at(summary: RunSummary, load: float | None, tol: float = 1e-9) -> Step | None:
    """The converged step of ``summary`` at the load factor ``load`` (None for None)."""
    if load is None:
        return None
    return next(s for s in summary.converged_steps if abs(s.load - load) <= tol)


def compare(vem: RunSummary, fem: RunSummary, process_wall: typing.Mapping[str, float] | None = None
            ) -> list[Row]:
    """The comparison table of two run summaries (SFVEM, FEM).

    Quantities at the largest load factor both reached (:func:`common_load`): the ``load``
    reaction, max |u| and every observer in ``extra``; over the whole run: unknowns, load reached,
    Newton iterations (all attempts, failed ones included), failed attempts, wall times.
    """
    load = common_load(vem, fem)
    runs = {"vem": vem, "fem": fem}
    at = {m: step_at(runs[m], load) for m in METHODS}
    reached = [step for step in at.values() if step is not None]

    def row(name: str, get: typing.Callable[[str], typing.Any]) -> Row:
        a, b = get("vem"), get("fem")
        return name, a, b, _relative(a, b)

    rows = [row("unknowns", lambda m: runs[m].dofs),
            row("load factor reached", lambda m: runs[m].load_reached),
            row("converged", lambda m: runs[m].converged),
            ("compared at load factor", load, load, None)]
    if any("load" in step.reaction for step in reached):
        for c, axis in enumerate("xy"):
            rows.append(row(f"reaction load R{axis}",
                            lambda m, c=c: at[m].reaction.get("load", [None] * 2)[c] if at[m] else None))
    if any(step.max_displacement is not None for step in reached):
        rows.append(row("max |u|", lambda m: at[m].max_displacement if at[m] else None))
    for name in sorted({k for step in reached for k in step.extra}):
        rows.append(row(name, lambda m, name=name: at[m].extra.get(name) if at[m] else None))
    rows += [row("Newton iterations (total)", lambda m: runs[m].newton_iterations),
             row("failed step attempts", lambda m: sum(not s.converged for s in runs[m].steps)),
             row("solve wall time [s]", lambda m: runs[m].wall_time_s)]
    if process_wall is not None:
        rows.append(row("process wall time [s]", lambda m: process_wall.get(m)))
    return rows


def _format(value) -> str:
    if value is None:
        return "–"
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def comparison_table(rows: typing.Sequence[Row]) -> str:
    """The table in Markdown; the last column is (FEM − SFVEM) / abs(SFVEM)."""
    lines = markdown.table(("quantity", "SFVEM", "FEM", "FEM vs SFVEM"),
                           [(name, _format(a), _format(b), "–" if rel is None else f"{rel:+.3%}")
                            for name, a, b, rel in rows])
    return "\n".join(lines) + "\n"


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python3 demos/compare.py", allow_abbrev=False,
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="Every other option is passed to both runs of the demo, "
                                       "--fem-NAME VALUE to the FEM run only.")
    p.add_argument("demo", help="demo name: demos/<demo>.py (e.g. cbox)")
    p.add_argument("--out", type=pathlib.Path, default=None, help="output directory (default out/compare/<demo>)")
    p.add_argument("--np", type=int, default=None, help="run each method on this many MPI ranks")
    p.add_argument("--mpiexec", default=None,
                   help="MPI launcher (default: mpiexec beside this Python, else mpiexec/mpirun on PATH)")
    p.add_argument("--demos", type=pathlib.Path, default=DEMOS,
                   help="directory of the demo scripts (default %(default)s)")
    return p


def main(argv: typing.Sequence[str] | None = None) -> int:
    p = parser()
    args, options = p.parse_known_args(argv)
    if "--method" in options or any(o.startswith("--method=") for o in options):
        p.error("--method is set by the comparison (both vem and fem are run)")
    if args.np is not None and args.np < 1:
        p.error(f"--np must be >= 1, got {args.np}")
    script = args.demos / f"{args.demo}.py"
    if not script.is_file():
        p.error(f"no demo {script}")
    out = args.out if args.out is not None else pathlib.Path("out") / "compare" / args.demo
    codes, walls, summaries = {}, {}, {}
    common, fem_only = split_fem_options(options)
    for method in METHODS:
        codes[method], walls[method] = run_demo(script, method, out / method,
                                                common + (fem_only if method == "fem" else []),
                                                mpi_launcher.command(args.np, launcher=args.mpiexec))
        path = out / method / "summary.json"
        summaries[method] = read_summary(path)
        if summaries[method] is None:
            print(f"error: the {method} run wrote no {path} (exit code {codes[method]}); see {out / f'{method}.log'}",
                  file=sys.stderr)
            return 2
    rows = compare(summaries["vem"], summaries["fem"], walls)
    table = comparison_table(rows)
    header = f"# {args.demo}: SFVEM vs FEM\n\nOptions: `{' '.join(options) or '(defaults)'}`" \
             f"{f', {args.np} MPI ranks' if args.np else ''}. Last column: (FEM − SFVEM) / abs(SFVEM); " \
             f"quantities at the largest load factor both runs reached.\n\n"
    post.atomic_write_text(out / "comparison.md", header + table)
    post.write_json(out / "comparison.json", {
        "demo": args.demo, "options": list(options), "ranks": args.np or 1, "exit_codes": codes,
        "rows": [{"quantity": n, "vem": a, "fem": b, "relative_difference": r} for n, a, b, r in rows]})
    print(table, end="")
    print(f"written: {out / 'comparison.md'}, {out / 'comparison.json'}")
    return 0 if all(s.converged for s in summaries.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
