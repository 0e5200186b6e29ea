"""Results page: run the paper's four examples (§5) and write ``docs/results.md``.

``make results`` (``python3 demos/results.py``) runs, one after the other, each as its own
``mpirun`` subprocess writing to ``<out>/results/<run>/`` (default ``out/results``):

- C-box (§5.2): u_y = -0.5 with gamma = 1e-5, alpha_r = 1 on both medium densities, u_y = -1
  with alpha_r = 20;
- box self-contact (§5.1): mesh 1, gamma = 1e-5, alpha_r = 1 (huhu_lulu, beta = 5), kept in
  the Table 2 sweep's directory (the sweep reuses it);
- multiple objects (§5.4): boundary conditions 1 and 2;
- punch (§5.3): soft and rigid punch, 130 steps to u_y = -1.3;

each with ``--method vem`` and ``--method fem`` on ``--np`` ranks (default 2); then the box
sweeps ``--table2``, ``--table3`` and ``--fig4`` (SFVEM; Fig. 4 shares the Table 2 runs); last,
the first configuration of every example once more on 1 rank with both methods (runs named
``...-np1``, the rank check). Every run uses its demo's defaults unless listed above.

Then it writes ``docs/results.md`` from whatever summary.json files exist (missing runs are
listed as "not run"): Table 2 and Table 3 beside the paper's values (imported from
``box_self_contact.py``) with an acceptance check, Fig. 4, per example an SFVEM vs FEM table
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
"""
from __future__ import annotations

import argparse
import dataclasses
import datetime
import fnmatch
import importlib
import json
import math
import os
import pathlib
import platform
import shutil
import signal
import statistics
import subprocess
import sys
import time
import typing

import box_self_contact as box
from dolfinx_sfvem import compare, mpi_launcher, post
from dolfinx_sfvem.problem import CHECKPOINT, interrupted

DEMOS = pathlib.Path(__file__).resolve().parent
REPO = DEMOS.parent
METHODS = ("vem", "fem")
METHOD_NAMES = {"vem": "SFVEM", "fem": "FEM"}
#: run-time factor of a 1-rank run against a 2-rank run (estimates only)
SERIAL_FACTOR = 1.8
#: relative differences above these are listed under "Where we differ"
METHOD_TOLERANCE, RANK_TOLERANCE = 0.05, 1e-6
#: our gap counts as different from the paper's outside the paper's own mesh-to-mesh spread of
#: that row, or this factor if that is larger
GAP_FACTOR = 1.1
#: the Table 2 acceptance band of our gap / the paper's
RATIO_BAND = (0.1, 10.0)
#: Table 2 acceptance: every gap at this gamma is below this value
SMALL_GAMMA, SMALL_GAP = 1e-6, 1e-3

#: the first bytes of an HDF5 file (superblock at offset 0, as DOLFINx writes it)
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"

TABLE2_DIR, TABLE3_DIR = "box-table2", "box-table3"
BOX_QUICK = ("--h", "0.1", "--steps", "10")
CBOX_QUICK = ("--h", "0.1", "--steps", "10")
PUNCH_QUICK = ("--h", "0.15", "--steps", "26")
MULTI_QUICK = ("--h", "0.1", "--steps", "6")


# --------------------------------------------------------------------------- the plan
@dataclasses.dataclass(frozen=True)
class Case:
    """One configuration of an example, run with both methods.

    Attributes
    ----------
    name, label
        Short name (part of the run names) and its description on the page.
    args
        Demo options of the full run (``--name value`` pairs); ``quick`` replaces or adds
        some in ``--quick`` mode.
    seconds, quick_seconds
        Estimated wall time of the SFVEM run on 2 ranks (start-up included), full and quick.
    vem_out
        Output directory of the SFVEM run if not its own (the box case lives in the Table 2
        sweep, which then reuses it).
    """

    name: str
    label: str
    args: tuple[str, ...]
    quick: tuple[str, ...]
    seconds: float
    quick_seconds: float = 10.0
    vem_out: str | None = None


@dataclasses.dataclass(frozen=True)
class Example:
    """One of the paper's examples: its demo, what is compared, which pictures are shown.

    Attributes
    ----------
    force
        Boundary condition whose reaction -R_y is the example's force.
    output
        (key, label) of the key output: an observer in the steps' ``extra`` or a step field
        such as ``max_displacement``; ``log_output`` plots it on a logarithmic scale.
    figures
        PNGs of the SFVEM runs shown besides deformed.png and uy.png.
    """

    key: str
    title: str
    demo: str
    force: str
    output: tuple[str, str]
    cases: tuple[Case, ...]
    figures: tuple[str, ...] = ()
    log_output: bool = False


@dataclasses.dataclass(frozen=True)
class Run:
    """One subprocess: a demo run (or sweep) with its options, ranks and output directory."""

    name: str
    demo: str
    argv: tuple[str, ...]
    ranks: int
    out: str
    seconds: float
    sweep: bool = False
    reference: str | None = None


BOX_CASE_DIR = str(box.run_dir(pathlib.Path(TABLE2_DIR), "huhu_lulu", box.BETA, 1.0, 1e-5, 1))

EXAMPLES = (
    Example("cbox", "C-box (§5.2)", "cbox", "load", ("tip_ux", "u_x of the loaded tip"), (
        Case("mesh1", "u_y = -0.5, gamma = 1e-5, alpha_r = 1, medium mesh 1",
             ("--uy", "-0.5", "--steps", "50", "--mesh", "1"), CBOX_QUICK, 40, 4),
        Case("mesh2", "u_y = -0.5, gamma = 1e-5, alpha_r = 1, medium mesh 2",
             ("--uy", "-0.5", "--steps", "50", "--mesh", "2"), CBOX_QUICK, 90, 5),
        Case("uy1", "u_y = -1, gamma = 1e-5, alpha_r = 20, medium mesh 1",
             ("--uy", "-1", "--alpha-r", "20", "--steps", "100"), ("--h", "0.1", "--steps", "20"), 150, 6))),
    Example("box", "Box self-contact (§5.1)", "box_self_contact", "load", ("gap", "gap g at mid-span"), (
        Case("mesh1", "mesh 1, gamma = 1e-5, alpha_r = 1, huhu_lulu with exp(-5 J)",
             ("--mesh", "1", "--gamma", "1e-5", "--alpha-r", "1"), BOX_QUICK, 240, 5, vem_out=BOX_CASE_DIR),),
        figures=("gap.png",), log_output=True),
    Example("multi", "Multiple objects (§5.4)", "multi_object", "discs", ("max_displacement", "max |u|"), (
        Case("bc1", "BC 1: block clamped at both ends, discs u_x = 0", ("--bc", "1"), MULTI_QUICK, 330, 13),
        Case("bc2", "BC 2: block clamped left, simply supported right, discs u_x free", ("--bc", "2"),
             MULTI_QUICK, 330, 13)),
        figures=("zoom.png",)),
    Example("punch", "Punch (§5.3)", "punch", "load", ("gap", "gap on the axis"), (
        Case("soft", "soft punch (K = 5/3, mu = 5/14), u_y = -1.3 in 130 steps", ("--punch", "soft"),
             PUNCH_QUICK, 1500, 15),
        Case("rigid", "rigid punch (K = 500/3, mu = 500/14), u_y = -1.3 in 130 steps", ("--punch", "rigid"),
             PUNCH_QUICK, 1800, 30)), log_output=True),
)

