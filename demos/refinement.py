"""Mesh refinement study: the paper's examples at several mesh sizes, and docs/refinement.md.

``make results`` runs it after ``results.py`` (``python3 demos/refinement.py``); each run is an
``mpirun`` subprocess of a demo writing to ``<out>/refinement/<run>/``, skipped when it already
converged with the same options and resumed when it was interrupted (the runner of
``results.py``). The page gives per study and mesh size, for SFVEM and FEM: unknowns, load
reached, the smallest signed gap between the deformed solids over the whole load path (negative:
the solids overlap; ``dolfinx_sfvem.physics.contact``) and where it occurs, the final gap, the reaction,
Newton iterations and wall time; and how the reaction changes from one mesh to the next finer.

Studies (the demos' defaults unless listed):

- C-box (§5.2), u_y = -0.5, gamma = 1e-5, alpha_r = 1, rotation, medium column 0.1 wide:
  h = 0.05, 0.033, 0.025 with 25 and 50 load steps, h = 0.0125 with 25; and a column only
  0.025 wide at h = 0.025 (the solids must not end as converged and overlapping);
- box (§5.1), mesh 1, gamma = 1e-5, alpha_r = 1: h = 0.05, 0.025; and gamma = 1e-6 at h = 0.05;
- soft punch (§5.3): h = 0.1, 0.05;
- multiple objects (§5.4), BC 1: h = 0.04, 0.02;
- a stiff cylinder on a soft block (``hertz.py``) at gamma = 1e-5 and 1e-6, h = 0.05, 0.03:
  at gamma = 1e-6 Newton stalls after contact (docs/notes/2026-11-23-gamma-1e-6.md), so there a stop naming the
  limit is the honest outcome.

Options: ``--quick`` (the coarsest two sizes of the C-box only, in ``<out>/refinement-quick``),
``--only PATTERN[,PATTERN]``, ``--np N`` (default 2), ``--list``, ``--report-only``,
``--retry-failed``, ``--out DIR``, ``--docs DIR``. Exit code 0 if every selected run ended as it
should (full load, or a stop where that is the honest outcome), 1 otherwise, 130 if interrupted.
"""
from __future__ import annotations

import argparse
import dataclasses
import pathlib
import signal
import sys
import typing

from dolfinx_sfvem.output import markdown
from dolfinx_sfvem.output.run_summary import RunSummary, read_summary
from results import select_and_execute
from results_plan import METHODS, REPO, Run
from results_report import field, final_step, fmt, force, machine, method_label, relative, status


@dataclasses.dataclass(frozen=True)
class Size:
    """One mesh size of a study: a label and the demo options that differ from the study's."""

    label: str
    args: tuple[str, ...]
    seconds: float
    series: str = ""                # sizes of one series are compared with each other (coarse first)
    may_stop: bool = False          # a stop (not converged) is the expected, honest outcome


@dataclasses.dataclass(frozen=True)
class Study:
    key: str
    title: str
    demo: str
    force: str
    args: tuple[str, ...]
    sizes: tuple[Size, ...]


def _cbox_sizes() -> tuple[Size, ...]:
    sizes = [Size(f"h = {h}, {n} steps", ("--h", h, "--steps", str(n)), s * n / 25, f"{n} steps")
             for h, s in (("0.05", 15), ("0.033", 25), ("0.025", 40)) for n in (25, 50)]
    return (*sizes, Size("h = 0.0125, 25 steps", ("--h", "0.0125", "--steps", "25"), 200, "25 steps"),
            Size("h = 0.025, column 0.025 wide, 25 steps", ("--h", "0.025", "--steps", "25", "--column", "0.025"),
                 40, "thin column", may_stop=True))


STUDIES = (
    Study("cbox", "C-box (§5.2): u_y = -0.5, gamma = 1e-5, alpha_r = 1, rotation, medium column 0.1 wide",
          "cbox", "load", ("--uy", "-0.5"), _cbox_sizes()),
    Study("box", "Box (§5.1): mesh 1, huhu_lulu with exp(-5 J), alpha_r = 1, 100 steps", "box_self_contact",
          "load", ("--mesh", "1", "--alpha-r", "1"),
          (Size("h = 0.05, gamma = 1e-5", ("--h", "0.05", "--gamma", "1e-5"), 40, "gamma 1e-5"),
           Size("h = 0.025, gamma = 1e-5", ("--h", "0.025", "--gamma", "1e-5"), 200, "gamma 1e-5"),
           Size("h = 0.05, gamma = 1e-6", ("--h", "0.05", "--gamma", "1e-6"), 60, "gamma 1e-6"))),
    Study("punch", "Soft punch (§5.3): u_y = -1.3 in 130 steps", "punch", "load", ("--punch", "soft"),
          (Size("h = 0.1", ("--h", "0.1"), 120), Size("h = 0.05", ("--h", "0.05"), 500))),
    Study("multi", "Multiple objects (§5.4), BC 1: u_y = -0.3 in 30 steps", "multi_object", "discs", ("--bc", "1"),
          (Size("h = 0.04", ("--h", "0.04"), 100), Size("h = 0.02", ("--h", "0.02"), 800))),
    Study("cylinder", "Stiff cylinder on a soft block (demos/hertz.py): u_y = -0.3 in 20 steps, "
          "rotation, alpha_r = 1", "hertz", "load", ("--steps", "20"),
          (Size("h = 0.05, gamma = 1e-5", ("--h", "0.05", "--gamma", "1e-5"), 60, "gamma 1e-5"),
           Size("h = 0.03, gamma = 1e-5", ("--h", "0.03", "--gamma", "1e-5"), 120, "gamma 1e-5"),
           Size("h = 0.05, gamma = 1e-6", ("--h", "0.05", "--gamma", "1e-6"), 90, "gamma 1e-6", may_stop=True),
           Size("h = 0.03, gamma = 1e-6", ("--h", "0.03", "--gamma", "1e-6"), 150, "gamma 1e-6", may_stop=True))),
)
QUICK_SIZES = 2


