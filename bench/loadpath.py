"""Load-path benchmark: time to full load of the paper's four examples, SFVEM against FEM.

Usage::

    python3 bench/loadpath.py [--quick] [--examples cbox box punch multi] [--line-search l2 bt]
                              [--out DIR] [--results DIR]

(``make bench`` runs it into ``out/loadpath`` and keeps the table in ``bench/loadpath.{md,json}``.)
Every run is a fresh process of ``loadpath_case.py`` (one demo, one method, one line search,
1 rank, the numba and FFCx caches of the user), all in one invocation so that the ratios compare runs on the same machine state.
The examples (``demos/``, their defaults unless listed; reduced where the full size takes
longer than a few minutes on one core):

- ``cbox``: C-box (§5.2), h = 0.05, u_y = -0.5 in 25 steps (FEM: P2 on a matched triangulation);
- ``box``: box self-contact (§5.1), mesh 1, h = 0.05, 100 steps;
- ``punch``: soft punch (§5.3), h = 0.1 (the demo's 0.05 takes 10 min), 130 steps;
- ``multi``: multiple objects (§5.4), BC 1, h = 0.04, 30 steps: polygons everywhere,
  about 4.5e4 unknowns.

The FEM meshes are matched to the SFVEM's unknowns by the package (``method="fem"``).
Writes ``DIR/loadpath.json`` (every run's measurements) and ``DIR/loadpath.md`` (the table,
per Newton iteration, ratios SFVEM/FEM); ``--results DIR`` copies both there. Nothing is
asserted: timings are reported, never checked.
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import time
import typing

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from run import PYTHON, mpi_launcher  # noqa: E402

#: example -> (demo module, its options); quick sizes for checking the pipeline in minutes
EXAMPLES: dict[str, tuple[str, tuple[str, ...]]] = {
    "cbox": ("cbox", ("--h", "0.05", "--uy", "-0.5", "--steps", "25")),
    "box": ("box_self_contact", ("--mesh", "1", "--h", "0.05", "--steps", "100")),
    "punch": ("punch", ("--punch", "soft", "--h", "0.1", "--steps", "130")),
    "multi": ("multi_object", ("--bc", "1", "--h", "0.04", "--steps", "30")),
}
QUICK: dict[str, tuple[str, ...]] = {
    "cbox": ("--h", "0.1", "--uy", "-0.3", "--steps", "10"),
    "box": ("--mesh", "1", "--h", "0.1", "--steps", "40"),
    "punch": ("--punch", "soft", "--h", "0.2", "--steps", "65"),
    "multi": ("--bc", "1", "--h", "0.08", "--steps", "30"),
}
METHODS = ("vem", "fem")
#: options of the FEM run only: the C-box's default FEM is Q2 on a coarser grid, P2 on a matched
#: triangulation has the SFVEM's unknowns
FEM_OPTIONS: dict[str, tuple[str, ...]] = {"cbox": ("--fem-cells", "triangles")}

#: ``--line-search`` value that gives no line-search option: the solver's own policy
DEFAULT_LINE_SEARCH = "default"

HEADER = ("example", "method", "line search", "unknowns", "load", "Newton its", "residuals/it",
          "per it ms: tangent / residual / factor+solve / checks / output / other",
          "solve s", "set-up s", "peak MB", "SFVEM/FEM time", "SFVEM/FEM memory")


def run_case(out: pathlib.Path, example: str, method: str, line_search: str,
             quick: bool) -> dict:
    """One fresh ``loadpath_case.py`` process; its JSON."""
    demo, options = EXAMPLES[example]
    options = (*(QUICK[example] if quick else options), *(FEM_OPTIONS.get(example, ()) if method == "fem" else ()))
    name = f"{example}-{method}-{line_search}"
    raw, log = out / "raw" / f"{name}.json", out / "logs" / f"{name}.log"
    raw.unlink(missing_ok=True)
    cmd = [PYTHON, str(HERE / "loadpath_case.py"), "--json", str(raw), "--", demo, "--method", method, *options,
           "--out", str(out / "runs" / name), "--quiet",
           *(() if line_search == DEFAULT_LINE_SEARCH else ("-tmc_snes_linesearch_type", line_search))]
    print(f"[loadpath] {name}: {' '.join(options)}", flush=True)
    start = time.perf_counter()
    with open(log, "w") as f:
        code = subprocess.call(cmd, stdout=f, stderr=subprocess.STDOUT, env=mpi_launcher.job_environment(OMP_NUM_THREADS="1"))
    if code != 0 or not raw.exists():
        raise RuntimeError(f"load-path process {name} failed (exit code {code}); see {log}")
    record = {**json.loads(raw.read_text()), "example": example, "line_search": line_search}
    print(f"[loadpath] {name}: {time.perf_counter() - start:.1f} s, load {record['load']:.3g}, "
          f"{record['newton_iterations']} Newton its", flush=True)
    return record


def per_iteration_ms(r: dict) -> dict[str, float]:
    """The solve's time per Newton iteration, split into disjoint parts (ms)."""
    w = r["wall_s"]
    its = max(r["newton_iterations"], 1)
    parts = {"tangent": w.get("tangent", 0.0),
             "residual": w.get("residual", 0.0) - w.get("injectivity", 0.0),
             "factor_solve": r["linear_solve_s"],
             "checks": w.get("injectivity", 0.0) + w.get("gap", 0.0),
             "output": w.get("output", 0.0) + w.get("output_final", 0.0)}
    parts["other"] = r["solve_s"] - sum(parts.values())
    return {k: 1e3 * v / its for k, v in parts.items()}


