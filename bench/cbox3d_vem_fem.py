"""The 3D C-box with the SFVEM and with Q2 FEM on the same hexahedral grids: reactions, gaps, cost.

Usage::

    python3 bench/cbox3d_vem_fem.py [--cases GRID:METHOD:SCALE:STEPS[:patch=S|end][:alpha_r=A] ...] [--out DIR] [--results DIR]
    python3 bench/cbox3d_vem_fem.py --results bench      # the measured cases

Every case builds ``demos/cbox3d.py``'s problem (:func:`cbox3d.build`) on the ``NXxNYxNZ`` grid of
hexahedra (``--cell hexahedron``: Q2 for ``fem``; for ``vem`` the same cells read as polyhedra,
whose SFVEM unknowns are exactly Q2's), point contact, the corner's displacement times ``SCALE``
(with ``patch=S``: the ``--load-patch`` square of side S at the corner, with ``patch=end`` the
upper beam's end face (``--load-end``), each a finite reaction where the
corner alone has none in 3D; docs/notes/2026-11-26-cbox3d-tet-hex.md) reached in ``STEPS`` load steps (adaptive, as the demo), the Hu-Hu regularization (the demo's
default, the rotation regularization, compiles for minutes in 3D), gamma the demo's default (1e-5),
alpha_r the demo's (10) unless ``alpha_r=A`` (0: the neo-Hookean medium alone), and solves it in this process, one case after the other. The default cases
(measured 2026-11-26 in about 50 min on 2 shared cores, kept in bench/cbox3d_vem_fem.{json,md},
discussed in docs/notes/2026-11-26-sfvem-3d-cbox.md): both methods at a quarter of the load in 2
steps on the grids 20x1x7, 20x2x7, 20x4x7, 40x2x14 and 40x4x14 (their grid lines resolve the C's
wall: x = 0.1, z = 0.1, z = 0.6), and at the full load in 10 steps on 20x1x7.

Writes ``DIR/cbox3d_vem_fem.json`` (every case, appended as it finishes: an interrupted run keeps
its cases and a rerun skips them) and ``DIR/cbox3d_vem_fem.md``: per grid and load both methods'
corner reaction R (the internal force at the moved corner, [R_x, R_y, R_z]), the relative difference
|R_vem - R_fem| / |R_fem| (and of R_z alone), the smallest gap over the converged steps and the
relative difference of its closure (initial gap less gap), Newton iterations and the
wall time per Newton iteration (the steps' wall time over their iterations: assembly, solve,
contact checks); then every case's gap at each converged step. ``--results DIR`` copies both there.
Timings are as measured on the machine's state at the time (shared by other jobs), never asserted.
"""
from __future__ import annotations

import argparse
import json
import math
import pathlib
import sys
import time
import typing

import numpy as np
from mpi4py import MPI

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent / "demos"))
import cbox3d  # noqa: E402
from dolfinx_sfvem.meshing.benchmarks3d import CBOX3D_H, CBOX3D_T  # noqa: E402
from dolfinx_sfvem.output.run_summary import RunSummary  # noqa: E402
from case_store import CaseStore, machine  # noqa: E402

#: the initial gap between the beams (height less two walls)
GAP0 = CBOX3D_H - 2 * CBOX3D_T
#: GRID:METHOD:SCALE:STEPS of the default run
DEFAULT_CASES = tuple(f"{grid}:{method}:{load}" for grid, load in
                      (("20x1x7", "0.25:2"), ("20x2x7", "0.25:2"), ("20x4x7", "0.25:2"), ("40x2x14", "0.25:2"),
                       ("40x4x14", "0.25:2"), ("20x1x7", "1:10")) for method in ("fem", "vem"))


