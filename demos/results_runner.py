"""The restartable runner of ``make results`` (and of ``demos/refinement.py``): each run of the plan
as its own MPI subprocess, skipped, resumed or started afresh by its state (:mod:`restart`, the
decision the box sweeps share), with progress lines and time estimates."""
from __future__ import annotations

import datetime
import importlib
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import time
import typing

from dolfinx_sfvem import mpi_launcher
from dolfinx_sfvem.output.run_output import HDF5_SIGNATURE
from dolfinx_sfvem.output.run_summary import read_summary
from restart import run_state
from results_plan import DEMOS, Run, clock, sweep_dirs


def expected_parameters(run: Run) -> dict:
    """The parameters the demo stores for ``run.argv`` (from the demo's own parser)."""
    args, _ = importlib.import_module(run.demo).make_parser().parse_known_args(list(run.argv))
    return {k: v for k, v in vars(args).items() if k not in ("out", "quiet", "resume")}


def state(run: Run, root: pathlib.Path) -> str:
    """``sweep``, ``missing``, ``done``, ``failed``, ``interrupted`` (resumable), or ``other``
    (a summary of other parameters, or an interrupted run without checkpoint)."""
    if run.sweep:
        return "sweep"
    return run_state(read_summary(root / run.out), expected_parameters(run), root / run.out)


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
    env = mpi_launcher.job_environment({"OMP_NUM_THREADS": "1", **os.environ})   # a job of its own
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
    if summary is None or not summary.interrupted or not unclosed_xdmf(out):
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
            print(f"[{k + 1}/{len(runs)}] {run.name}: {note} (estimate {clock(run.seconds)})", flush=True)
            t0 = time.perf_counter()
            try:
                codes[run.name] = launch(run, root, resume, retry_failed)
            except Interrupted:
                return False, codes
            took = time.perf_counter() - t0
            spent, estimated = spent + took, estimated + run.seconds
            note = f"exit code {codes[run.name]} in {clock(took)}"
        speed = spent / estimated if estimated > 0 else 1.0
        left = speed * sum(remaining(r, root, retry_failed) for r in runs[k + 1:])
        print(f"[{k + 1}/{len(runs)}] {run.name}: {note} | elapsed {clock(time.perf_counter() - start)}"
              f" | left ~{clock(left)}", flush=True)
    return True, codes


def remaining(run: Run, root: pathlib.Path, retry_failed: bool) -> float:
    """Estimated seconds ``run`` still needs (a sweep: the share of its runs not at full load)."""
    if run.sweep:
        summaries = {key: read_summary(d) for key, d in sweep_dirs(run, root).items()}
        return run.seconds * sum(not (s and s.converged) for s in summaries.values()) / len(summaries)
    current = state(run, root)
    return 0.0 if current == "done" or (current == "failed" and not retry_failed) else run.seconds