def residuals_per_iteration(r: dict) -> dict[str, float]:
    """Residual evaluations per Newton iteration: all of them, and those SNES asked for."""
    its = max(r["newton_iterations"], 1)
    return {"all": r["calls"].get("residual", 0) / its, "snes": r["calls"].get("residual_snes", 0) / its}


def ratios(records: typing.Sequence[dict]) -> dict[str, dict[str, float]]:
    """SFVEM / FEM per example and line search: solve time, peak memory, tangent per unknown."""
    by = {(r["example"], r["line_search"], r["method"]): r for r in records}
    out = {}
    for (example, ls, method), vem in by.items():
        fem = by.get((example, ls, "fem"))
        if method != "vem" or fem is None:
            continue
        tangent = [r["wall_s"].get("tangent", 0.0) / max(r["calls"].get("tangent", 1), 1) / r["unknowns"]
                   for r in (vem, fem)]
        out[f"{example}/{ls}"] = {"solve_time": vem["solve_s"] / fem["solve_s"],
                                  "peak_memory": vem["peak_rss_mb"] / fem["peak_rss_mb"],
                                  "tangent_per_unknown": tangent[0] / tangent[1],
                                  "unknowns": vem["unknowns"] / fem["unknowns"]}
    return out


def table_rows(records: typing.Sequence[dict]) -> list[tuple[str, ...]]:
    r_of = ratios(records)
    rows = []
    for r in records:
        it = per_iteration_ms(r)
        ratio = r_of.get(f"{r['example']}/{r['line_search']}") if r["method"] == "vem" else None
        rows.append((r["example"], r["method"], r["line_search"], str(r["unknowns"]),
                     f"{r['load']:.3g}" + ("" if r["converged"] else " (stopped)"),
                     str(r["newton_iterations"]), f"{residuals_per_iteration(r)['snes']:.2f}",
                     " / ".join(f"{it[k]:.1f}" for k in ("tangent", "residual", "factor_solve", "checks", "output",
                                                         "other")),
                     f"{r['solve_s']:.1f}", f"{r['setup_s']:.1f}", f"{r['peak_rss_mb']:.0f}",
                     f"{ratio['solve_time']:.2f}" if ratio else "", f"{ratio['peak_memory']:.2f}" if ratio else ""))
    return rows


def markdown(records: typing.Sequence[dict], machine: dict) -> str:
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "---:|" * len(HEADER)]
    lines += ["| " + " | ".join(row) + " |" for row in table_rows(records)]
    per_ls: dict[str, list[float]] = {}
    for r in records:
        per_ls.setdefault(r["line_search"], []).append(residuals_per_iteration(r)["snes"])
    notes = ["- residuals per Newton iteration (SNES), mean over the runs: "
             + ", ".join(f"`{ls}` {sum(v) / len(v):.2f}" for ls, v in per_ls.items()),
             "- residuals/it: the residuals SNES evaluates (Newton + line search) per Newton iteration; "
             "the final diagnostics and the reactions of a converged state reuse SNES's last one",
             "- per it: the solve's time per Newton iteration (failed attempts included): tangent assembly, "
             "residual assembly (all of them, guard excluded), MUMPS factorization (LDL^T by default) + solve, checks (folded-"
             "element guard on every residual + gap per converged state), output (XDMF, checkpoint, summary, "
             "CSV per step; pictures at the end), other (SNES, vectors, Python)",
             "- solve s: `problem.solve` from start to return (numba compilation excluded by a first assembly "
             "before it); set-up s: mesh + discretization; peak MB: peak resident set size of the process",
             f"- machine: {machine['cpu']}, load average before/after {machine['load_before']} / "
             f"{machine['load_after']} (shared: ratios within one run are what counts)"]
    return "\n".join(lines) + "\n\n" + "\n".join(notes) + "\n"


def parse_args(argv: typing.Sequence[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="coarse meshes (about a minute per example)")
    p.add_argument("--examples", nargs="+", choices=tuple(EXAMPLES), default=list(EXAMPLES))
    p.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS))
    p.add_argument("--line-search", nargs="+", default=[DEFAULT_LINE_SEARCH],
                   help=f"PETSc line-search types, one run each; {DEFAULT_LINE_SEARCH!r}: the solver's default "
                        "policy (bt, l2 when a solve fails with it; default %(default)s)")
    p.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out") / "loadpath")
    p.add_argument("--results", type=pathlib.Path, default=None,
                   help="also copy loadpath.json and loadpath.md into this directory (e.g. bench)")
    return p.parse_args(argv)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    for sub in ("raw", "logs", "runs"):
        (args.out / sub).mkdir(parents=True, exist_ok=True)
    load_before = [round(x, 2) for x in os.getloadavg()]
    records = [run_case(args.out, e, m, ls, args.quick)
               for e in args.examples for ls in args.line_search for m in args.methods]
    with open("/proc/cpuinfo") as f:
        cpu = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), "unknown")
    machine = {"cpu": cpu, "load_before": load_before, "load_after": [round(x, 2) for x in os.getloadavg()]}
    results = {"quick": args.quick, "machine": machine, "ratios_vem_over_fem": ratios(records),
               "per_iteration_ms": {f"{r['example']}/{r['method']}/{r['line_search']}": per_iteration_ms(r)
                                    for r in records},
               "runs": records}
    (args.out / "loadpath.json").write_text(json.dumps(results, indent=1) + "\n")
    (args.out / "loadpath.md").write_text(markdown(records, machine))
    print(markdown(records, machine), flush=True)
    if args.results is not None:
        for name in ("loadpath.json", "loadpath.md"):
            shutil.copy(args.out / name, args.results / name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
