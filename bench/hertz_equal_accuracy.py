"""Equal accuracy on the 3D Hertz sphere: the SFVEM on the octree block against P2 on graded and on
uniform tetrahedra (issue 31 item 6).

Usage::

    python3 bench/hertz_equal_accuracy.py [--cases NAME ...] [--out DIR] [--results DIR]
    python3 bench/hertz_equal_accuracy.py --results bench      # the measured cases

Every case runs ``demos/hertz3d.py`` to the full load (indent 0.04, gamma 1e-5, the demo's
rotation regularization with alpha_r 1, 20 load steps, 1 rank) in a child process, one after the
other, and reads the last state from the child's ``hertz3d.json``. The cases (:data:`CASES`):

- ``octree-H-C``: the SFVEM on :func:`~dolfinx_sfvem.meshing.benchmarks3d.hertz3d_octree` (the block's
  cubes of the largest size 2^-k within the size field, ``--h H --h-core C``, tetrahedra in the
  medium and the sphere);
- ``graded-H-C``: P2 on :func:`~dolfinx_sfvem.meshing.benchmarks3d.hertz3d`'s tetrahedra graded by gmsh
  toward the contact (size H within 0.5 of it, C within 0.25, 0.4 far);
- ``uniform-H``: P2 on tetrahedra of size H everywhere.

Writes ``DIR/hertz_equal_accuracy.json`` (every case, appended as it finishes; a rerun skips the
cases already there) and ``DIR/hertz_equal_accuracy.md``: per case the unknowns, Newton iterations
(converged steps, and of failed attempts), wall time, the child's peak memory (its maximum resident
set, from ``wait4``), and the errors against Hertz at the full load: the peak pressure p_max / p0
the radius from the pressure's second moment within 2 a, a_m / a_H, the radius from the nodal
forces' second moment within 2 a, a_F / a_H (no recovered pressure in between), and Hertz's
ellipse fitted to the block-top pressure, p0_fit / p0 and a_fit / a_H (with the zone's a_zone / a_H
for reference). Timings are the machine's at the time, never asserted.
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import subprocess
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent
DEMO = HERE.parent / "demos" / "hertz3d.py"
sys.path.insert(0, str(HERE))
from case_store import CaseStore, machine  # noqa: E402

#: the demo's options shared by every case
COMMON = ("--gamma", "1e-5", "--indent", "0.04", "--steps", "20")
#: name -> the demo's mesh and method options
CASES = {
    "octree-0.2-0.1": ("--method", "vem", "--block", "octree", "--h", "0.2", "--h-core", "0.1"),
    "graded-0.2-0.1": ("--h", "0.2", "--h-core", "0.1"),
    "graded-0.1-0.05": ("--h", "0.1", "--h-core", "0.05"),
    "graded-0.1-0.03": ("--h", "0.1", "--h-core", "0.03"),
    "uniform-0.2": ("--h", "0.2", "--h-far", "0.2", "--h-core", "0"),
}


def run_case(name: str, work: pathlib.Path) -> dict:
    """Run one case's demo in a child process; its record (``error`` set if the demo failed)."""
    out = work / name
    command = [sys.executable, str(DEMO), *CASES[name], *COMMON, "--out", str(out)]
    start = time.perf_counter()
    with open(work / f"{name}.log", "w") as log:
        child = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT)
        _, status, usage = os.wait4(child.pid, 0)
    record = {"case": name, "options": list(CASES[name]), "wall_s": time.perf_counter() - start,
              "peak_rss_gb": usage.ru_maxrss / 2 ** 20, "exit_status": os.waitstatus_to_exitcode(status)}
    summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else {}
    record.update(dofs=summary.get("dofs"), message=summary.get("message"), converged=summary.get("converged"))
    steps = summary.get("steps", [])
    record["newton"] = sum(s["newton_iterations"] for s in steps if s.get("converged", True))
    record["newton_failed"] = sum(s["newton_iterations"] for s in steps if not s.get("converged", True))
    record["min_gap"] = min((s["gap"]["value"] for s in steps if s.get("converged", True) and s.get("gap")),
                            default=None)
    if (out / "hertz3d.json").exists():
        result = json.loads((out / "hertz3d.json").read_text())
        if result["rows"]:
            row, last = result["rows"][-1], result["last"]
            record.update(load=row["load"], F=row["F"], p_ratio=row["p_max"] / row["p0_H"],
                          a_m_ratio=last["a_m"] / row["a_H"], a_m_H_ratio=last["a_m_H"] / row["a_H"],
                          a_F_ratio=last["a_F"] / row["a_H"],
                          a_fit_ratio=last["a_fit"] / row["a_H"], p0_fit_ratio=last["p0_fit"] / row["p0_H"],
                          a_zone_ratio=row["a_zone"] / row["a_H"],
                          a_H=row["a_H"], gap=row["gap"])
    return record


