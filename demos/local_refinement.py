"""Local refinement study: uniform SFVEM, SFVEM refined only where contact happens (static and
adaptive) and uniform FEM on the C-box (u_y = -0.5) and the box, against the finest uniform SFVEM.

Each run is one load path of the demo's problem (demos/cbox.py, demos/box_self_contact.py, their
default parameters) on one rank; the table gives the unknowns at the end, the final reaction
-R_y at the load point, the final gap (C-box: smallest gap between the solids; box: gap between
the flanges at mid-span), the wall time of the solve and the differences to the reference.
Writes ``--page`` (default docs/local-refinement-study.md) and ``study.json`` in ``--out``, the
latter after every run: a study that stopped continues with the runs it lacks (``--fresh`` runs
all again).

    python3 demos/local_refinement.py                       # the study of the docs (~40 min on one core)
    python3 demos/local_refinement.py --quick --out /tmp/s  # two coarse C-box runs (tests)
    python3 demos/local_refinement.py --page-only           # the page again from out/.../study.json
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time
import typing
from dataclasses import asdict, dataclass

import box_self_contact
import cbox

import dolfinx_sfvem as sf
from dolfinx_sfvem.output.run_summary import STOPPED_BY_SIGNAL

#: the region where contact happens, marked on polygon centroids: C-box beam tips, box mid-span
CONTACT_REGION = {"cbox": lambda x: x[0] > 0.5, "box": lambda x: abs(x[0] - 1.0) < 0.45}


@dataclass
class Run:
    """One row of the study: how the mesh was made and what the run gave."""
    problem: str
    label: str
    method: str
    converged: bool
    dofs: int
    force: float            # -R_y at the load point at the last converged step
    gap: float
    wall_time_s: float
    newton_iterations: int
    load: float = 1.0       # load factor reached
    message: str = ""       # why the run stopped short ("" if converged)


@dataclass
class Case:
    """A run to make: the demo's arguments and how to refine before or during the path."""
    problem: str
    label: str
    argv: list[str]
    levels: int = 0                          # static refinement of the medium in CONTACT_REGION
    solid_levels: int = 0                    # static refinement of all solid polygons, before that
    adapt: sf.Adaptivity | None = None


def solve(case: Case, quiet: bool) -> Run:
    """Build the demo's problem, refine as the case says, solve; the row of the table."""
    demo = cbox if case.problem == "cbox" else box_self_contact
    args = demo.make_parser().parse_args(case.argv)
    problem, observers = demo.build(args)
    problem.verbose = not quiet
    for _ in range(case.solid_levels):       # one level at a time (docs/refinement-local.md)
        problem.refine(tags=[sf.meshes.SOLID])
    for _ in range(case.levels):
        problem.refine(CONTACT_REGION[case.problem], tags=[sf.meshes.MEDIUM])
    t0 = time.perf_counter()
    result = problem.solve(args.steps, observers=observers, adapt=case.adapt)
    wall = time.perf_counter() - t0
    last = result.steps[-1] if result.steps else None
    gap = (last["extra"]["gap"] if case.problem == "box" else last["gap"]["value"]) if last else float("nan")
    return Run(case.problem, case.label, args.method, result.converged, int(problem.disc.num_dofs_global),
               -last["reaction"]["load"][1] if last else float("nan"), float(gap), wall,
               sum(a["newton_iterations"] for a in result.attempts), float(result.load), result.message)


def cases(quick: bool) -> list[Case]:
    """The runs of the study (``quick``: two coarse C-box runs before contact)."""
    if quick:
        small = ["--uy", "-0.15", "--steps", "4", "--h", "0.1"]
        return [Case("cbox", "uniform h = 0.1", small),
                Case("cbox", "h = 0.1, adaptive", small, adapt=sf.Adaptivity(sf.Compression(0.95), max_levels=1))]
    out: list[Case] = []
    for name, hs, coarse, fem_hs in (("cbox", (0.1, 0.05, 0.025, 0.0125), 0.05, (0.1, 0.05, 0.025, 0.0125)),
                                     ("box", (0.05, 0.025, 0.0125), 0.05, (0.05, 0.025))):
        out += [Case(name, f"uniform h = {h:g}", ["--h", str(h)]) for h in hs]
        out += [Case(name, f"h = {coarse:g}, contact region {k} level{'s' * (k > 1)}", ["--h", str(coarse)], levels=k)
                for k in (1, 2)]
        out += [Case(name, f"h = {coarse:g}, solids 1 level" + (f", contact region {k} level{'s' * (k > 1)}" if k else ""),
                     ["--h", str(coarse)], levels=k, solid_levels=1) for k in (0, 1, 2)]
        out.append(Case(name, f"h = {coarse:g}, adaptive (near contact, 0.1, 1 level)", ["--h", str(coarse)],
                        adapt=sf.Adaptivity(sf.NearContact(0.1), max_levels=1)))
        out.append(Case(name, f"h = {coarse:g}, adaptive (J < 0.8, 2 levels)", ["--h", str(coarse)],
                        adapt=sf.Adaptivity(sf.Compression(0.8), max_levels=2)))
        out += [Case(name, f"uniform h = {h:g}", ["--h", str(h), "--method", "fem"]) for h in fem_hs]
    return out


def _method(case: Case) -> str:
    return "fem" if "fem" in case.argv else "vem"


