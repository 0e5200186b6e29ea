"""Rates of the P2 FEM on the thick sphere (issue 44 item 5): straight-sided against curved
(degree-2 geometry) tetrahedra, L2 and H1 errors over the wall against the exact radial field.

The 1/8 shell 1 < R < 2 of ``demos/thick_sphere.py`` (K = 5/3, mu = 1, its symmetry conditions),
meshed by gmsh at each ``--h`` with ``order=1`` (flat faces, edge nodes on the chords) and
``order=2`` (gmsh's second order: edge nodes on the spheres), loaded on the inner sphere by a
dead pressure

- ``lame``: p = 2e-7 in one step, against Lamé (``exact.lame_sphere``; the finite-strain answer
  differs by O(p) relative);
- ``finite``: p = 0.2 in ``--steps`` steps, against the radial boundary value problem
  (``exact.thick_sphere(..., follower=False)``: u_r(a) = 0.064).

Measured per mesh: the relative errors ``||u - u_h|| / ||u||`` (L2) and ``|u - u_h|_H1 / |u|_H1``
over the discrete wall (``Discretization.error_norms``: a degree-8 rule on the curved cells, the
exact field ``exact.radial_field`` at the quadrature points' reference positions), and, as the
earlier measure, the signed mean and the largest relative error of u_r at the vertices on R = a.
Orders between consecutive meshes in h = (exact wall volume / cells)^(1/3).

Usage: ``python bench/thick_sphere_rates.py [--h 0.4 0.25 0.2 0.15 0.12] [--cases lame finite]
[--orders 1 2]``; writes bench/thick_sphere_rates.json (a case run again replaces its rows) and
bench/thick_sphere_rates.md.
"""
from __future__ import annotations

import argparse
import json
import math
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "demos")]

import thick_sphere as demo  # noqa: E402
from dolfinx_sfvem import exact  # noqa: E402
from dolfinx_sfvem.output.run_summary import RunSummary  # noqa: E402

#: the exact wall volume of the 1/8 shell
WALL_VOLUME = math.pi / 6 * (demo.B_OUT ** 3 - demo.A_IN ** 3)
#: case -> (pressure, compared with Lamé)
CASES = {"lame": (demo.SMALL * demo.P_REF, True), "finite": (demo.P_REF, False)}
H = (0.4, 0.25, 0.2, 0.15, 0.12)
OUT = pathlib.Path(__file__).with_name("thick_sphere_rates.json")


def exact_solution(case: str) -> exact.LameSolution | exact.RadialSolution:
    """The exact radial solution of ``case`` (dead pressure)."""
    p, lame = CASES[case]
    solution = exact.thick_sphere(demo.A_IN, demo.B_OUT, demo.K, demo.MU, p, follower=False)
    return solution.lame if lame else solution


def inner_vertex_errors(problem, u_r_exact: float) -> tuple[float, float]:
    """(signed mean, largest) relative error of u_r at the mesh vertices on R = a (serial)."""
    disc = problem.disc
    X = disc.x_nodes[:disc.n_owned_nodes]
    vertex = (np.abs(np.linalg.norm(X, axis=1) - demo.A_IN) < 1e-9) & (disc.node_point[:disc.n_owned_nodes] >= 0)
    _, u = disc.get_state(problem.x)
    u_r = np.einsum("ij,ij->i", u[vertex], X[vertex]) / demo.A_IN
    return float(u_r.mean() / u_r_exact - 1), float(np.abs(u_r - u_r_exact).max() / u_r_exact)