#: what the FEM reference is, at the top of the page
FEM_NOTE = ("The FEM reference is degree-2 Lagrange on the same UFL energy with the cell-wise second "
            "gradient: P2 on a triangulation with about the SFVEM's unknowns, except on the C-box, where it is "
            "Q2 on the medium's quadrilateral grid continued through the solid (`meshes.cbox_grid`; "
            "`demos/cbox.py --fem-cells triangles` for P2, docs/fem-reference.md).")

#: the box sweeps: (run name, option, output directory, estimated full / quick seconds)
SWEEPS = (("box-table2", "--table2", TABLE2_DIR, 3 * 3600, 60),
          ("box-table3", "--table3", TABLE3_DIR, 3600, 20),
          ("box-fig4", "--fig4", TABLE2_DIR, 0, 5))


def override(options: typing.Sequence[str], new: typing.Sequence[str]) -> tuple[str, ...]:
    """``options`` (``--name value`` pairs) with the values in ``new`` replacing or added."""
    pairs = dict(zip(options[::2], options[1::2]))
    pairs.update(zip(new[::2], new[1::2]))
    return tuple(item for pair in pairs.items() for item in pair)


def run_name(example: Example, case: Case, method: str, ranks: int | None = None) -> str:
    """``<example>-<case>-<method>``, with ``-np<ranks>`` for the rank check runs."""
    return f"{example.key}-{case.name}-{method}" + (f"-np{ranks}" if ranks is not None else "")


def plan(quick: bool, ranks: int) -> list[Run]:
    """All runs in the order they are made: examples, sweeps, then the 1-rank check."""
    def case_run(example: Example, case: Case, method: str, n: int, check: bool) -> Run:
        name = run_name(example, case, method, n if check else None)
        out = case.vem_out if method == "vem" and not check and case.vem_out else name
        seconds = (case.quick_seconds if quick else case.seconds) * (SERIAL_FACTOR if n == 1 else 1.0)
        return Run(name, example.demo, ("--method", method, *override(case.args, case.quick if quick else ())), n, out,
                   seconds, reference=run_name(example, case, method) if check else None)

    runs = [case_run(e, c, m, ranks, False) for e in EXAMPLES for c in e.cases for m in METHODS]
    sweep_quick = ("--meshes", "1", *BOX_QUICK) if quick else ()
    runs += [Run(name, box.__name__, (option, *sweep_quick), ranks, out, quick_s if quick else full_s, sweep=True)
             for name, option, out, full_s, quick_s in SWEEPS]
    if ranks != 1:
        runs += [case_run(e, e.cases[0], m, 1, True) for e in EXAMPLES for m in METHODS]
    return runs


def select(runs: typing.Sequence[Run], only: str | None) -> list[Run]:
    """The runs matching one of the comma-separated shell patterns of ``only`` (all for None)."""
    if only is None:
        return list(runs)
    patterns = [p.strip() for p in only.split(",") if p.strip()]
    unknown = [p for p in patterns if not any(fnmatch.fnmatchcase(r.name, p) for r in runs)]
    if unknown:
        raise ValueError(f"--only: no run matches {', '.join(unknown)}; runs: {', '.join(r.name for r in runs)}")
    return [r for r in runs if any(fnmatch.fnmatchcase(r.name, p) for p in patterns)]


# --------------------------------------------------------------------------- state of a run
def read_summary(directory: pathlib.Path) -> dict | None:
    """summary.json of ``directory`` (None if absent or unreadable)."""
    try:
        return json.loads((directory / "summary.json").read_text())
    except (OSError, ValueError):
        return None


def expected_parameters(run: Run) -> dict:
    """The parameters the demo stores for ``run.argv`` (from the demo's own parser)."""
    args, _ = importlib.import_module(run.demo).make_parser().parse_known_args(list(run.argv))
    return {k: v for k, v in vars(args).items() if k not in ("out", "quiet", "resume")}


def state(run: Run, root: pathlib.Path) -> str:
    """``sweep``, ``missing``, ``done``, ``failed``, ``interrupted`` (resumable), or ``other``
    (a summary of other parameters, or an interrupted run without checkpoint)."""
    if run.sweep:
        return "sweep"
    summary = read_summary(root / run.out)
    if summary is None:
        return "missing"
    stored, wanted = summary.get("parameters", {}), expected_parameters(run)
    if any(stored[k] != v for k, v in wanted.items() if k in stored):
        return "other"
    if summary["converged"]:
        return "done"
    if interrupted(summary):
        return "interrupted" if (root / run.out / CHECKPOINT).exists() else "other"
    return "failed"


# --------------------------------------------------------------------------- running
class Interrupted(Exception):
    """Ctrl-C during a run: it was stopped after its load step."""


def launch(run: Run, root: pathlib.Path, resume: bool, retry_failed: bool) -> int:
    """Run one demo (or sweep) under mpirun; output appended to ``logs/<run>.log``.

    Raises
    ------
    Interrupted
        On Ctrl-C, after the run has stopped (it keeps every converged step).
    """
    out = root / run.out
    where = ("--resume", str(out)) if resume else ("--out", str(out))
    cmd = [*mpi_launcher.command(run.ranks), sys.executable, str(DEMOS / f"{run.demo}.py"), *run.argv, *where,
           *(("--retry-failed",) if run.sweep and retry_failed else ())]
    (root / "logs").mkdir(parents=True, exist_ok=True)
    # os.environ is Python's start-up copy, without the variables MPI initialisation set (see compare)
    env = {"OMP_NUM_THREADS": "1", **os.environ}
    with open(root / "logs" / f"{run.name}.log", "a") as log:
        log.write(f"\n# {datetime.datetime.now().isoformat(timespec='seconds')}: {' '.join(cmd)}\n")
        log.flush()
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env)
        try:
            return proc.wait()
        except KeyboardInterrupt:
            print(f"\ninterrupted: {run.name} stops after its current load step ...", flush=True)
            proc.send_signal(signal.SIGTERM)
            proc.wait()
            raise Interrupted from None


def _clock(seconds: float) -> str:
    """h:mm:ss."""
    return str(datetime.timedelta(seconds=round(seconds)))


def supersede(paths: typing.Sequence[pathlib.Path], root: pathlib.Path, name: str) -> pathlib.Path:
    """Move ``paths`` into a new directory ``superseded/<name>-<time>`` of ``root``; returns it."""
    moved = root / "superseded" / f"{name}-{datetime.datetime.now():%Y%m%d-%H%M%S-%f}"
    moved.mkdir(parents=True)
    for path in paths:
        shutil.move(str(path), moved / path.name)
    return moved


def unclosed_xdmf(out: pathlib.Path) -> bool:
    """Whether the run in ``out`` left displacement.h5 without its HDF5 superblock (killed while the
    file was open): DOLFINx cannot append to it, so a resume would fail."""
    try:
        with open(out / "displacement.h5", "rb") as f:
            return f.read(len(HDF5_SIGNATURE)) != HDF5_SIGNATURE
    except OSError:
        return False