def run_name(study: Study, size: Size, method: str) -> str:
    """``refine-<study>-<options of the size>-<method>``."""
    return "-".join(["refine", study.key, *(a.lstrip("-") for a in size.args), method])


def plan(quick: bool, ranks: int) -> list[tuple[Study, Size, str, Run]]:
    """(study, size, method, run) of every run, in the order they are made."""
    studies = STUDIES[:1] if quick else STUDIES
    return [(study, size, method, Run(run_name(study, size, method), study.demo,
                                      ("--method", method, *study.args, *size.args), ranks,
                                        run_name(study, size, method), size.seconds))
            for study in studies for size in (study.sizes[:QUICK_SIZES] if quick else study.sizes)
            for method in METHODS]


# --------------------------------------------------------------------------- the page
def smallest_gap(summary: RunSummary | None) -> dict | None:
    """The gap record (value, place, regions) of the converged step with the smallest gap."""
    steps = summary.converged_steps if summary else []
    gaps = [s.gap for s in steps if s.gap and s.gap["value"] is not None]
    return min(gaps, key=lambda g: g["value"], default=None)


def expected(size: Size, summary: RunSummary | None) -> bool | None:
    """Whether the run ended as it should: full load without overlap, or (``may_stop``) any
    honest end; never converged with overlapping solids. None if not run."""
    if summary is None:
        return None
    gap = smallest_gap(summary)
    overlapping = gap is not None and gap["overlap"] > 1.0
    if summary.converged:
        return not overlapping
    return size.may_stop and not summary.interrupted


def rows(study: Study, entries: typing.Sequence[tuple[Size, str, RunSummary | None]]) -> list[list[str]]:
    """One row per run; the force change is against the previous size of the same method and
    series (the next coarser mesh)."""
    out, previous = [], {}
    for size, method, summary in entries:
        gap, last = smallest_gap(summary), final_step(summary)
        final_gap = ((last.gap if last else None) or {}).get("value")
        final_force = force(last, study.force) if summary and summary.converged else None
        series = (method, size.series)
        change = relative(previous.get(series), final_force)
        if final_force is not None:
            previous[series] = final_force
        ok = expected(size, summary)
        out.append([size.label, method_label(method, summary), status(summary),
                    fmt(field(summary, "dofs"), "d"), fmt(gap and gap["value"], "+.3e"),
                    "—" if gap is None else f"({gap['x'][0]:.3f}, {gap['x'][1]:.3f})", fmt(final_gap, "+.3e"),
                    fmt(final_force, ".5g"), fmt(change, "+.2%"), fmt(field(summary, "newton_iterations"), "d"),
                    fmt(field(summary, "wall_time_s"), ".0f"),
                    {None: "—", True: "yes", False: "**no**"}[ok]])
    return out


HEADER = ("mesh", "method", "status", "unknowns", "smallest gap", "at (deformed)", "final gap", "force -R_y",
          "change vs coarser", "Newton iterations", "wall [s]", "as it should")


def report(entries: typing.Sequence[tuple[Study, Size, str, Run]], root: pathlib.Path, docs: pathlib.Path,
           ranks: int) -> tuple[list[str], bool]:
    """The page, and whether every run that exists ended as it should."""
    lines = ["# Mesh refinement study", "",
             "Made by `demos/refinement.py` (`make results`); the method and what the gap means are in "
             "[contact.md](contact.md). *Smallest gap*: the smallest signed distance between the deformed "
             "solids over all converged steps (negative: they overlap), with the deformed position of the "
             "node where it occurs; *final gap*: at the last converged step; *change vs coarser*: the "
             "final force against the next coarser mesh of the same method and load steps; *as it should*: "
             "full load without overlap, or, for the thin medium column and the cylinder at gamma = 1e-6, a "
             "stop (never converged and overlapping).", ""]
    fine = True
    for study in STUDIES:
        mine = [(size, method, read_summary(root / run.out)) for s, size, method, run in entries if s is study]
        if not mine:
            continue
        fine &= all(expected(size, summary) is not False for size, _, summary in mine)
        lines += [f"## {study.title}", "", *markdown.table(HEADER, rows(study, mine)), ""]
    lines += [f"Runs on {ranks} MPI rank(s). {machine()}", ""]
    (docs / "refinement.md").write_text("\n".join(lines))
    return lines, fine


def make_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true")
    p.add_argument("--only", default=None)
    p.add_argument("--np", type=int, default=2)
    p.add_argument("--list", action="store_true")
    p.add_argument("--report-only", action="store_true")
    p.add_argument("--retry-failed", action="store_true")
    p.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out"))
    p.add_argument("--docs", type=pathlib.Path, default=None)
    return p


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = make_parser().parse_args(argv)
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    root = args.out / ("refinement-quick" if args.quick else "refinement")
    docs = args.docs or (root / "docs" if args.quick else REPO / "docs")
    entries = plan(args.quick, args.np)
    step = select_and_execute([run for *_, run in entries], args, root)
    if step is None:
        return 0
    selected, completed, _ = step
    docs.mkdir(parents=True, exist_ok=True)
    _, fine = report(entries, root, docs, args.np)
    print(f"wrote {docs / 'refinement.md'}", flush=True)
    if not completed:
        return 130
    made = {run.name for run in selected}
    ran = [read_summary(root / run.out) for *_, run in entries if run.name in made]
    return 0 if fine and all(s is not None for s in ran) else 1


if __name__ == "__main__":
    sys.exit(main())