def run_case(grid: str, method: str, scale: float, steps: int, patch: float | str | None = None,
             alpha_r: float | None = None) -> dict:
    """Build and solve one case in this process (MPI.COMM_SELF); its record."""
    argv = ["--n", *grid.split("x"), "--cell", "hexahedron", "--contact", "point", "--scale", str(scale),
            "--steps", str(steps), "--regularization", "huhu", "--method", method, "--quiet"]
    if patch == "end":
        argv += ["--load-end"]
    elif patch is not None:
        argv += ["--load-patch", str(patch)]
    if alpha_r is not None:
        argv += ["--alpha-r", str(alpha_r)]
    args = cbox3d.common.parse_args(cbox3d.make_parser(), argv)
    t0 = time.perf_counter()
    problem, _ = cbox3d.build(args, MPI.COMM_SELF)
    setup_s = time.perf_counter() - t0
    result = problem.solve(control=cbox3d.common.load_stepping(args))
    run = RunSummary.from_dict(result.summary)
    converged = run.converged_steps
    gaps = [[s.load, s.gap["value"] if s.gap else None] for s in converged]
    newton = run.newton_iterations
    step_time = sum(s.wall_time_s for s in run.steps)
    final = run.final_step
    return {"grid": grid, "method": method, "scale": scale, "steps": steps, "patch": patch,
            "alpha_r": alpha_r, "unknowns": run.dofs,
            "converged": run.converged, "load": run.load_reached, "message": run.message,
            "R": final.reaction["load"] if final else None, "R_clamp": final.reaction["clamp"] if final else None,
            "gaps": gaps, "min_gap": min((g for _, g in gaps if g is not None), default=None),
            "min_J": min((s.min_J for s in converged if s.min_J is not None), default=None),
            "newton": newton, "setup_s": setup_s, "solve_s": result.wall_time_s,
            "s_per_newton": step_time / newton if newton else None}


def _loading(record: dict) -> tuple[str, float, int, float | None, float | None]:
    """(grid, scale, steps, patch, alpha_r) of a record: the cases whose two methods are compared."""
    return record["grid"], record["scale"], record["steps"], record.get("patch"), record.get("alpha_r")


def _patch(patch: float | str | None) -> str:
    return "corner" if patch is None else "end face" if patch == "end" else f"{patch:g} patch"


def _patch_order(patch: float | str | None) -> tuple[int, float]:
    return (0, 0.0) if patch is None else (2, 0.0) if patch == "end" else (1, patch)


def _alpha(alpha_r: float | None) -> str:
    return "10 (demo)" if alpha_r is None else f"{alpha_r:g}"


def _vector(v: typing.Sequence[float] | None) -> str:
    return "-" if v is None else "(" + ", ".join(f"{x:.3e}" for x in v) + ")"