def set_aside_xdmf(out: pathlib.Path, root: pathlib.Path, name: str) -> pathlib.Path | None:
    """Move the XDMF output of an interrupted run in ``out`` aside if it cannot be appended to
    (:func:`unclosed_xdmf`); the resumed run starts a new XDMF time series. Returns where to."""
    summary = read_summary(out)
    if summary is None or not interrupted(summary) or not unclosed_xdmf(out):
        return None
    return supersede([out / "displacement.xdmf", out / "displacement.h5"], root, f"{name}-xdmf")


def prepare(run: Run, root: pathlib.Path, retry_failed: bool) -> tuple[bool, bool, str]:
    """Decide about one run: (launch it?, resume?, what to report).

    A run of other parameters is moved aside (:func:`supersede`), and so is the unreadable XDMF
    output of an interrupted run, the sweep's runs included (:func:`set_aside_xdmf`).
    """
    if run.sweep:
        moved = [m for d in sweep_dirs(run, root).values() if (m := set_aside_xdmf(d, root, f"{run.name}-{d.name}"))]
        return True, False, "sweep" + (f" (unreadable XDMF output moved to {', '.join(map(str, moved))})"
                                       if moved else "")
    current = state(run, root)
    out = root / run.out
    if current == "done":
        return False, False, "converged before, skipped"
    if current == "failed" and not retry_failed:
        return False, False, "failed before, skipped (--retry-failed repeats it)"
    if current == "other":
        return True, False, f"earlier run with other parameters moved to {supersede([out], root, run.name)}"
    if current == "interrupted":
        moved = set_aside_xdmf(out, root, run.name)
        return True, True, f"resuming (unreadable XDMF output moved to {moved})" if moved else "resuming"
    return True, False, "running"


def execute(runs: typing.Sequence[Run], root: pathlib.Path, retry_failed: bool) -> tuple[bool, dict[str, int]]:
    """Make the runs one after the other with a progress line each.

    Returns
    -------
    completed
        False if interrupted by Ctrl-C.
    codes
        Exit code of every run launched.
    """
    start, spent, estimated, codes = time.perf_counter(), 0.0, 0.0, {}
    for k, run in enumerate(runs):
        go, resume, note = prepare(run, root, retry_failed)
        if go:
            print(f"[{k + 1}/{len(runs)}] {run.name}: {note} (estimate {_clock(run.seconds)})", flush=True)
            t0 = time.perf_counter()
            try:
                codes[run.name] = launch(run, root, resume, retry_failed)
            except Interrupted:
                return False, codes
            took = time.perf_counter() - t0
            spent, estimated = spent + took, estimated + run.seconds
            note = f"exit code {codes[run.name]} in {_clock(took)}"
        speed = spent / estimated if estimated > 0 else 1.0
        left = speed * sum(remaining(r, root, retry_failed) for r in runs[k + 1:])
        print(f"[{k + 1}/{len(runs)}] {run.name}: {note} | elapsed {_clock(time.perf_counter() - start)}"
              f" | left ~{_clock(left)}", flush=True)
    return True, codes


def remaining(run: Run, root: pathlib.Path, retry_failed: bool) -> float:
    """Estimated seconds ``run`` still needs (a sweep: the share of its runs not at full load)."""
    if run.sweep:
        summaries = {key: read_summary(d) for key, d in sweep_dirs(run, root).items()}
        return run.seconds * sum(not (s and s["converged"]) for s in summaries.values()) / len(summaries)
    current = state(run, root)
    return 0.0 if current == "done" or (current == "failed" and not retry_failed) else run.seconds


# --------------------------------------------------------------------------- reading results
def converged_steps(summary: dict | None) -> list[dict]:
    """The converged steps of a summary (none for None)."""
    return [s for s in summary.get("steps", []) if s.get("converged")] if summary else []


def step_value(step: dict, key: str) -> float | None:
    """An observer of ``step["extra"]`` or a field of the step (e.g. ``max_displacement``)."""
    value = step.get("extra", {}).get(key, step.get(key))
    return float(value) if isinstance(value, (int, float)) else None


def force(step: dict, condition: str) -> float | None:
    """-R_y of the boundary condition ``condition`` in ``step``."""
    reaction = step.get("reaction", {}).get(condition)
    return -float(reaction[1]) if reaction is not None else None


def load_reached(summary: dict | None) -> float:
    """Largest load factor of a converged step (0 if none)."""
    return max([s["load"] for s in converged_steps(summary)], default=0.0)


def total_newton(summary: dict) -> int:
    """Newton iterations of all attempts, failed ones included."""
    return sum(s["newton_iterations"] for s in summary.get("steps", []))


def status(summary: dict | None, why: bool = False) -> str:
    """"full load", "not run", "interrupted at load ..." or "stopped at load ..." (with the
    failure message if ``why``)."""
    if summary is None:
        return "not run"
    if summary["converged"]:
        return "full load"
    how = "interrupted" if interrupted(summary) else "stopped"
    message = f": {summary['message']}" if why and not interrupted(summary) else ""
    return f"{how} at load {load_reached(summary):.3g}{message}"


def relative(a: float | None, b: float | None) -> float | None:
    """(b - a) / |a|; None if either is missing or a = 0."""
    if a is None or b is None or a == 0 or not (math.isfinite(a) and math.isfinite(b)):
        return None
    return (b - a) / abs(a)


def fmt(value, spec: str = ".4g", missing: str = "—") -> str:
    """``value`` formatted with ``spec``; ``missing`` for None."""
    return missing if value is None else format(value, spec)


def table(header: typing.Sequence[str], rows: typing.Iterable[typing.Sequence[str]]) -> list[str]:
    """A Markdown table."""
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] + ["| " + " | ".join(r) + " |"
                                                                             for r in rows]


# --------------------------------------------------------------------------- box tables
def final_gap(summary: dict | None) -> float | None:
    """Gap at the full load (None if the run is missing or short of it)."""
    return step_value(final_step(summary), "gap") if summary and summary["converged"] else None


def table2_dirs(root: pathlib.Path) -> dict[tuple[float, float, int], pathlib.Path]:
    """Directory of every Table 2 run, keyed (alpha_r, gamma, mesh)."""
    return {(a, g, m): box.run_dir(root / TABLE2_DIR, "huhu_lulu", box.BETA, a, g, m)
            for a, g in box.PAPER_TABLE2 for m in (1, 2, 3)}


def table3_dirs(root: pathlib.Path) -> dict[tuple[str, int], pathlib.Path]:
    """Directory of every Table 3 run, keyed (regularization, mesh)."""
    return {(r, m): box.run_dir(root / TABLE3_DIR, r, None, box.TABLE3_ALPHA_R, box.TABLE3_GAMMA, m)
            for r in box.PAPER_TABLE3 for m in (1, 2, 3)}


def sweep_dirs(run: Run, root: pathlib.Path) -> dict[tuple, pathlib.Path]:
    """The directories of a sweep's runs (Fig. 4: those of Table 2, whose runs it shares)."""
    return table2_dirs(root) if run.out == TABLE2_DIR else table3_dirs(root)


def table2_summaries(root: pathlib.Path) -> dict[tuple[float, float, int], dict | None]:
    """Summary of every Table 2 run (None if not run)."""
    return {key: read_summary(d) for key, d in table2_dirs(root).items()}


