"""Benchmark harness: SFVEM vs P2 FEM on the C-box and the box, one table and results.json.

Usage::

    python3 bench/run.py [--quick] [--out DIR] [--geometries cbox box]

(``make bench`` runs the full version into ``out/bench``.) Every measurement runs in a
fresh process of ``bench/case.py``, in this order:

1. cold start, per method: the first geometry at its smallest size with empty numba and
   FFCx caches (private directories through ``NUMBA_CACHE_DIR`` and ``XDG_CACHE_HOME``);
   set-up and first assembly only;
2. per geometry and method, serially: all sizes (set-up, repeated assembly, load path,
   peak memory). Same cache directories, now filled: the first size of the first
   geometry is the warm second start of step 1;
3. right after each process of step 2, the same geometry and method on 2 MPI ranks:
   the largest size, set-up and repeated assembly, for the MPI speed-up.

Full: sizes up to more than 1e5 SFVEM unknowns; ``--quick``: a few thousand (a few
minutes). Writes ``DIR/results.json`` (all measurements, the derived quantities,
the machine), ``DIR/results.md`` (the table for the README) and ``DIR/logs/``.
Nothing here is asserted: timings are reported, never checked.
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time
import typing

HERE = pathlib.Path(__file__).resolve().parent
#: the interpreter of the benchmark processes: the repository's venv (``make install``) if
#: there is one, else this one; the driver itself needs only the standard library
PYTHON = next((str(p) for p in [HERE.parent / ".venv" / "bin" / "python"] if p.exists()), sys.executable)
sys.path.insert(0, str(HERE))
import report  # noqa: E402
from geometries import GEOMETRIES  # noqa: E402

METHODS = ("vem", "fem")
#: ranks of the MPI speed-up measurement
RANKS = 2


def _load_mpi_launcher():
    """``dolfinx_sfvem/mpi_launcher.py`` without importing the package (it loads DOLFINx)."""
    spec = importlib.util.spec_from_file_location("mpi_launcher", HERE.parent / "dolfinx_sfvem" / "mpi_launcher.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


mpi_launcher = _load_mpi_launcher()


def cache_env(cache: pathlib.Path) -> dict[str, str]:
    """The environment of a benchmark process with its numba and FFCx caches under ``cache``."""
    return mpi_launcher.job_environment(NUMBA_CACHE_DIR=str(cache / "numba"), XDG_CACHE_HOME=str(cache / "xdg"), OMP_NUM_THREADS="1")


class Runner:
    """Starts benchmark processes and collects their JSON.

    Parameters
    ----------
    out
        Output directory (``logs/`` and ``raw/`` go there).
    caches
        Directory holding one numba/FFCx cache directory per method.
    """

    def __init__(self, out: pathlib.Path, caches: pathlib.Path):
        self.out = out
        self.caches = caches
        (out / "logs").mkdir(parents=True, exist_ok=True)
        (out / "raw").mkdir(parents=True, exist_ok=True)

    def case(self, name: str, geometry: str, method: str, sizes: typing.Sequence[float],
             options: typing.Sequence[str] = (), np: int = 1) -> dict:
        """Run ``case.py`` for one geometry and method; its JSON, with the process wall time added."""
        raw = self.out / "raw" / f"{name}.json"
        raw.unlink(missing_ok=True)
        cmd = [*mpi_launcher.command(np if np > 1 else None, PYTHON), PYTHON, str(HERE / "case.py"),
               "--geometry", geometry, "--method", method, "--h", *map(str, sizes), "--json", str(raw), *options]
        log = self.out / "logs" / f"{name}.log"
        print(f"[bench] {name}: {geometry} {method} h = {', '.join(map(str, sizes))} on {np} rank(s)", flush=True)
        start = time.perf_counter()
        with open(log, "w") as f:
            code = subprocess.call(cmd, stdout=f, stderr=subprocess.STDOUT, env=cache_env(self.caches / method))
        wall = time.perf_counter() - start
        if code != 0 or not raw.exists():
            raise RuntimeError(f"benchmark process {name} failed (exit code {code}); see {log}")
        print(f"[bench] {name}: {wall:.1f} s", flush=True)
        return {**json.loads(raw.read_text()), "process_wall_from_parent": wall}


def measure(runner: Runner, geometries: typing.Sequence[str], quick: bool, min_time: float
            ) -> tuple[dict, dict, dict]:
    """Steps 1-3 of the module docstring: (startups by method, main and mpi by geometry and method)."""
    first = GEOMETRIES[geometries[0]]
    startups = {m: runner.case(f"cold-{first.name}-{m}", first.name, m, first.sizes(quick)[:1], ["--startup-only"])
                for m in METHODS}
    timing = ["--min-time", str(min_time)]
    main: dict[str, dict] = {g: {} for g in geometries}
    mpi: dict[str, dict] = {g: {} for g in geometries}
    for g in geometries:
        sizes = GEOMETRIES[g].sizes(quick)
        for m in METHODS:       # the N-rank run right after its serial reference
            main[g][m] = runner.case(f"{g}-{m}", g, m, sizes, timing)
            mpi[g][m] = runner.case(f"{g}-{m}-np{RANKS}", g, m, sizes[-1:], [*timing, "--no-load-path"], np=RANKS)
    return startups, main, mpi


def write_results(out: pathlib.Path, results: dict, text: str, markdown: str) -> None:
    """results.json and results.md."""
    (out / "results.json").write_text(json.dumps(report.finite(results), indent=1) + "\n")
    (out / "results.md").write_text(markdown)
    print(text, flush=True)
    print(f"\nwrote {out / 'results.json'} and {out / 'results.md'}", flush=True)


def parse_args(argv: typing.Sequence[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="small meshes (a few thousand unknowns)")
    p.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out") / "bench",
                   help="output directory (default %(default)s)")
    p.add_argument("--geometries", nargs="+", choices=sorted(GEOMETRIES), default=["cbox", "box"],
                   help="geometries (default: %(default)s); the first one is used for the cold start")
    p.add_argument("--min-time", type=float, default=None,
                   help="least total time of the repeated assemblies per size (s; default 0.3 quick, 1 full)")
    return p.parse_args(argv)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    min_time = args.min_time if args.min_time is not None else (0.3 if args.quick else 1.0)
    load_before = [round(x, 2) for x in os.getloadavg()]
    start = time.perf_counter()
    caches = pathlib.Path(tempfile.mkdtemp(prefix="sfvem-bench-cache-"))
    try:
        startups, main_runs, mpi = measure(Runner(args.out, caches), args.geometries, args.quick, min_time)
    finally:
        shutil.rmtree(caches, ignore_errors=True)
    machine = {**report.machine(main_runs[args.geometries[0]]["vem"]["versions"]), "interpreter": PYTHON,
               "load_average_before": load_before, "load_average_after": [round(x, 2) for x in os.getloadavg()]}
    derived = report.derive(main_runs, mpi, startups)
    rows = report.table_rows(main_runs)
    lines = report.key_figures(derived, RANKS)
    results = {"quick": args.quick, "ranks_mpi": RANKS, "machine": machine,
               **{k: derived[k] for k in ("assembly_ratio_vem_over_fem", "mpi_speedup_assembly_2",
                                          "mpi_speedup_assembly_2_fem", "headline_case")},
               "derived": derived, "table": {"header": list(report.HEADER), "rows": rows},
               "runs": {"cold": startups, "serial": main_runs, "mpi": mpi},
               "geometries": {g: dataclasses.asdict(GEOMETRIES[g]) for g in args.geometries},
               "benchmark_wall_s": time.perf_counter() - start, "definitions": report.DEFINITIONS}
    write_results(args.out, results, report.format_text(rows, lines, machine),
                  report.format_markdown(rows, lines, machine, args.quick))
    return 0


if __name__ == "__main__":
    sys.exit(main())