def _number(v: float | None, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def comparison_rows(records: typing.Sequence[dict]) -> list[str]:
    """The markdown rows comparing the two methods on each grid and load that has both."""
    rows = []
    keys = sorted({_loading(r) for r in records},
                  key=lambda k: (_patch_order(k[3]), -1.0 if k[4] is None else k[4], k[1], k[2],
                                 [int(n) for n in k[0].split("x")]))
    for grid, scale, steps, patch, alpha_r in keys:
        by = {r["method"]: r for r in records if _loading(r) == (grid, scale, steps, patch, alpha_r)}
        if set(by) != {"vem", "fem"}:
            continue
        vem, fem = by["vem"], by["fem"]
        both = vem["R"] is not None and fem["R"] is not None and math.isclose(vem["load"], fem["load"])
        diff = (np.linalg.norm(np.subtract(vem["R"], fem["R"])) / np.linalg.norm(fem["R"])) if both else None
        diff_z = abs(vem["R"][2] - fem["R"][2]) / abs(fem["R"][2]) if both else None
        closure = [GAP0 - r["min_gap"] if r["min_gap"] is not None else None for r in (vem, fem)]
        diff_closure = abs(closure[0] - closure[1]) / closure[1] if both and None not in closure else None
        ratio = (vem["s_per_newton"] / fem["s_per_newton"]) if vem["s_per_newton"] and fem["s_per_newton"] else None
        rows.append(f"| {grid} | {_patch(patch)} | {_alpha(alpha_r)} | {scale:g} | {vem['unknowns']} | {_vector(vem['R'])} | {_vector(fem['R'])} | "
                    f"{_number(diff, '.2%')} | {_number(diff_z, '.2%')} | {_number(vem['min_gap'], '.4f')} | "
                    f"{_number(fem['min_gap'], '.4f')} | {_number(diff_closure, '.2%')} | "
                    f"{vem['newton']} / {fem['newton']} | {_number(vem['s_per_newton'], '.1f')} / "
                    f"{_number(fem['s_per_newton'], '.1f')} | {_number(ratio, '.1f')} |")
    return rows


def markdown(records: typing.Sequence[dict], machine: str) -> str:
    """The comparison table, then every case's gaps over its load path."""
    lines = ["# 3D C-box: SFVEM and Q2 FEM on the same hexahedral grids (bench/cbox3d_vem_fem.py)", "",
             "Point contact, the corner (or a patch at it, or the upper beam's end face: 'moved') displaced by (0, 0.25, -1) x scale, Hu-Hu "
             f"regularization of weight alpha_r (0: none), gamma 1e-5; {machine}. R: the internal force at the moved nodes at the last converged step; "
             "difference: |R_vem - R_fem| / |R_fem| (both at the same load), R_z: the same of R_z alone; gap: the "
             "smallest over the converged steps; closure: the relative difference of the gap's closure "
             f"{GAP0:g} - gap; s/it: the steps' wall time per Newton iteration (machine shared with other jobs).", "",
             "| grid | moved | alpha_r | scale | unknowns | R SFVEM | R Q2 | difference | R_z | gap SFVEM | gap Q2 | closure | "
             "Newton SFVEM / Q2 | s/it SFVEM / Q2 | ratio |",
             "|---|---|---:|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    lines += comparison_rows(records)
    lines += ["", "Every case: load reached, steps, smallest det F, and the smallest gap at each converged step "
              "(load: gap).", "",
              "| grid | moved | alpha_r | method | scale | unknowns | load reached | Newton | min J | gaps |",
              "|---|---|---:|---|---:|---:|---:|---:|---:|---|"]
    for r in records:
        gaps = ", ".join(f"{load:.3g}: {_number(g, '.4f')}" for load, g in r["gaps"])
        lines.append(f"| {r['grid']} | {_patch(r.get('patch'))} | {_alpha(r.get('alpha_r'))} | {r['method']} | {r['scale']:g} | {r['unknowns']} | {r['load']:.3g} | "
                     f"{r['newton']} | {_number(r['min_J'], '.3g')} | {gaps} |")
    return "\n".join(lines) + "\n"


def parse_args(argv: typing.Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(DEFAULT_CASES), help="NXxNYxNZ:METHOD:SCALE:STEPS[:patch=S|end][:alpha_r=A]")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/cbox3d_vem_fem"))
    parser.add_argument("--results", type=pathlib.Path, default=None)
    return parser.parse_args(argv)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    store = CaseStore(args.out, "cbox3d_vem_fem")
    done = {(r["grid"], r["method"], r["scale"], r["steps"], r.get("patch"), r.get("alpha_r")) for r in store.records}
    for case in args.cases:
        grid, method, scale, steps, *options = case.split(":")
        named = dict(option.split("=") for option in options)
        if not set(named) <= {"patch", "alpha_r"}:
            raise SystemExit(f"{case}: options after STEPS are patch=S (or patch=end) and alpha_r=A")
        patch = named.get("patch")
        key = (grid, method, float(scale), int(steps), patch if patch in (None, "end") else float(patch),
               float(named["alpha_r"]) if "alpha_r" in named else None)
        if key in done:
            continue
        record = run_case(*key)
        print(case, json.dumps(record), flush=True)
        store.add(record)
    store.write(markdown(store.records, machine()), args.results)
    return 0

if __name__ == "__main__":
    sys.exit(main())