def table3_summaries(root: pathlib.Path) -> dict[tuple[str, int], dict | None]:
    """Summary of every Table 3 run (None if not run)."""
    return {key: read_summary(d) for key, d in table3_dirs(root).items()}


def gap_cell(summary: dict | None) -> str:
    """Our final gap, or the run's status when there is none."""
    gap = final_gap(summary)
    return f"{gap:.4e}" if gap is not None else status(summary)


def ratio_cell(summary: dict | None, paper: float) -> str:
    """Our final gap over the paper's (— when there is none)."""
    gap = final_gap(summary)
    return "—" if gap is None else f"{gap / paper:.3f}"


def gap_row(row: tuple, paper: typing.Sequence[float], summaries: typing.Mapping[tuple, dict | None]) -> list[str]:
    """The row's parameters, then our gap, the paper's and their ratio on meshes 1-3."""
    cells = [f"{v:g}" if isinstance(v, float) else v for v in row]
    for m in (1, 2, 3):
        summary = summaries[(*row, m)]
        cells += [gap_cell(summary), f"{paper[m - 1]:.4e}", ratio_cell(summary, paper[m - 1])]
    return cells


def gap_table(row_names: typing.Sequence[str], rows: typing.Mapping[tuple, typing.Sequence[float]],
              summaries: typing.Mapping[tuple, dict | None]) -> list[str]:
    """Our gap beside the paper's per row and mesh, then unknowns, run counts and wall time."""
    header = list(row_names) + [f"{what} mesh {m}" for m in (1, 2, 3) for what in ("g", "paper", "g/paper")]
    lines = table(header, [gap_row(row, paper, summaries) for row, paper in rows.items()])
    done = [s for s in summaries.values() if s is not None]
    dofs = {m: next((s["dofs"] for (*_, mm), s in summaries.items() if mm == m and s), None) for m in (1, 2, 3)}
    lines += ["", f"Unknowns (SFVEM): mesh 1 {fmt(dofs[1], 'd')}, mesh 2 {fmt(dofs[2], 'd')}, "
                  f"mesh 3 {fmt(dofs[3], 'd')}. Runs: {sum(bool(s['converged']) for s in done)} of "
                  f"{len(summaries)} at full load, {len(summaries) - len(done)} not run; "
                  f"{sum(total_newton(s) for s in done)} Newton iterations, solve wall time "
                  f"{_clock(sum(s['wall_time_s'] for s in done if _finite(s['wall_time_s'])))} in all."]
    return lines


def _finite(value) -> bool:
    """A finite number (wall times of interrupted runs are NaN)."""
    return isinstance(value, (int, float)) and math.isfinite(value)


# --------------------------------------------------------------------------- Table 2 acceptance
@dataclasses.dataclass(frozen=True)
class Check:
    """One acceptance criterion: PASS, FAIL, or INCOMPLETE (no failure, data missing)."""

    criterion: str
    result: str
    detail: str


def _verdict(outcomes: typing.Iterable[bool | None]) -> str:
    """FAIL if any is False, else INCOMPLETE if any is None (not evaluable), else PASS."""
    outcomes = list(outcomes)
    return "FAIL" if False in outcomes else "INCOMPLETE" if None in outcomes or not outcomes else "PASS"


def _decreasing(values: typing.Sequence[float | None]) -> bool | None:
    """Strictly decreasing over the available values (None if fewer than 2, or one missing)."""
    known = [v for v in values if v is not None]
    if len(known) < 2:
        return None
    falls = all(b < a for a, b in zip(known, known[1:]))
    return False if not falls else (None if len(known) < len(values) else True)


def _spread(values: typing.Iterable[float | None]) -> float | None:
    """log10(max / min) of the available values (None if fewer than 2)."""
    known = [v for v in values if v is not None]
    return math.log10(max(known) / min(known)) if len(known) >= 2 else None


def table2_acceptance(gaps: typing.Mapping[tuple[float, float, int], float | None]) -> list[Check]:
    """Acceptance of our Table 2 against the paper's (``box.PAPER_TABLE2``).

    Parameters
    ----------
    gaps
        Our final gap per (alpha_r, gamma, mesh); None or absent: not available (not run,
        or short of the full load).

    Returns
    -------
    list of Check
        Per row of Table 2: every gap within a factor 10 of the paper's; then: the gap falls
        as gamma falls (every alpha_r and mesh); gamma matters more than alpha_r (per mesh,
        the smallest log-spread over gamma exceeds the largest log-spread over alpha_r); every
        gamma = 1e-6 gap below 1e-3.
    """
    alpha_rs = sorted({a for a, _ in box.PAPER_TABLE2}, reverse=True)
    gammas = sorted({g for _, g in box.PAPER_TABLE2}, reverse=True)
    meshes = (1, 2, 3)
    gap = {key: gaps.get(key) for key in ((a, g, m) for a in alpha_rs for g in gammas for m in meshes)}
    lo, hi = RATIO_BAND
    checks = []
    for (a, g), paper in box.PAPER_TABLE2.items():
        ratios = [None if gap[(a, g, m)] is None else gap[(a, g, m)] / paper[m - 1] for m in meshes]
        checks.append(Check(f"alpha_r = {a:g}, gamma = {g:g}: g / paper in [{lo:g}, {hi:g}]",
                            _verdict(None if r is None else lo <= r <= hi for r in ratios),
                            " / ".join(fmt(r, ".3f") for r in ratios)))
    falls = {(a, m): _decreasing([gap[(a, g, m)] for g in gammas]) for a in alpha_rs for m in meshes}
    checks.append(Check("g falls as gamma falls (every alpha_r, mesh)", _verdict(falls.values()),
                        "; ".join(f"alpha_r {a:g} mesh {m}: {'—' if ok is None else 'yes' if ok else 'NO'}"
                                  for (a, m), ok in falls.items())))
    details, outcomes = [], []
    for m in meshes:
        by_gamma = [_spread(gap[(a, g, m)] for g in gammas) for a in alpha_rs]
        by_alpha = [_spread(gap[(a, g, m)] for a in alpha_rs) for g in gammas]
        complete = None not in by_gamma + by_alpha
        known_g, known_a = [s for s in by_gamma if s is not None], [s for s in by_alpha if s is not None]
        ok = min(known_g) > max(known_a) if known_g and known_a else None
        outcomes.append(ok if complete or ok is False else None)
        details.append(f"mesh {m}: {fmt(min(known_g, default=None), '.2f')} vs "
                       f"{fmt(max(known_a, default=None), '.2f')}")
    checks.append(Check("gamma matters more than alpha_r (smallest log10 spread over gamma > largest over alpha_r)",
                        _verdict(outcomes), "; ".join(details)))
    small = [gap[(a, SMALL_GAMMA, m)] for a in alpha_rs for m in meshes]
    checks.append(Check(f"every gamma = {SMALL_GAMMA:g} gap < {SMALL_GAP:g}",
                        _verdict(None if v is None else v < SMALL_GAP for v in small),
                        f"largest {fmt(max((v for v in small if v is not None), default=None), '.4e')}"))
    return checks


def overall(checks: typing.Sequence[Check]) -> str:
    """PASS, FAIL or INCOMPLETE over all checks (as :func:`_verdict`)."""
    return _verdict(False if c.result == "FAIL" else None if c.result == "INCOMPLETE" else True for c in checks)