def run(case: str, order: int, h: float, steps: int = 2) -> dict:
    """One mesh of one case: cells, unknowns, h, the relative L2 and H1 errors, the inner vertices'
    u_r errors, Newton iterations and seconds."""
    t0 = time.perf_counter()
    p, lame = CASES[case]
    args = demo.make_parser().parse_args(["--order", str(order), "--quiet"])
    problem = demo.build("dead", p, h, args)
    summary = RunSummary.from_dict(problem.solve(1 if lame else steps).summary)
    solution = exact_solution(case)
    u_exact, grad_exact = exact.radial_field(solution)
    e0, e1 = problem.disc.error_norms(problem.x, u_exact, grad_exact)
    zero = problem.disc.create_vector()
    zero.set(0.0)
    n0, n1 = problem.disc.error_norms(zero, u_exact, grad_exact)
    zero.destroy()
    mean, largest = inner_vertex_errors(problem, solution.inner_radius_change)
    cells = problem.disc.output_mesh.n_cells
    return {"case": case, "order": order, "h_requested": h, "cells": cells, "unknowns": summary.dofs,
            "h": (WALL_VOLUME / cells) ** (1 / 3), "L2": e0 / n0, "H1": e1 / n1, "u_r_mean": mean,
            "u_r_largest": largest, "newton": summary.newton_iterations,
            "converged": summary.converged, "seconds": round(time.perf_counter() - t0, 1)}


def orders(rows: list[dict], key: str) -> list[str]:
    """Observed orders of |rows[key]| between consecutive rows in h ("" for the first)."""
    e, h = np.abs([r[key] for r in rows]), np.array([r["h"] for r in rows])
    return [""] + [f"{math.log(e[i] / e[i + 1]) / math.log(h[i] / h[i + 1]):.2f}" for i in range(len(rows) - 1)]


def markdown(rows: list[dict]) -> str:
    """The table of all rows, grouped by case and order."""
    lines = ["# Thick sphere, P2 FEM: straight-sided vs curved tetrahedra", "",
             "Written by `bench/thick_sphere_rates.py` (1/8 shell 1 < R < 2, K = 5/3, mu = 1, dead pressure; "
             "`lame`: p = 2e-7 against Lamé, `finite`: p = 0.2 against the radial BVP). L2, H1: relative errors "
             "over the wall; u_r(a): signed mean and largest relative error at the inner sphere's vertices; "
             "orders in h = (wall volume / cells)^(1/3). Discussion: docs/notes/2026-12-07-curved-geometry.md.", "",
             "| case | geometry | cells | unknowns | h | L2 error | order | H1 error | order | u_r(a) mean | order "
             "| u_r(a) largest | Newton | s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for case in CASES:
        for order in (1, 2):
            group = sorted((r for r in rows if r["case"] == case and r["order"] == order), key=lambda r: -r["h"])
            if not group:
                continue
            rate = {key: orders(group, key) for key in ("L2", "H1", "u_r_mean")}
            for i, r in enumerate(group):
                geometry = "curved" if order == 2 else "straight"
                lines.append(f"| {case} | {geometry} | {r['cells']} | {r['unknowns']} | {r['h']:.4f} | "
                             f"{r['L2']:.3e} | {rate['L2'][i]} | {r['H1']:.3e} | {rate['H1'][i]} | "
                             f"{r['u_r_mean']:+.2e} | {rate['u_r_mean'][i]} | {r['u_r_largest']:.2e} | "
                             f"{r['newton']} | {r['seconds']:.0f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--h", type=float, nargs="+", default=list(H), help="gmsh's largest cell sizes")
    parser.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    parser.add_argument("--orders", type=int, nargs="+", choices=(1, 2), default=[1, 2])
    parser.add_argument("--steps", type=int, default=2, help="load steps of the finite case")
    parser.add_argument("--out", type=pathlib.Path, default=OUT)
    args = parser.parse_args()
    rows = json.loads(args.out.read_text()) if args.out.exists() else []
    for case in args.cases:
        for order in args.orders:
            rows = [r for r in rows if (r["case"], r["order"]) != (case, order)]
            for h in args.h:
                rows.append(run(case, order, h, args.steps))
                print(json.dumps(rows[-1]), flush=True)
                args.out.write_text(json.dumps(rows, indent=1) + "\n")
    args.out.with_suffix(".md").write_text(markdown(rows))
    print(markdown(rows))


if __name__ == "__main__":
    main()
