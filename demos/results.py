"""Results page: run the paper's four examples (§5) and write ``docs/results.md``.

``make results`` (``python3 demos/results.py``) runs, one after the other, each as its own
``mpirun`` subprocess writing to ``<out>/results/<run>/`` (default ``out/results``):

- C-box (§5.2): u_y = -0.5 with gamma = 1e-5, alpha_r = 1 on both medium densities, u_y = -1
  with alpha_r = 20 on medium mesh 2 (on mesh 1 the medium polygon at the C's mouth inverts
  at load 0.887);
- box self-contact (§5.1): mesh 1, gamma = 1e-5, alpha_r = 1 (huhu_lulu, beta = 5), kept in
  the Table 2 sweep's directory (the sweep reuses it);
- multiple objects (§5.4): boundary conditions 1 and 2;
- punch (§5.3): soft and rigid punch, 130 steps to u_y = -1.3;

each with ``--method vem`` and ``--method fem`` on ``--np`` ranks (default 2); then the box
sweeps ``--table2``, ``--table3`` and ``--fig4`` (SFVEM; Fig. 4 shares the Table 2 runs); last,
the first configuration of every example once more on 1 rank with both methods (runs named
``...-np1``, the rank check). Every run uses its demo's defaults unless listed above.

Then it writes ``docs/results.md`` from whatever summary.json files exist (missing runs are
listed as "not run"): Table 2 and Table 3 beside the paper's values (``dolfinx_sfvem/paper.py``)
with an acceptance check, Fig. 4, per example an SFVEM vs FEM table
(DOFs, load reached, force, the example's key output, Newton iterations, wall time, ranks),
force and key-output curves of both methods, the deformed configurations (PNGs copied to
``docs/figures/``), the 1-rank vs N-rank check, where we differ from the paper, the machine
and the date.

Restart
-------
A run whose summary.json says converged with the same parameters is skipped; one that was
interrupted (killed, or stopped by a signal) is continued with the demo's ``--resume``; one
that failed is not repeated unless ``--retry-failed`` is given; a finished run with other
parameters is moved to ``<out>/results/superseded/`` before its directory is reused (so is
the XDMF output of a run killed while writing it, which cannot be appended to). The
sweeps skip and resume their own runs. Ctrl-C (or SIGTERM) stops the current run after its load step
and writes the page from what exists; the same command continues. Each run's output is appended
to ``<out>/results/logs/<run>.log``.

Options
-------
``--quick`` coarse meshes and few steps (a few minutes; runs in ``<out>/results-quick``, page
in ``<out>/results-quick/docs``); ``--only NAME[,NAME]`` select runs (shell patterns, e.g.
``cbox-*``); ``--np N`` ranks of the main runs; ``--list`` print the plan (state, estimated
time) and stop; ``--report-only`` write the page without running; ``--retry-failed``;
``--out DIR``; ``--docs DIR``.

Exit code: 0 if every selected run reached the full load, 1 if not, 130 if interrupted.

This file is the command line; the plan is ``results_plan.py``, the runner ``results_runner.py``
(its restart decision, ``restart.py``, is the box sweeps' too), the page ``results_report.py``,
and the measured notes the page includes are ``docs/results-notes.md``.
"""
from __future__ import annotations

import argparse
import pathlib
import signal
import sys
import typing

from dolfinx_sfvem.output.run_summary import read_summary
from results_plan import REPO, Run, clock, plan, select
from results_report import overall, write_report
from results_runner import execute, remaining, state


def make_parser() -> argparse.ArgumentParser:
    """The command line (see the module docstring)."""
    p = argparse.ArgumentParser(prog="results.py", description=__doc__, allow_abbrev=False,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="coarse meshes and few steps (pipeline check)")
    p.add_argument("--only", default=None, metavar="NAME[,NAME]", help="run only these (shell patterns)")
    p.add_argument("--np", type=int, default=2, help="MPI ranks of the main runs (default %(default)s)")
    p.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out"),
                   help="runs go to OUT/results (OUT/results-quick with --quick) (default %(default)s)")
    p.add_argument("--docs", type=pathlib.Path, default=None,
                   help="directory of results.md and figures/ (default docs; with --quick OUT/results-quick/docs)")
    p.add_argument("--list", action="store_true", help="print the plan with states and estimates, run nothing")
    p.add_argument("--report-only", action="store_true", help="write the page from the existing runs only")
    p.add_argument("--retry-failed", action="store_true", help="repeat runs that failed before")
    return p


def select_and_execute(runs: typing.Sequence[Run], args: argparse.Namespace, root: pathlib.Path
                       ) -> tuple[list[Run], bool, dict[str, int]] | None:
    """The runs ``--only`` selects (SystemExit naming a bad selection); None after printing their
    plan with ``--list``; else the selected runs with :func:`execute`'s (completed, exit codes),
    nothing run with ``--report-only``. Shared by the results page and the refinement study."""
    try:
        selected = select(runs, args.only)
    except ValueError as err:
        raise SystemExit(str(err)) from None
    if args.list:
        print_plan(selected, root, args.retry_failed)
        return None
    completed, codes = (True, {}) if args.report_only else execute(selected, root, args.retry_failed)
    return selected, completed, codes


def print_plan(runs: typing.Sequence[Run], root: pathlib.Path, retry_failed: bool) -> None:
    """One line per run: state, ranks, estimate, command; then the total still to make."""
    left = {r.name: remaining(r, root, retry_failed) for r in runs}
    for run in runs:
        print(f"{run.name:24s} {state(run, root):12s} {run.ranks} rank(s)  estimate {clock(run.seconds):>8s}  "
              f"{run.demo}.py {' '.join(run.argv)}")
    print(f"{sum(t > 0 for t in left.values())} of {len(runs)} runs to make, estimated "
          f"{clock(sum(left.values()))}")


def main(argv: typing.Sequence[str] | None = None) -> int:
    """Run what is selected, write the page; returns the exit code (module docstring)."""
    args = make_parser().parse_args(argv)
    signal.signal(signal.SIGTERM, signal.default_int_handler)      # stop like Ctrl-C
    if args.np < 1:
        raise SystemExit("--np must be >= 1")
    root = args.out / ("results-quick" if args.quick else "results")
    docs = args.docs or (root / "docs" if args.quick else REPO / "docs")
    runs = plan(args.quick, args.np)
    step = select_and_execute(runs, args, root)
    if step is None:
        return 0
    selected, completed, codes = step
    checks = write_report(runs, root, docs, args.quick)
    print("Table 2 acceptance:")
    for check in checks:
        print(f"  {check.result:10s} {check.criterion}: {check.detail}")
    print(f"  overall: {overall(checks)}\nwrote {docs / 'results.md'}", flush=True)
    if not completed:
        return 130
    made = [read_summary(root / r.out) for r in selected if not r.sweep]
    return 0 if all(s and s.converged for s in made) and not any(codes.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
