"""Equal-accuracy benchmark: SFVEM vs FEM, time to an answer of a given accuracy (issue 24).

Usage::

    python3 bench/accuracy.py [--quick] [--list] [--examples cbox box punch multi] [--out DIR]
                              [--results DIR] [--retry-failed] [--report-only]

(``make bench`` runs it last, into ``out/accuracy``, and keeps the page in ``bench/accuracy.{md,json}``.)
Per example (``accuracy_plan.py``): a ladder of uniform meshes for each method and a few locally
refined SFVEM meshes, every run a fresh process of ``accuracy_case.py`` at 1 rank
(OMP_NUM_THREADS=1), one at a time, cheapest first, the demo's defaults otherwise. From the
records: the reference force and gap by Richardson extrapolation of both methods' uniform
ladders with an error estimate (``accuracy_reference.py``), then per method the cheapest run
with the force within 1 % and the gap within 5 % of the reference, its time to the answer,
the SFVEM/FEM ratio and the goal's verdict (``accuracy_report.py``).

Restartable: a run whose record (``DIR/records/<run>.json``) has the same demo options and
refinement is reused; a run stopped by Ctrl-C or SIGTERM is made again from the start (its
time would not be one run's). A run that stopped short of the full load is not repeated unless
``--retry-failed``. The page is rewritten after every run, so a study cut short leaves the
page of what finished. ``--list`` prints the plan with states and estimated times.
Nothing is asserted: timings are reported, never checked.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import pathlib
import resource
import shutil
import signal
import subprocess
import sys
import time
import typing

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from accuracy_plan import EXAMPLES, Config, plan  # noqa: E402
from accuracy_report import analyse, as_json, markdown  # noqa: E402
from run import PYTHON, mpi_launcher  # noqa: E402


def record_path(out: pathlib.Path, config: Config) -> pathlib.Path:
    return out / "records" / f"{config.name}.json"


def command(config: Config, out: pathlib.Path) -> list[str]:
    """The process of one run."""
    refine = ("--refine", *(f"{r}:{k}" for r, k in config.refine)) if config.refine else ()
    return [PYTHON, str(HERE / "accuracy_case.py"), "--record", str(record_path(out, config)),
            "--example", config.example.key, *refine, "--", *config.argv, "--out", str(out / "runs" / config.name),
            "--quiet"]


def state(config: Config, out: pathlib.Path) -> tuple[str, dict | None]:
    """(``done``, ``failed``, ``other`` or ``missing``, the record if it is this run's)."""
    path = record_path(out, config)
    if not path.exists():
        return "missing", None
    record = json.loads(path.read_text())
    if record.get("argv", [])[:len(config.argv)] != list(config.argv) or record.get("refine") != [
            list(x) for x in config.refine] or not (out / "runs" / config.name / "summary.json").exists():
        return "other", None
    return ("done" if record["exit_code"] == 0 and record["converged"] else "failed"), record


class Interrupted(Exception):
    """Ctrl-C or SIGTERM during a run."""


def launch(config: Config, out: pathlib.Path) -> dict | None:
    """Make one run (a fresh process) and return its record, with the process's wall and CPU time
    (None if the process wrote none: it crashed, and the next invocation makes it again)."""
    (out / "logs").mkdir(parents=True, exist_ok=True)
    record_path(out, config).unlink(missing_ok=True)
    cpu_before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    with open(out / "logs" / f"{config.name}.log", "w") as log:
        proc = subprocess.Popen(command(config, out), stdout=log, stderr=subprocess.STDOUT,
                                env=mpi_launcher.job_environment(OMP_NUM_THREADS="1"))
        try:
            proc.wait()
        except KeyboardInterrupt:
            proc.send_signal(signal.SIGTERM)
            proc.wait()
            record_path(out, config).unlink(missing_ok=True)
            raise Interrupted from None
    wall = time.perf_counter() - start
    cpu_after = resource.getrusage(resource.RUSAGE_CHILDREN)
    path = record_path(out, config)
    if not path.exists():
        return None
    record = json.loads(path.read_text())
    record.update(process_wall_s=wall, process_cpu_s=(cpu_after.ru_utime + cpu_after.ru_stime)
                  - (cpu_before.ru_utime + cpu_before.ru_stime))
    path.write_text(json.dumps(record, indent=1) + "\n")
    return record


def clock(seconds: float) -> str:
    return str(datetime.timedelta(seconds=round(seconds)))


def print_plan(configs: typing.Sequence[Config], out: pathlib.Path, retry_failed: bool) -> None:
    left = 0.0
    for c in configs:
        s, _ = state(c, out)
        todo = s in ("missing", "other") or (s == "failed" and retry_failed)
        left += c.seconds if todo else 0.0
        print(f"{c.name:40s} {s:8s} estimate {clock(c.seconds):>8s}  {' '.join(c.argv)}"
              + (f"  refine {' '.join(f'{r}:{k}' for r, k in c.refine)}" if c.refine else ""))
    print(f"{sum(state(c, out)[0] not in ('done', 'failed') for c in configs)} of {len(configs)} runs to make, "
          f"estimated {clock(left)} at 1 rank")


def machine() -> dict:
    with open("/proc/cpuinfo") as f:
        cpu = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), "unknown")
    return {"cpu": cpu, "cores": os.cpu_count()}