def acceptance_lines(ours: typing.Sequence[Check], paper: typing.Sequence[Check]) -> list[str]:
    """The acceptance table with our result and the same check applied to the paper's values."""
    return table(("criterion", "ours", "detail (ours)", "paper's values"),
                 [(c.criterion, f"**{c.result}**", c.detail, p.result) for c, p in zip(ours, paper)]) + [
        "", f"Overall: **{overall(ours)}** (the paper's own values: {overall(paper)})."]


def paper_gaps() -> dict[tuple[float, float, int], float]:
    """The paper's Table 2 gaps keyed (alpha_r, gamma, mesh)."""
    return {(a, g, m): values[m - 1] for (a, g), values in box.PAPER_TABLE2.items() for m in (1, 2, 3)}


# --------------------------------------------------------------------------- examples
def summaries_of(example: Example, runs: typing.Mapping[str, Run], root: pathlib.Path
                 ) -> dict[tuple[str, str], dict | None]:
    """Summary of every (case, method) run of ``example`` (None if not run or not planned)."""
    return {(c.name, m): read_summary(root / runs[run_name(example, c, m)].out) if run_name(example, c, m) in runs
            else None for c in example.cases for m in METHODS}


def method_difference(example: Example, vem: dict | None, fem: dict | None
                      ) -> tuple[float | None, float | None, float | None]:
    """(load factor, force difference, key-output difference): (FEM − SFVEM) / |SFVEM| at the
    largest load factor both runs reached (None where not available)."""
    load = compare.common_load(vem, fem) if vem and fem else None
    if load is None:
        return None, None, None
    a, b = (next(s for s in converged_steps(x) if abs(s["load"] - load) <= 1e-9) for x in (vem, fem))
    key = example.output[0]
    return (load, relative(force(a, example.force), force(b, example.force)),
            relative(step_value(a, key), step_value(b, key)))


def method_label(method: str, summary: dict | None) -> str:
    """SFVEM, or the FEM with its element (P2 on triangles, Q2 on quadrilaterals) from its summary."""
    if method == "fem" and summary is not None and "cell_type" in summary:
        return {"triangle": "P2 FEM", "quadrilateral": "Q2 FEM"}[summary["cell_type"]]
    return METHOD_NAMES[method]


def method_rows(example: Example, case: Case, vem: dict | None, fem: dict | None) -> list[list[str]]:
    """Rows SFVEM, FEM (P2 or Q2) and their relative difference at the largest load both reached."""
    key, _ = example.output
    rows = []
    for method, summary in (("vem", vem), ("fem", fem)):
        last = final_step(summary)
        rows.append([case.label, method_label(method, summary), status(summary),
                     fmt(summary and summary.get("ranks"), "d"), fmt(summary and summary.get("dofs"), "d"),
                     fmt(load_reached(summary) if summary else None, ".4g"), fmt(force(last, example.force)),
                     fmt(step_value(last, key)), fmt(summary and total_newton(summary), "d"),
                     fmt(summary and summary.get("wall_time_s"), ".0f")])
    load, *diff = method_difference(example, vem, fem)
    where = "" if load is None or load >= 1 - 1e-9 else f" at load {load:.3g}"
    rows.append(["", f"FEM vs SFVEM{where}", "", "", "", ""] + [fmt(d, "+.2%") for d in diff] + ["", ""])
    return rows


def method_table(example: Example, summaries: typing.Mapping[tuple[str, str], dict | None]) -> list[str]:
    """The SFVEM vs FEM table of an example, all its configurations."""
    header = ("configuration", "method", "status", "ranks", "unknowns", "load reached",
              f"force -R_y ({example.force})", example.output[1], "Newton iterations", "solve wall time [s]")
    rows = [r for c in example.cases for r in method_rows(example, c, summaries[(c.name, "vem")],
                                                          summaries[(c.name, "fem")])]
    return table(header, rows) + ["", "Values at the last converged step; the difference row is "
                                      "(FEM − SFVEM) / |SFVEM| at the largest load factor both runs reached."]


def plot_curves(example: Example, summaries: typing.Mapping[tuple[str, str], dict | None],
                path: pathlib.Path) -> bool:
    """Force and key output over the prescribed displacement, SFVEM solid, FEM dashed (False if no data)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4), dpi=110, layout="constrained")
    key, label = example.output
    drawn = False
    for k, case in enumerate(example.cases):
        for method, style in zip(METHODS, ("-", "--")):
            summary = summaries[(case.name, method)]
            steps = converged_steps(summary)
            if not steps:
                continue
            uy = abs(float(summary["parameters"]["uy"]))
            x = [uy * s["load"] for s in steps]
            curves = ([force(s, example.force) for s in steps], [step_value(s, key) for s in steps])
            for ax, ys in zip(axes, curves):
                ax.plot(x, [math.nan if y is None else y for y in ys], style, color=f"C{k}",
                        label=f"{case.name} {METHOD_NAMES[method]}")
            drawn = True
    for ax, ylabel in zip(axes, (f"force $-R_y$ ({example.force})", label)):
        ax.set_xlabel("prescribed displacement $|u_y|$")
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        if drawn:
            ax.legend(fontsize=8)
    if example.log_output:
        axes[1].set_yscale("log")
    fig.suptitle(f"{example.title}: SFVEM (solid) and FEM (dashed)")
    if drawn:
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path)
    plt.close(fig)
    return drawn


def copy_figure(source: pathlib.Path, docs: pathlib.Path, name: str) -> str | None:
    """Copy a PNG to ``docs/figures/<name>``; the relative link, or None if there is none."""
    if not source.is_file():
        return None
    (docs / "figures").mkdir(parents=True, exist_ok=True)
    shutil.copyfile(source, docs / "figures" / name)
    return f"figures/{name}"


def image(link: str | None, alt: str) -> str:
    """Markdown image, or "not run" without a link."""
    return f"![{alt}]({link})" if link else "not run"


def figure_lines(example: Example, runs: typing.Mapping[str, Run], root: pathlib.Path,
                 docs: pathlib.Path) -> list[str]:
    """Per case: deformed mesh and u_y of both methods, and the example's own SFVEM plots."""
    lines = []
    for case in example.cases:
        names = {m: run_name(example, case, m) for m in METHODS}
        dirs = {m: root / runs[n].out if n in runs else None for m, n in names.items()}
        rows = []
        for picture in ("deformed.png", "uy.png"):
            rows.append([image(copy_figure(dirs[m] / picture, docs, f"{names[m]}-{picture}") if dirs[m] else None,
                               f"{names[m]} {picture}") for m in METHODS])
        for picture in example.figures:
            link = copy_figure(dirs["vem"] / picture, docs, f"{names['vem']}-{picture}") if dirs["vem"] else None
            rows.append([image(link, picture), ""])
        lines += [f"#### {case.label}", ""] + table([METHOD_NAMES[m] for m in METHODS], rows) + [""]
    return lines