def table(records: list[dict]) -> str:
    """The Markdown table of the records."""
    lines = ["# Equal accuracy on the 3D Hertz sphere (bench/hertz_equal_accuracy.py)", "",
             f"Machine: {machine()}, 1 rank per case, one case at a time. gamma 1e-5, indent 0.04 (Hertz's a "
             "about 0.217 at the full load), 20 load steps. Errors at the last converged state against Hertz at "
             "its force: the nodal peak p_max / p0, the radius from the pressure's second moment within 2 a (a_m; "
             "'on nodes': what Hertz's own profile gives on the same nodes), the radius from the nodal forces' second "
             "moment within 2 a (a_F: no recovered pressure in between), Hertz's ellipse fitted to the "
             "nodes above 30 % of the peak (p0_fit, a_fit), the zone's a_zone for reference. Gaps: the block's "
             "smallest gap at the last state, and the smallest gap between any two bodies over the converged "
             "steps (negative: a node within the overlap tolerance inside the other body).", "",
             "| case | unknowns | load | Newton (failed) | wall | peak memory | p_max/p0 | a_m/a_H (on nodes) "
             "| a_F/a_H | p0_fit/p0 | a_fit/a_H | a_zone/a_H | block's gap | smallest gap |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in records:
        if "p_ratio" not in r:
            lines.append(f"| {r['case']} | {r['dofs']} | no contact | {r['newton']} ({r['newton_failed']}) "
                         f"| {r['wall_s'] / 60:.1f} min | {r['peak_rss_gb']:.2f} GB | | | | | | | | {r['message']} |")
            continue
        lines.append(f"| {r['case']} | {r['dofs']:,} | {r['load']:.3g} | {r['newton']} ({r['newton_failed']}) "
                     f"| {r['wall_s'] / 60:.1f} min | {r['peak_rss_gb']:.2f} GB | {r['p_ratio']:.3f} "
                     f"| {r['a_m_ratio']:.3f} ({r['a_m_H_ratio']:.3f}) | {r['a_F_ratio']:.3f} | {r['p0_fit_ratio']:.3f} "
                     f"| {r['a_fit_ratio']:.3f} "
                     f"| {r['a_zone_ratio']:.3f} | {r['gap']:.2e} | {r['min_gap']:.2e} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", nargs="+", choices=tuple(CASES), default=tuple(CASES))
    p.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/hertz_equal_accuracy"))
    p.add_argument("--results", type=pathlib.Path, default=None, help="copy the JSON and the table here")
    args = p.parse_args()
    store = CaseStore(args.out, "hertz_equal_accuracy")
    done = {r["case"] for r in store.records}
    for name in args.cases:
        if name in done:
            continue
        print(f"{name}: {' '.join(CASES[name])}", flush=True)
        store.add(run_case(name, args.out))
        r = store.records[-1]
        print(f"  {r['dofs']} unknowns, {r['newton']} Newton iterations, {r['wall_s'] / 60:.1f} min, "
              f"{r['peak_rss_gb']:.2f} GB, p_max/p0 {r.get('p_ratio', float('nan')):.3f}, "
              f"a_m/a_H {r.get('a_m_ratio', float('nan')):.3f}, a_F/a_H {r.get('a_F_ratio', float('nan')):.3f}", flush=True)
    store.write(table(store.records), args.results)


if __name__ == "__main__":
    main()