def write_page(configs: typing.Sequence[Config], records: dict[str, dict], out: pathlib.Path, quick: bool,
               examples: typing.Sequence[str], results_dir: pathlib.Path | None) -> None:
    """accuracy.md and accuracy.json in ``out`` (and copies in ``results_dir``)."""
    results = [analyse(key, configs, records) for key in examples]
    cmd = "python3 bench/accuracy.py" + (" --quick" if quick else "")
    (out / "accuracy.json").write_text(json.dumps(as_json(results, machine(), quick), indent=1, default=float) + "\n")
    (out / "accuracy.md").write_text(markdown(results, machine(), quick, cmd))
    if results_dir is not None:
        results_dir.mkdir(parents=True, exist_ok=True)
        for name in ("accuracy.json", "accuracy.md"):
            shutil.copy(out / name, results_dir / name)


def parse_args(argv: typing.Sequence[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="coarse ladders and small loads: a pipeline check in minutes")
    p.add_argument("--list", action="store_true", help="print the plan with states and estimated times, run nothing")
    p.add_argument("--examples", nargs="+", choices=tuple(EXAMPLES), default=list(EXAMPLES))
    p.add_argument("--out", type=pathlib.Path, default=None,
                   help="runs, records and pages (default out/accuracy, with --quick out/accuracy-quick)")
    p.add_argument("--results", type=pathlib.Path, default=None,
                   help="also copy accuracy.md and accuracy.json into this directory (e.g. bench)")
    p.add_argument("--retry-failed", action="store_true", help="repeat runs that stopped short of the full load")
    p.add_argument("--report-only", action="store_true", help="write the page from the records, run nothing")
    args = p.parse_args(argv)
    if args.out is None:
        args.out = pathlib.Path("out") / ("accuracy-quick" if args.quick else "accuracy")
    return args


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    configs = plan(args.quick, args.examples)
    if args.list:
        print_plan(configs, args.out, args.retry_failed)
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    signal.signal(signal.SIGTERM, signal.default_int_handler)          # stop like Ctrl-C
    records = {}
    for c in configs:
        s, record = state(c, args.out)
        if record is not None:
            records[c.name] = record
    start = time.perf_counter()
    for k, c in enumerate(configs):
        s, _ = state(c, args.out)
        if args.report_only or s == "done" or (s == "failed" and not args.retry_failed):
            continue
        print(f"[{k + 1}/{len(configs)}] {c.name}: running (estimate {clock(c.seconds)})", flush=True)
        try:
            record = launch(c, args.out)
        except Interrupted:
            print(f"[{k + 1}/{len(configs)}] {c.name}: interrupted; the same command continues", flush=True)
            write_page(configs, records, args.out, args.quick, args.examples, args.results)
            return 130
        if record is None:
            print(f"[{k + 1}/{len(configs)}] {c.name}: no record (the process crashed, see "
                  f"{args.out / 'logs' / c.name}.log); made again by the next invocation", flush=True)
            continue
        records[c.name] = record
        print(f"[{k + 1}/{len(configs)}] {c.name}: {'full load' if record['converged'] else 'stopped'}, "
              f"{record['unknowns']} unknowns, {record['newton_iterations']} Newton its, "
              f"{record['setup']['wall'] + record['summary_wall_s']:.1f} s to the answer, process "
              f"{clock(record['process_wall_s'])} | elapsed {clock(time.perf_counter() - start)}", flush=True)
        write_page(configs, records, args.out, args.quick, args.examples, args.results)
    write_page(configs, records, args.out, args.quick, args.examples, args.results)
    print((args.out / "accuracy.md").read_text(), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