def example_section(example: Example, runs: typing.Mapping[str, Run], root: pathlib.Path,
                    docs: pathlib.Path) -> list[str]:
    """An example's SFVEM vs FEM table, its curves and its deformed configurations."""
    summaries = summaries_of(example, runs, root)
    lines = ["### SFVEM vs FEM", ""] + method_table(example, summaries) + [""]
    curves = docs / "figures" / f"{example.key}-curves.png"
    if plot_curves(example, summaries, curves):
        lines += [f"![{example.key} curves](figures/{curves.name})", ""]
    return lines + ["### Deformed configurations", ""] + figure_lines(example, runs, root, docs)


# --------------------------------------------------------------------------- rank check
def rank_pairs(runs: typing.Sequence[Run], root: pathlib.Path
               ) -> list[tuple[Example, str, dict | None, dict | None]]:
    """(example, N-rank run name, 1-rank summary, N-rank summary) of every rank-check run."""
    by_name = {r.name: r for r in runs}
    return [(next(e for e in EXAMPLES if e.demo == run.demo), run.reference, read_summary(root / run.out),
             read_summary(root / by_name[run.reference].out) if run.reference in by_name else None)
            for run in runs if run.reference is not None]


def final_step(summary: dict | None) -> dict:
    """The last converged step ({} if none)."""
    steps = converged_steps(summary)
    return steps[-1] if steps else {}


def rank_row(example: Example, name: str, one: dict | None, many: dict | None) -> list[str]:
    """Load reached, force and key output on 1 and N ranks, wall times."""
    forces = [force(final_step(s), example.force) for s in (one, many)]
    outputs = [step_value(final_step(s), example.output[0]) for s in (one, many)]
    return [name, fmt(many and many.get("ranks"), "d"), fmt(load_reached(one) if one else None),
            fmt(load_reached(many) if many else None), fmt(forces[0], ".6g"), fmt(forces[1], ".6g"),
            fmt(relative(forces[1], forces[0]), ".1e"), fmt(outputs[0], ".6g"), fmt(outputs[1], ".6g"),
            fmt(one and one.get("wall_time_s"), ".0f"), fmt(many and many.get("wall_time_s"), ".0f")]


def rank_section(runs: typing.Sequence[Run], root: pathlib.Path) -> list[str]:
    """The 1-rank vs N-rank table of all examples."""
    header = ("run", "N", "load (1 rank)", "load (N ranks)", "force (1)", "force (N)", "relative difference",
              "key output (1)", "key output (N)", "wall [s] (1)", "wall [s] (N)")
    rows = [rank_row(*pair) for pair in rank_pairs(runs, root)]
    if not rows:
        return ["Not planned (--np 1).", ""]
    return table(header, rows) + ["", "Force and key output (as in the example's table) at the last converged "
                                      "step; relative difference (1 rank − N ranks) / |N ranks|.", ""]


# --------------------------------------------------------------------------- overview, machine
def overview(runs: typing.Sequence[Run], root: pathlib.Path) -> list[str]:
    """Every planned run: status, ranks, unknowns, load reached, solve wall time, options."""
    rows = []
    for run in runs:
        if run.sweep:
            rows.append([run.name, sweep_status(run, root), str(run.ranks), "", "", "", " ".join(run.argv)])
            continue
        summary = read_summary(root / run.out)
        rows.append([run.name, status(summary), str(run.ranks), fmt(summary and summary.get("dofs"), "d"),
                     fmt(load_reached(summary) if summary else None),
                     fmt(summary and summary.get("wall_time_s"), ".0f"), " ".join(run.argv)])
    return table(("run", "status", "ranks", "unknowns", "load reached", "solve wall time [s]", "options"), rows)


def sweep_status(run: Run, root: pathlib.Path) -> str:
    """How many of a sweep's runs are at full load (Fig. 4: whether fig4.png exists)."""
    if run.name == "box-fig4":
        return "fig4.png written" if (root / run.out / "fig4.png").is_file() else "not run"
    summaries = {key: read_summary(d) for key, d in sweep_dirs(run, root).items()}
    done = sum(bool(s and s["converged"]) for s in summaries.values())
    return f"{done} of {len(summaries)} runs at full load"