def table(runs: list[Run], problem: str) -> str:
    """Markdown table of one problem's runs against its finest uniform SFVEM run."""
    mine = [r for r in runs if r.problem == problem]
    ref = _reference(mine)
    lines = ["| method | mesh | converged | unknowns | force -R_y | vs reference | gap | gap - reference | "
             "Newton its | wall [s] |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in mine:
        rel = f"{100 * (r.force / ref.force - 1):+.2f} %" if ref else ""
        dgap = f"{r.gap - ref.gap:+.2e}" if ref else ""
        lines.append(f"| {r.method.upper() if r.method == 'fem' else 'SFVEM'} | {r.label} | "
                     f"{'yes' if r.converged else f'no, load {r.load:.3g}'} | {r.dofs} | {r.force:.6e} | {rel} | {r.gap:.4e} | {dgap} | "
                     f"{r.newton_iterations} | {r.wall_time_s:.1f} |")
    if ref:
        lines.append(f"\nReference: SFVEM {ref.label} ({ref.dofs} unknowns).")
    lines += [f"\nStopped: {r.label} ({r.method.upper() if r.method == 'fem' else 'SFVEM'}): {r.message}"
              for r in mine if not r.converged]
    return "\n".join(lines)


def _reference(runs: list[Run]) -> Run | None:
    uniform = [r for r in runs if r.method == "vem" and r.label.startswith("uniform") and r.converged]
    return max(uniform, key=lambda r: r.dofs) if uniform else None


def verdict(runs: list[Run], problem: str, force_tol: float = 0.01, gap_tol: float = 0.05) -> str:
    """The cheapest run of each kind (uniform SFVEM, locally refined SFVEM, uniform FEM), other
    than the reference, whose force is within ``force_tol`` of the reference's, and the cheapest
    whose gap is also within ``gap_tol`` of the reference's (relative), in unknowns and wall time."""
    mine = [r for r in runs if r.problem == problem]
    ref = _reference(mine)
    if ref is None:
        return "No converged uniform SFVEM run: no reference."
    force_ok = [r for r in mine if r is not ref and r.converged and abs(r.force / ref.force - 1) <= force_tol]
    both_ok = [r for r in force_ok if abs(r.gap / ref.gap - 1) <= gap_tol]
    lines = []
    for title, close in ((f"Force within {100 * force_tol:g} % of the reference's ({ref.force:.6e})", force_ok),
                         (f"Force within {100 * force_tol:g} % and gap within {100 * gap_tol:g} % of the "
                          f"reference's ({ref.gap:.4e})", both_ok)):
        lines.append(f"{title}:\n")
        kinds = {"uniform SFVEM": [r for r in close if r.method == "vem" and r.label.startswith("uniform")],
                 "locally refined SFVEM": [r for r in close if r.method == "vem" and not r.label.startswith("uniform")],
                 "uniform FEM": [r for r in close if r.method == "fem"]}
        for kind, rs in kinds.items():
            if rs:
                best = min(rs, key=lambda r: r.dofs)
                lines.append(f"- {kind}: cheapest {best.label}, {best.dofs} unknowns ({best.dofs / ref.dofs:.2f} x "
                             f"the reference's), {best.wall_time_s:.1f} s ({best.wall_time_s / ref.wall_time_s:.2f} x), "
                             f"force {100 * (best.force / ref.force - 1):+.2f} %, gap {100 * (best.gap / ref.gap - 1):+.1f} %")
            else:
                lines.append(f"- {kind}: none")
        lines.append("")
    return "\n".join(lines).rstrip()


def page(runs: list[Run], command: str) -> str:
    """The study page (Markdown)."""
    return "\n\n".join([
        "# Local refinement study",
        "Written by `demos/local_refinement.py` (" + command + "); what the tables mean, how the "
        "meshes are made and what to read from them: [refinement-local.md](refinement-local.md). One rank, "
        "on a machine shared with other jobs: compare wall times within a table only.",
        "## C-box", table(runs, "cbox"), verdict(runs, "cbox"),
        "## Box", table(runs, "box"), verdict(runs, "box"),
    ]) + "\n"


def main(argv: typing.Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out") / "local-refinement")
    p.add_argument("--page", type=pathlib.Path, default=pathlib.Path(__file__).resolve().parents[1] / "docs"
                   / "local-refinement-study.md")
    p.add_argument("--quick", action="store_true", help="two coarse C-box runs before contact (for the tests)")
    p.add_argument("--only", choices=("cbox", "box"), default=None, help="one problem only")
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--page-only", action="store_true", help="write the page from --out/study.json, run nothing")
    p.add_argument("--fresh", action="store_true", help="run every case again (default: the runs already in "
                   "--out/study.json are kept and only the missing ones are run)")
    args = p.parse_args(argv)
    record = args.out / "study.json"
    if args.fresh and record.exists():
        record.unlink()
    recorded = [Run(**r) for r in json.loads(record.read_text())] if record.exists() else []
    done = {(r.problem, r.label, r.method): r for r in recorded}
    runs = []
    for case in (c for c in cases(args.quick) if args.only in (None, c.problem)):
        run = done.get((case.problem, case.label, _method(case)))
        if run is None and not args.page_only:
            run = solve(case, args.quiet)
            if run.message.startswith(STOPPED_BY_SIGNAL):   # interrupted: not a result, the study stops
                print(f"{case.problem}, {case.label}: {run.message}; study.json keeps the runs before it")
                return 1
            done[(run.problem, run.label, run.method)] = run
            args.out.mkdir(parents=True, exist_ok=True)     # study.json after every run: nothing lost
            record.write_text(json.dumps([asdict(r) for r in done.values()], indent=1))
        if run is not None:
            runs.append(run)
    command = "python3 demos/local_refinement.py" + (" --quick" if args.quick else "")
    args.page.write_text(page(runs, command))
    print(f"wrote {args.page}" + ("" if args.page_only else f" and {record}"))
    return 0 if all(r.converged for r in runs) else 1


if __name__ == "__main__":
    sys.exit(main())