def machine() -> str:
    """CPU model, cores, OS, date and commit."""
    model = platform.processor() or platform.machine()
    try:
        model = next(line.split(":", 1)[1].strip() for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines()
                     if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    try:
        commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = "unknown"
    return (f"{model}, {os.cpu_count()} cores, {platform.system()} {platform.release()}; "
            f"generated {datetime.datetime.now():%Y-%m-%d %H:%M}, commit {commit}")


# --------------------------------------------------------------------------- where we differ
def differences(runs: typing.Sequence[Run], root: pathlib.Path) -> list[str]:
    """Bullet points computed from the data, then the stated modelling choices and the TODOs."""
    items = _gap_differences(root) + _short_runs(root) + _method_differences(runs, root) \
        + _rank_differences(runs, root) + _projection_orders(root)
    return [f"- {item}" for item in items] + [""] + STATED + [""]


def label(key: tuple) -> str:
    """A Table 2 / Table 3 row key as text: "alpha_r 10, gamma 1e-06" or the regularization."""
    return f"alpha_r {key[0]:g}, gamma {key[1]:g}" if len(key) == 2 else str(key[0])


def _gap_differences(root: pathlib.Path) -> list[str]:
    """Our gap against the paper's, measured against the spread of the paper's own meshes."""
    items = []
    tables = (("Table 2", table2_summaries(root), box.PAPER_TABLE2),
              ("Table 3", table3_summaries(root), {(r,): v for r, v in box.PAPER_TABLE3.items()}))
    for name, summaries, paper in tables:
        ratios, outside = [], []
        for key, values in paper.items():
            spread = max(max(values) / min(values), GAP_FACTOR)
            for m in (1, 2, 3):
                gap = final_gap(summaries[(*key, m)])
                if gap is None:
                    continue
                r = gap / values[m - 1]
                ratios.append(r)
                if not 1 / spread <= r <= spread:
                    outside.append(f"{label(key)}, mesh {m}: {r:.2f}")
        if not ratios:
            items.append(f"{name}: not run.")
            continue
        items.append(f"{name}: our gap / the paper's over {len(ratios)} runs: median {statistics.median(ratios):.2f}, "
                     f"range {min(ratios):.2f} to {max(ratios):.2f}. "
                     + (f"Outside the paper's own spread over its three meshes for that row (or "
                        f"{GAP_FACTOR - 1:.0%} where that is smaller): {'; '.join(outside)}. "
                        f"**TODO (maintainers): explain these.**" if outside else
                        f"Every one is within the paper's own spread over its three meshes for that row (or "
                        f"{GAP_FACTOR - 1:.0%} where that is smaller)."))
    return items


def made_runs(root: pathlib.Path) -> dict[str, dict]:
    """Every summary under ``root`` (sweep runs included, superseded ones not), by directory."""
    found = {str(path.parent.relative_to(root)): read_summary(path.parent) for path in root.glob("**/summary.json")
             if "superseded" not in path.relative_to(root).parts}
    return {name: found[name] for name in sorted(found) if found[name] is not None}


#: analysed causes of stopping short: (fnmatch pattern of run directories, what stops them)
ANALYSED_STOPS = [
    ("box-table2/huhu_lulu-beta5/*-mesh3",
     "box mesh 3 with the exp(-5 J) scaling: in four of these runs the load path meets a bifurcation, at "
     "the last converged state the tangent has one negative eigenvalue (-5e-9 to -3e-7, the next ones "
     "positive) whose mode lives in the medium at a corner of the cavity, where the flange turns against "
     "the wall; the upper corner quads are stretched on average (J 1.7 to 3.7) while pinched at a vertex "
     "(J down to 0.02), and the scaling has switched their regularization almost off (exp(-5 * 1.7) = "
     "2e-4). The run with alpha_r = 0.1 stops at load 0.91 in the contact zone at mid-span (J down to "
     "2e-3) with a positive definite tangent. Tried without effect: the full sub-triangle quadrature "
     "(stops earlier), an absolute tolerance of 1e-8, trust-region Newton, a perturbation along the "
     "unstable mode. Without the scaling (`--no-beta`, as in Table 3, whose mesh-3 runs all reach the "
     "full load) all five reach the full load on mesh 3 (gaps 4.42e-4, 4.52e-4, 7.87e-3, 1.88e-3 for "
     "alpha_r 1 / 0.1 at gamma 1e-6 and alpha_r 10 at 1e-4 / 1e-5; the paper, with the scaling: 4.90e-4, "
     "4.64e-4, 7.50e-3, 1.73e-3). A higher projection order in the medium takes alpha_r = 1, gamma = 1e-6 "
     "further but not to the end (l = 4: load 0.62, l = 5: 0.72), and so do splitting the non-convex solid "
     "polygons at the re-entrant corners (0.35), a solid of squares (0.73; alpha_r = 10: 0.60) and medium quads "
     "of h/4 (0.45; alpha_r = 10: 0.53); 200 Newton iterations per step gain no step. The "
     "paper's mesh 3 is not shown; its corners may be meshed differently (demos/box_self_contact.py)"),
]


#: analysed causes of SFVEM vs FEM force differences above METHOD_TOLERANCE, by example key
ANALYSED_METHOD_DIFFERENCES = {
    "box": "not found yet (**TODO (maintainers)**); measured (mesh 1, gamma = 1e-5, final force): it is "
           "not the regularization (alpha_r = 0: SFVEM 0.04953, FEM 0.05257, +6.1 %), not the FEM element "
           "(Q2 on a grid of the box: 0.05295), not the SFVEM medium mesh (meshes 1 / 2 / 3: 0.04956 / "
           "0.04955 / 0.04943); it builds up once the flanges touch (FEM vs SFVEM at load 0.25 / 0.5 / 0.75 / "
           "1: -1.4 / +0.1 / +1.4 / +6.1 %) and shrinks slowly with the solid mesh (h = 0.025, 21586 / 22106 "
           "unknowns: 0.04929 vs 0.05189, +5.3 %); spreading the three point conditions over short segments "
           "widens it (+12.9 %)",
    "multi": "the P2 FEM hardly feels the regularization. Before contact (BC 1, u_y = -0.03, h = 0.04) "
             "alpha_r = 0 / 1 / 10 give FEM forces 6.189e-4 / 6.212e-4 / 6.213e-4 and SFVEM forces "
             "6.189e-4 / 7.832e-4 / 1.221e-3; with alpha_r = 10, refining to h = 0.028 and 0.02 leaves the "
             "FEM force at 6.215e-4 and brings the SFVEM's down to 1.065e-3 and 9.67e-4. A P2 field can put "
             "its bending into kinks along element edges, where the cell-wise G sees none of it, so the FEM "
             "medium is the softer one. The SFVEM's G is projected over whole polygons, so it sees these kinks "
             "inside each polygon. In BC 2 the discs slide sideways against the medium alone (disc 1: u_x "
             "0.11 SFVEM, 0.22 FEM), so the difference lasts to the full load; in BC 1 (u_x = 0) the solids "
             "carry the load once in contact and the forces agree to 0.5 %",
}


def explain_stops(names: typing.Iterable[str]) -> tuple[dict[str, list[str]], list[str]]:
    """Sort run directories that stopped short by :data:`ANALYSED_STOPS`.

    Returns
    -------
    explained
        Explanation -> the runs it covers.
    unexplained
        Runs no analysed cause covers.
    """
    explained: dict[str, list[str]] = {}
    unexplained = []
    for name in names:
        cause = next((why for pattern, why in ANALYSED_STOPS if fnmatch.fnmatch(name, pattern)), None)
        if cause is None:
            unexplained.append(name)
        else:
            explained.setdefault(cause, []).append(name)
    return explained, unexplained


def _short_runs(root: pathlib.Path) -> list[str]:
    """Every run made (sweeps included) that stopped short of the full load, with its message and,
    where analysed, the cause."""
    short = {name: s for name, s in made_runs(root).items() if not s["converged"]}
    paused = [name for name, s in short.items() if interrupted(s)]
    failed = {name: s for name, s in short.items() if name not in paused}
    items = [f"Interrupted, `make results` continues them: {', '.join(paused)}."] if paused else []
    if not failed:
        return items + ["Every run that finished reached the full load."]
    explained, unexplained = explain_stops(failed)
    items += [f"Runs short of the full load: {'; '.join(f'{n} ({status(s, why=True)})' for n, s in failed.items())}."]
    items += [f"Why ({', '.join(names)}): {why}." for why, names in explained.items()]
    if unexplained:
        items.append(f"Not analysed: {', '.join(unexplained)}. **TODO (maintainers): why.**")
    return items


def _method_differences(runs: typing.Sequence[Run], root: pathlib.Path) -> list[str]:
    """SFVEM vs FEM: the largest relative force difference per example."""
    by_name = {r.name: r for r in runs}
    items = []
    for example in EXAMPLES:
        summaries = summaries_of(example, by_name, root)
        diffs = {c.name: method_difference(example, summaries[(c.name, "vem")], summaries[(c.name, "fem")])[1]
                 for c in example.cases}
        known = {k: d for k, d in diffs.items() if d is not None}
        if not known:
            continue
        worst = max(known, key=lambda k: abs(known[k]))
        note = "" if abs(known[worst]) <= METHOD_TOLERANCE else \
            f", above {METHOD_TOLERANCE:.0%}. Why: {ANALYSED_METHOD_DIFFERENCES[example.key]}" \
            if example.key in ANALYSED_METHOD_DIFFERENCES else \
            f", above {METHOD_TOLERANCE:.0%}: **TODO (maintainers): explain**"
        items.append(f"{example.title}: SFVEM and FEM forces differ by at most {known[worst]:+.2%} "
                     f"({worst}){note}.")
    return items


def _rank_differences(runs: typing.Sequence[Run], root: pathlib.Path) -> list[str]:
    """The largest relative difference of the final force between 1 and N ranks."""
    diffs = [(name, relative(force(final_step(many), example.force), force(final_step(one), example.force)))
             for example, name, one, many in rank_pairs(runs, root)
             if one and many and one["converged"] and many["converged"]]
    known = [(n, d) for n, d in diffs if d is not None]
    if not known:
        return []
    worst = max(known, key=lambda x: abs(x[1]))
    verdict = "" if abs(worst[1]) <= RANK_TOLERANCE else " **TODO (maintainers): above 1e-6, explain.**"
    return [f"1 rank vs N ranks: final forces agree to {abs(worst[1]):.1e} relative at worst ({worst[0]}).{verdict}"]


def _projection_orders(root: pathlib.Path) -> list[str]:
    """Runs in which the rank check chose l > 3 (the paper uses l = 3 throughout)."""
    made = made_runs(root)
    higher = {name: sum(n for l, n in s.get("projection_order_histogram", {}).items() if int(l) > 3)
              for name, s in made.items()}
    higher = {name: n for name, n in higher.items() if n}
    if not higher:
        return []
    most = max(higher, key=higher.get)
    return [f"Projection order l: the paper uses l = 3; our rank check (docs/method.md §3, README \"Choice of l\") chose "
            f"l > 3 in {len(higher)} of {len(made)} runs, on at most {higher[most]} of {made[most]['polygons']} "
            f"polygons ({most}): polygons with 8 or more vertices (the paper's Eq. 40 also asks for l > 3 "
            f"there) or with several hanging nodes on one side, which keep spurious zero-energy modes at "
            f"l = 3 (meshes/summary.md)."]


#: choices stated in the demos' docstrings and meshes/README.md (not computed)
STATED = [
    "Choices of ours where the paper's figures are missing (stated in each demo's docstring and in "
    "`meshes/README.md`):",
    "",
    "- mesh sizes and the medium quads of the box and C-box meshes (solid: dual polygons of a gmsh triangle "
    "mesh of size h; medium: quads of size h, h/2, h/3); point load at one node in the box and C-box;",
    "- |F| in the exp(-beta |F|) scaling of Eq. 8 is read as J = det F; Table 3 is run without the scaling;",
    "- punch: initial gap 1 between the punch tip and the block (u_y = -1.3 indents the block by 0.3), "
    "block bottom clamped, half model;",
    "- multiple objects: the 7 half-discs evenly spaced above the block with a gap of 0.1, driven through "
    "their flat tops by u_y = -0.3 in 30 steps (the paper gives no load value).",
    "",
    "**TODO (maintainers):** the paper gives only figures for §5.2-5.4; compare the deformed configurations "
    "above with its Figs. 7, 8, 10, 11, 13 and 14 and note the differences here.",
]


# --------------------------------------------------------------------------- the page
def box_tables(root: pathlib.Path, docs: pathlib.Path) -> tuple[list[str], list[Check]]:
    """Table 2 with the acceptance check, Table 3 and Fig. 4; also returns our checks."""
    t2 = table2_summaries(root)
    ours = table2_acceptance({k: final_gap(s) for k, s in t2.items()})
    fig4 = copy_figure(root / TABLE2_DIR / "fig4.png", docs, "box-fig4.png")
    lines = ["### Table 2: gap g at u_y = -1, huhu_lulu with exp(-5 J)", ""]
    lines += gap_table(("alpha_r", "gamma"), box.PAPER_TABLE2, t2) + ["", "#### Acceptance check", ""]
    lines += acceptance_lines(ours, table2_acceptance(paper_gaps())) + [""]
    lines += [f"### Table 3: gap g, gamma = {box.TABLE3_GAMMA:g}, alpha_r = {box.TABLE3_ALPHA_R:g}, "
              "no scaling", ""]
    lines += gap_table(("regularization",), {(r,): v for r, v in box.PAPER_TABLE3.items()}, table3_summaries(root))
    lines += ["", "### Fig. 4: gap and force over the load, alpha_r = 0.1, mesh 3", "", image(fig4, "Fig. 4"), ""]
    return lines, ours


def report(runs: typing.Sequence[Run], root: pathlib.Path, docs: pathlib.Path, quick: bool) -> tuple[str, list[Check]]:
    """The Markdown page (PNGs copied to ``docs/figures``) and the Table 2 acceptance checks."""
    by_name = {r.name: r for r in runs}
    lines = ["# Results: the paper's examples with SFVEM and FEM", "",
             f"Generated by `make results` (`demos/results.py`{' --quick' if quick else ''}) from the runs in "
             f"`{root}`. Machine: {machine()}.", "", FEM_NOTE, ""]
    if quick:
        lines += ["**Quick mode: coarse meshes and few load steps, not the paper's settings.**", ""]
    lines += ["## Runs", ""] + overview(runs, root) + [""]
    checks: list[Check] = []
    for example in EXAMPLES:
        lines += [f"## {example.title}", ""]
        if example.key == "box":
            box_lines, checks = box_tables(root, docs)
            lines += box_lines
        lines += example_section(example, by_name, root, docs)
    lines += ["## 1 rank vs N ranks", ""] + rank_section(runs, root)
    lines += ["## Where we differ from the paper and why", ""] + differences(runs, root)
    lines += ["## Reproduce", "", "```", "make results                 # everything (hours; restartable)",
              "make results RESULTS_OPTS=--quick   # the pipeline on coarse meshes in a few minutes",
              "python3 demos/results.py --list     # the plan with states and estimated times", "```", ""]
    return "\n".join(lines), checks


def write_report(runs: typing.Sequence[Run], root: pathlib.Path, docs: pathlib.Path, quick: bool) -> list[Check]:
    """Write ``docs/results.md``; returns the Table 2 acceptance checks."""
    docs.mkdir(parents=True, exist_ok=True)
    text, checks = report(runs, root, docs, quick)
    post.atomic_write_text(docs / "results.md", text)
    return checks


# --------------------------------------------------------------------------- command line
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


def print_plan(runs: typing.Sequence[Run], root: pathlib.Path, retry_failed: bool) -> None:
    """One line per run: state, ranks, estimate, command; then the total still to make."""
    left = {r.name: remaining(r, root, retry_failed) for r in runs}
    for run in runs:
        print(f"{run.name:24s} {state(run, root):12s} {run.ranks} rank(s)  estimate {_clock(run.seconds):>8s}  "
              f"{run.demo}.py {' '.join(run.argv)}")
    print(f"{sum(t > 0 for t in left.values())} of {len(runs)} runs to make, estimated "
          f"{_clock(sum(left.values()))}")


def main(argv: typing.Sequence[str] | None = None) -> int:
    """Run what is selected, write the page; returns the exit code (module docstring)."""
    args = make_parser().parse_args(argv)
    signal.signal(signal.SIGTERM, signal.default_int_handler)      # stop like Ctrl-C
    if args.np < 1:
        raise SystemExit("--np must be >= 1")
    root = args.out / ("results-quick" if args.quick else "results")
    docs = args.docs or (root / "docs" if args.quick else REPO / "docs")
    runs = plan(args.quick, args.np)
    try:
        selected = select(runs, args.only)
    except ValueError as err:
        raise SystemExit(str(err)) from None
    if args.list:
        print_plan(selected, root, args.retry_failed)
        return 0
    completed, codes = (True, {}) if args.report_only else execute(selected, root, args.retry_failed)
    checks = write_report(runs, root, docs, args.quick)
    print("Table 2 acceptance:")
    for check in checks:
        print(f"  {check.result:10s} {check.criterion}: {check.detail}")
    print(f"  overall: {overall(checks)}\nwrote {docs / 'results.md'}", flush=True)
    if not completed:
        return 130
    made = [read_summary(root / r.out) for r in selected if not r.sweep]
    return 0 if all(s and s["converged"] for s in made) and not any(codes.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
